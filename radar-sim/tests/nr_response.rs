//! The measured response of each reference under the default NR cell (`psf::reference_responses`):
//! range and along-track −3 dB widths against their predictions, the peak sidelobe and the comb
//! alias of the range profile (a −13.3 dB sinc and no alias once the PRS's staggering cycle is
//! complete); a pulse of one comb-4 PRS symbol keeps the alias at full height.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use radar_sim::config::NrConfig;
use radar_sim::nr::Reference;
use radar_sim::psf::{default_cases, reference_responses};

#[test]
fn each_reference_resolves_as_predicted_and_a_single_comb_symbol_aliases() {
    let params = planner::Params::default();
    let case = &default_cases()[0];
    let full = reference_responses(&params, case, &NrConfig::default()).unwrap();
    let one = NrConfig {
        pulse_symbols: 1,
        ..NrConfig::default()
    };
    let single = reference_responses(&params, case, &one).unwrap();
    for r in full.iter().chain(&single) {
        let c = &r.cell;
        println!(
            "{:?} ({} symbols): range {:.3} m (predicted {:.3}), along-track {:.3} m (predicted {:.3}), peak sidelobe {:.1} dB, alias at N/4 {:.1} dB",
            r.reference,
            r.pulse_symbols,
            c.range_width_m,
            c.range_width_pred_m,
            c.along_track_width_m,
            c.along_track_width_pred_m,
            r.levels.peak_sidelobe_db,
            r.levels.alias_db
        );
    }
    for r in &full {
        let c = &r.cell;
        assert!(
            (c.range_width_m / c.range_width_pred_m - 1.0).abs() < 0.05,
            "{:?}: {} vs {}",
            r.reference,
            c.range_width_m,
            c.range_width_pred_m
        );
        assert!((c.along_track_width_m / c.along_track_width_pred_m - 1.0).abs() < 0.05);
        // every subcarrier evenly once the staggering cycle is complete: the unweighted sinc's
        // −13.3 dB sidelobes, and no alias
        assert!(
            (r.levels.peak_sidelobe_db + 13.3).abs() < 0.5,
            "{:?}: {}",
            r.reference,
            r.levels.peak_sidelobe_db
        );
        assert!(
            r.levels.alias_db < -40.0,
            "{:?}: {}",
            r.reference,
            r.levels.alias_db
        );
    }
    let pilots = single
        .iter()
        .find(|r| r.reference == Reference::Pilots)
        .unwrap();
    assert!(pilots.levels.alias_db > -1.0, "{}", pilots.levels.alias_db);
}
