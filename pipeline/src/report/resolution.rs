//! The resolution report (`cellsar-radar-sim resolution`): radar-sim measures each case
//! ([`radar_sim::psf::measure_case`]); this writes `RESOLUTION.md` (the table), `resolution.json`
//! (the rows) and one drawing per case (`psf_<B>MHz_<k>.svg`: the measured −3 dB region and the
//! predicted cell, drawn with plotters). Under the table, the measured response of each
//! reference mode (`ideal`, `pilots`, `reconstructed`) under the default NR cell
//! ([`radar_sim::psf::reference_responses`]) against its prediction, also in `references.json`.

use std::path::Path;

use plotters::prelude::*;
use radar_sim::config::NrConfig;
use radar_sim::io::{write_bytes, write_json};
use radar_sim::psf::{
    measure_case, params_at, reference_responses, PsfCase, ReferenceResponse, ReportRow,
    SINC_PEAK_SIDELOBE_DB,
};
use radar_sim::resolution::CellReport;
use radar_sim::RadarError;

/// The table's heading and the text above it.
const HEADER: &str = "# Resolution report: measured point response vs the predicted cell\n\n\
Measured: the −3 dB region of one noise-free look (T_d = 1 s, 20 m/s, unweighted) traced in 40 \
directions through the peak. *range* and *along-track* are the region's extents along the range \
gradient g and along the Doppler gradient (the track); *cross-track* and *iso-range* are its \
chords along the iso-Doppler and iso-range lines (the sides of the parallelogram cell); *worst* \
is the longest chord in any measured direction (the predicted major axis among them), against \
the major axis of the −3 dB ellipse of the predicted range and along-track widths, which the \
parallelogram bounds (erratum 12 (docs/paper-notes.md)). Every width in the \
table is a −3 dB width, one definition for every pair: the predictions are the planner's \
`ResolutionCell` widths × 0.886 (the main-lobe factor of the unweighted response), and the \
paper's δ_r, δ_a are shown × 0.886 too. The last column is the planner's worst width without \
the factor (the 1/B, 1/T cell its `--resolution general` guarantee bounds by d_min); a Hann \
weighting (the main job's scene) would multiply every −3 dB width by 1.44 instead. Errors are \
measured/predicted − 1.\n\n\
| B / MHz | geometry | β / ° | ψ / ° | range (pred) / m | along-track (pred) / m | cross-track (pred) / m | iso-range (pred) / m | worst (pred) / m | max error | paper δ_r, δ_a × 0.886 / m | planner worst cell (no factor) / m |\n\
|---|---|---|---|---|---|---|---|---|---|---|---|\n";

/// The note under the table.
const FOOTER: &str =
    "\nAway from blind geometry the four principal widths and the worst width agree with the \
predictions; near \
blind (small ψ) the cell is long along the iso-range and iso-Doppler lines, and the gradients \
change over its length, so the linear prediction is only approximate there.\n";

/// Font sizes as plotters takes them (its SVG text comes out 1/1.24 of this: 14 and 12 px).
const TITLE_FONT_PX: f64 = 17.4;
/// See [`TITLE_FONT_PX`].
const LABEL_FONT_PX: f64 = 14.9;
/// Width of the drawing, px.
const WIDTH_PX: u32 = 480;
/// Margin around the chart, px.
const MARGIN_PX: u32 = 8;
/// Room for the x axis' labels under the chart, px.
const X_LABELS_PX: u32 = 36;
/// Room for the y axis' labels left of the chart, px.
const Y_LABELS_PX: u32 = 48;
/// Height of the chart's area: its plotting area is square (equal scales on equal ranges).
const PLOT_PX: u32 = WIDTH_PX - Y_LABELS_PX + X_LABELS_PX;
/// Height of the two title lines above the plot, px.
const TITLE_PX: u32 = 40;
/// Height of the note under the plot, px.
const NOTE_PX: u32 = 24;

/// Measures every case at every bandwidth and writes `resolution.json`, `RESOLUTION.md` (a
/// table: measured principal widths beside the predictions and the paper's δ_r, δ_a, all as
/// −3 dB widths, and the planner's worst cell without the factor) and one SVG per case
/// (`psf_<B>MHz_<k>.svg`: measured −3 dB region and predicted cell) into `out`, every file
/// atomically. `progress` gets (cases done, cases in all).
pub fn write_resolution_report(
    out: &Path,
    bandwidths_hz: &[f64],
    cases: &[PsfCase],
    progress: &mut dyn FnMut(u64, u64),
) -> radar_sim::Result<Vec<ReportRow>> {
    std::fs::create_dir_all(out).map_err(|e| RadarError::io(out, e))?;
    let total = (bandwidths_hz.len() * cases.len()) as u64;
    let mut rows = Vec::new();
    let mut md = String::from(HEADER);
    for &b in bandwidths_hz {
        let params = params_at(b);
        for (k, case) in cases.iter().enumerate() {
            let cell = measure_case(&params, case)?;
            md += &table_row(b, case, &cell);
            let path = out.join(format!("psf_{:.0}MHz_{k}.svg", b / 1e6));
            let title = format!("B = {:.0} MHz, {}", b / 1e6, case.label);
            let svg = cell_svg(&cell, &title)
                .map_err(|e| RadarError::io(&path, std::io::Error::other(format!("plot: {e}"))))?;
            write_bytes(&path, svg.as_bytes())?;
            rows.push(ReportRow {
                case: case.clone(),
                cell,
            });
            progress(rows.len() as u64, total);
        }
    }
    md += FOOTER;
    if let Some(case) = cases.first() {
        let nr = NrConfig::default();
        let mut refs = Vec::new();
        md += &references_header(case, &nr);
        for &b in bandwidths_hz {
            for r in reference_responses(&params_at(b), case, &nr)? {
                md += &reference_row(b, &r, nr.prs_comb);
                refs.push(ReferenceRow {
                    bandwidth_hz: b,
                    geometry: case.label.clone(),
                    response: r,
                });
            }
        }
        write_json(&out.join("references.json"), &refs)?;
    }
    write_bytes(&out.join("RESOLUTION.md"), md.as_bytes())?;
    write_json(&out.join("resolution.json"), &rows)?;
    Ok(rows)
}

/// One row of `references.json`: a reference mode's response at one bandwidth.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ReferenceRow {
    /// Bandwidth, Hz.
    pub bandwidth_hz: f64,
    /// The geometry's label.
    pub geometry: String,
    /// The measured response.
    pub response: ReferenceResponse,
}

/// The heading and text of the reference modes' table for `case` under the NR cell `nr`.
fn references_header(case: &PsfCase, nr: &NrConfig) -> String {
    format!(
        "\n## Reference modes under the default NR cell\n\n\
The geometry *{}* under the default `[radar.nr]` cell (μ = {}, a comb-{} PRS, {}-symbol pulses), \
the receiver's reference `ideal` (the transmitted grid), `pilots` (the reference signals alone, \
every other RE masked) or `reconstructed` (the pilots and the decoded data): one noise-free look \
with the direct path on and cancelled, unweighted, measured as above. Predicted: the cell's \
−3 dB widths (× 0.886), the unweighted sinc's {:.1} dB peak sidelobe, and, at the comb's alias \
N/{} from the peak, nothing (*none*: the reference covers every subcarrier over the pulse) or \
0 dB (a `pilots` pulse shorter than the PRS's staggering cycle).\n\n\
| B / MHz | reference | symbols per pulse | range (pred) / m | along-track (pred) / m | peak sidelobe (pred) / dB | alias at N/{} (pred) / dB |\n\
|---|---|---|---|---|---|---|\n",
        case.label,
        nr.numerology,
        nr.prs_comb,
        nr.pulse_symbols,
        SINC_PEAK_SIDELOBE_DB,
        nr.prs_comb,
        nr.prs_comb
    )
}

/// One line of the reference modes' table.
fn reference_row(b: f64, r: &ReferenceResponse, prs_comb: usize) -> String {
    let c = &r.cell;
    let alias_pred = match r.predicted_alias_db(prs_comb) {
        Some(db) => format!("{db:.1}"),
        None => "none".into(),
    };
    format!(
        "| {:.0} | {} | {} | {:.3} ({:.3}) | {:.3} ({:.3}) | {:.1} ({:.1}) | {:.1} ({}) |\n",
        b / 1e6,
        reference_name(r.reference),
        r.pulse_symbols,
        c.range_width_m,
        c.range_width_pred_m,
        c.along_track_width_m,
        c.along_track_width_pred_m,
        r.levels.peak_sidelobe_db,
        SINC_PEAK_SIDELOBE_DB,
        r.levels.alias_db,
        alias_pred
    )
}

/// The scene file's name of a reference mode.
fn reference_name(r: radar_sim::nr::Reference) -> &'static str {
    match r {
        radar_sim::nr::Reference::Ideal => "ideal",
        radar_sim::nr::Reference::Pilots => "pilots",
        radar_sim::nr::Reference::Reconstructed => "reconstructed",
    }
}

/// One line of the table for `cell`, measured at bandwidth `b` Hz.
fn table_row(b: f64, case: &PsfCase, cell: &CellReport) -> String {
    let max_err = cell
        .errors()
        .iter()
        .chain([cell.worst_width_error()].iter())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    format!(
        "| {:.0} | {} | {:.1} | {:.1} | {:.3} ({:.3}) | {:.3} ({:.3}) | {:.2} ({:.2}) | {:.2} ({:.2}) | {:.1} ({:.1}) | {:.1}% | {:.2}, {:.2} | {:.1} |\n",
        b / 1e6,
        case.label,
        cell.bistatic_angle_deg,
        cell.psi_deg,
        cell.range_width_m,
        cell.range_width_pred_m,
        cell.along_track_width_m,
        cell.along_track_width_pred_m,
        cell.cross_track_width_m,
        cell.cross_track_width_pred_m,
        cell.iso_range_width_m,
        cell.iso_range_width_pred_m,
        cell.worst_width_m,
        cell.worst_width_pred_m,
        100.0 * max_err,
        cell.mainlobe_factors[0] * cell.paper_range_m,
        cell.mainlobe_factors[1] * cell.paper_azimuth_m,
        cell.planner_worst_width_m,
    )
}

/// The drawing of one case: the measured −3 dB region (filled) and the predicted −3 dB
/// parallelogram (outline) in local coordinates around the peak, with the range gradient g
/// and the track (dashed), on equal axes.
pub fn cell_svg(cell: &CellReport, title: &str) -> Result<String, Box<dyn std::error::Error>> {
    let region = cell.local_boundary_m();
    let para = cell.predicted_cell_m();
    // the half-width of the view: the farthest point of either shape, and 15% more
    let ext = region
        .iter()
        .chain(para.iter())
        .map(|p| p[0].abs().max(p[1].abs()))
        .fold(1.0f64, f64::max)
        * 1.15;
    let [g, d] = cell.axes;
    let blue = RGBColor(0x4c, 0x72, 0xb0);
    let red = RGBColor(0xc4, 0x4e, 0x52);
    let mut text = String::new();
    {
        let size = (WIDTH_PX, TITLE_PX + PLOT_PX + NOTE_PX);
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        root.fill(&WHITE)?;
        root.draw(&Text::new(
            title,
            (8, 4),
            ("sans-serif", TITLE_FONT_PX).into_font(),
        ))?;
        root.draw(&Text::new(
            format!(
                "β = {:.1}°, ψ = {:.1}°; half-width of the view {ext:.1} m",
                cell.bistatic_angle_deg, cell.psi_deg
            ),
            (8, 22),
            ("sans-serif", LABEL_FONT_PX).into_font(),
        ))?;
        let (_, rest) = root.split_vertically(TITLE_PX);
        let (plot, note) = rest.split_vertically(PLOT_PX);
        let mut chart = ChartBuilder::on(&plot)
            .margin(MARGIN_PX)
            .x_label_area_size(X_LABELS_PX)
            .y_label_area_size(Y_LABELS_PX)
            .build_cartesian_2d(-ext..ext, -ext..ext)?;
        chart
            .configure_mesh()
            .x_desc("local x (m, east)")
            .y_desc("local y (m, north)")
            .x_labels(7)
            .y_labels(7)
            .label_style(("sans-serif", LABEL_FONT_PX))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        let pts =
            |ps: &[[f64; 2]]| -> Vec<(f64, f64)> { ps.iter().map(|p| (p[0], p[1])).collect() };
        chart.draw_series(std::iter::once(Polygon::new(
            pts(&region),
            blue.mix(0.45).filled(),
        )))?;
        let mut closed = pts(&region);
        closed.extend(closed.first().copied());
        chart.draw_series(LineSeries::new(closed, blue.stroke_width(1)))?;
        let mut outline = pts(&para);
        outline.extend(outline.first().copied());
        chart.draw_series(LineSeries::new(outline, red.stroke_width(1)))?;
        let mut ellipse = pts(&cell.predicted_ellipse_m(180));
        ellipse.extend(ellipse.first().copied());
        chart.draw_series(LineSeries::new(ellipse, red.stroke_width(2)))?;
        for (v, colour, label) in [
            (g, RGBColor(0x2a, 0x7f, 0x2a), "g"),
            (d, RGBColor(0x7f, 0x2a, 0x7f), "track"),
        ] {
            let tip = (v[0] * ext * 0.8, v[1] * ext * 0.8);
            chart.draw_series(DashedLineSeries::new(
                [(0.0, 0.0), tip],
                4,
                3,
                colour.stroke_width(1),
            ))?;
            chart.draw_series(std::iter::once(Text::new(
                label,
                tip,
                ("sans-serif", TITLE_FONT_PX).into_font().color(&colour),
            )))?;
        }
        note.draw(&Text::new(
            "filled: measured −3 dB region; red: predicted ellipse and parallelogram",
            (8, 4),
            ("sans-serif", LABEL_FONT_PX).into_font(),
        ))?;
        root.present()?;
    }
    Ok(text)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use radar_sim::resolution::PsfRegion;

    /// A cell whose measured region is the disc of radius 2 m around (10, 20) and whose
    /// predicted cell is the 4 m × 6 m rectangle along the axes.
    fn disc_cell() -> CellReport {
        let c = [10.0, 20.0];
        let disc = move |p: [f64; 2]| {
            let r = (p[0] - c[0]).hypot(p[1] - c[1]);
            if r < 2.0 {
                1.0
            } else {
                0.0
            }
        };
        let region = PsfRegion::measure(&disc, c, 36, &[], 0.1, 100.0).unwrap();
        CellReport {
            bandwidth_hz: 150e6,
            bistatic_angle_deg: 45.0,
            psi_deg: 90.0,
            range_width_m: 4.0,
            range_width_pred_m: 4.0,
            minor_width_pred_m: 3.0,
            along_track_width_m: 4.0,
            along_track_width_pred_m: 6.0,
            cross_track_width_m: 4.0,
            cross_track_width_pred_m: 4.0,
            iso_range_width_m: 4.0,
            iso_range_width_pred_m: 6.0,
            worst_width_m: 4.0,
            worst_width_pred_m: 6.0,
            longest_chord_m: 4.0,
            longest_chord_deg: 0.0,
            chord_along_g_m: 4.0,
            paper_range_m: 4.5,
            paper_azimuth_m: 6.8,
            planner_worst_width_m: 6.8,
            mainlobe_factors: [0.886, 0.886],
            region,
            axes: [[1.0, 0.0], [0.0, 1.0]],
        }
    }

    #[test]
    fn the_drawing_shows_the_region_the_cell_and_the_axes() {
        let cell = disc_cell();
        let para = cell.predicted_cell_m();
        for (corner, want) in para
            .iter()
            .zip([[2.0, 3.0], [-2.0, 3.0], [-2.0, -3.0], [2.0, -3.0]])
        {
            assert!((corner[0] - want[0]).abs() < 1e-12 && (corner[1] - want[1]).abs() < 1e-12);
        }
        let svg = cell_svg(&cell, "B = 150 MHz, test case").unwrap();
        assert!(svg.starts_with("<svg"), "{svg}");
        assert!(svg.contains("B = 150 MHz, test case"));
        assert!(svg.contains("β = 45.0°, ψ = 90.0°"));
        assert!(svg.contains("predicted ellipse and parallelogram"));
        // the measured region, filled, the predicted parallelogram's outline (closed: 5 points)
        // and the predicted ellipse's (closed: 181 points)
        assert!(svg.contains("<polygon") && svg.contains("#4C72B0"), "{svg}");
        let outlines: Vec<usize> = svg
            .lines()
            .filter(|l| l.contains("#C44E52") && l.contains("points="))
            .map(|l| l.matches(',').count())
            .collect();
        assert_eq!(outlines, [5, 181], "{svg}");
        // the range gradient and the track, labelled
        assert!(svg.contains("\ng\n") && svg.contains("\ntrack\n"), "{svg}");
    }

    #[test]
    fn a_reference_row_shows_the_measurement_beside_its_prediction() {
        let r = ReferenceResponse {
            reference: radar_sim::nr::Reference::Pilots,
            pulse_symbols: 1,
            cell: disc_cell(),
            levels: radar_sim::psf::ProfileLevels {
                peak_sidelobe_db: -13.0,
                alias_db: -0.2,
            },
        };
        assert_eq!(
            reference_row(150e6, &r, 4),
            "| 150 | pilots | 1 | 4.000 (4.000) | 4.000 (6.000) | -13.0 (-13.3) | -0.2 (0.0) |\n"
        );
        let full = ReferenceResponse {
            pulse_symbols: 4,
            ..r
        };
        assert!(reference_row(150e6, &full, 4).ends_with("| -0.2 (none) |\n"));
    }

    /// The whole report at one bandwidth and one geometry: the reference modes' table and
    /// `references.json`, each mode measured as predicted (widths within 5 %, the sinc's
    /// sidelobe within 0.5 dB, no alias).
    #[test]
    fn the_report_measures_each_reference_mode_against_its_prediction() {
        let dir = tempfile::tempdir().unwrap();
        let cases = radar_sim::psf::default_cases();
        write_resolution_report(dir.path(), &[150e6], &cases[..1], &mut |_, _| {}).unwrap();
        let md = std::fs::read_to_string(dir.path().join("RESOLUTION.md")).unwrap();
        assert!(
            md.contains("## Reference modes under the default NR cell"),
            "{md}"
        );
        for name in ["ideal", "pilots", "reconstructed"] {
            assert!(md.contains(&format!("| 150 | {name} | 4 |")), "{md}");
        }
        let text = std::fs::read_to_string(dir.path().join("references.json")).unwrap();
        let rows: Vec<ReferenceRow> = serde_json::from_str(&text).unwrap();
        assert_eq!(rows.len(), 3);
        for row in &rows {
            let (r, c) = (&row.response, &row.response.cell);
            assert!(
                (c.range_width_m / c.range_width_pred_m - 1.0).abs() < 0.05,
                "{row:?}"
            );
            assert!(
                (c.along_track_width_m / c.along_track_width_pred_m - 1.0).abs() < 0.05,
                "{row:?}"
            );
            assert!(
                (r.levels.peak_sidelobe_db - SINC_PEAK_SIDELOBE_DB).abs() < 0.5,
                "{row:?}"
            );
            assert_eq!(r.predicted_alias_db(4), None);
            assert!(r.levels.alias_db < -40.0, "{row:?}");
        }
    }

    #[test]
    fn a_report_into_a_file_that_cannot_be_written_names_it() {
        let dir = tempfile::tempdir().unwrap();
        // `out` is a file: the directory cannot be made
        let out = dir.path().join("taken");
        std::fs::write(&out, b"x").unwrap();
        let e = write_resolution_report(&out, &[150e6], &[], &mut |_, _| {}).unwrap_err();
        assert!(e.to_string().contains("taken"), "{e}");
    }
}
