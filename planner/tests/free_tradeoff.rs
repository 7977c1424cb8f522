#![allow(clippy::unwrap_used, clippy::expect_used)]
//! The energy–resolution trade-off of a free-altitude mission (`altitude = "free"` with
//! `PlanOptions::altitude_profile`): every point is a free plan, checked again on the exact
//! geometry at its own altitudes (bounds, rates, every constraint), each capped point within its
//! cap of the least-energy plan at the fixed altitude (computed here independently), the first
//! point the free least-energy plan, the resolution deficit never rising along the curve, and no
//! point worse than the fixed-altitude curve's in both energy and deficit; the plot's title and
//! energy axis say so (the first point the free least-energy plan, the percentages of the plan
//! at the fixed altitude).

use planner::evaluate::evaluate_with_altitudes;
use planner::shortfall::ResolutionShortfall;
use planner::tradeoff::{
    energy_axis_label, plot_title, tradeoff, EnergyBasis, TradeoffPoint, UNUSED_CAP_PCT,
};
use planner::{plan, AltitudeMode, Mission, PlanOptions, Preset};

#[test]
fn a_free_mission_gets_a_curve_of_free_plans_within_their_caps() {
    let fixed = Mission::preset(Preset::Default, 30.0).unwrap();
    let mut p = fixed.params().clone();
    p.altitude = AltitudeMode::Free;
    p.min_altitude_m = Some(600.0);
    p.max_altitude_m = Some(1200.0);
    let m = fixed.with_params(p.clone()).unwrap();
    let options = PlanOptions {
        altitude_profile: true,
        ..PlanOptions::least_energy()
    };
    let caps = [2.0];
    let t0 = std::time::Instant::now();
    let points = tradeoff(&m, &options, &caps).unwrap();
    eprintln!(
        "free curve of {} points in {:.1} s",
        points.len(),
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(points.len(), caps.len() + 2);
    assert_eq!(points[0].cap_pct, Some(0.0));
    assert_eq!(points[1].cap_pct, Some(2.0));
    assert_eq!(points.last().unwrap().cap_pct, None);

    // the percentages are of the fixed-altitude least-energy plan, the first point of the
    // fixed-altitude curve
    let fixed_least_j = plan(&fixed, &PlanOptions::least_energy())
        .unwrap()
        .evaluation
        .energy_j;
    let fixed_points = tradeoff(&fixed, &PlanOptions::least_energy(), &caps).unwrap();
    assert_eq!(fixed_points[0].plan.evaluation.energy_j, fixed_least_j);
    labels_name_the_basis(&points, &fixed_points, fixed_least_j, p.altitude_m);
    let weight = options.resolution_weight_j_per_m;
    // the first point is the free least-energy plan, no dearer than the fixed one
    let free_least = plan(&m, &options).unwrap();
    assert_eq!(points[0].plan.trajectory, free_least.trajectory);
    assert_eq!(points[0].plan.altitudes_m, free_least.altitudes_m);
    assert!(
        points[0].extra_energy_pct <= 1e-7,
        "{}",
        points[0].extra_energy_pct
    );

    let mut deficit = f64::INFINITY;
    for (i, pt) in points.iter().enumerate() {
        let z = pt
            .plan
            .altitudes_m
            .as_ref()
            .expect("a free plan has altitudes");
        let mut prev = p.altitude_m;
        for (t, &h) in z.iter().enumerate() {
            assert!(
                (600.0..=1200.0).contains(&h),
                "point {i} slot {}: {h} m",
                t + 1
            );
            let rate = (h - prev) / p.slot_s;
            assert!(
                rate <= p.max_climb_mps + 1e-9 && -rate <= p.max_descent_mps + 1e-9,
                "point {i} slot {}: {rate} m/s",
                t + 1
            );
            prev = h;
        }
        let ev = evaluate_with_altitudes(&m, &pt.plan.trajectory, z).unwrap();
        assert_eq!(ev, pt.plan.evaluation, "point {i}");
        assert!(ev.is_feasible(), "point {i}: {:?}", ev.violations);
        let want_pct = 100.0 * (ev.energy_j / fixed_least_j - 1.0);
        assert!(
            (pt.extra_energy_pct - want_pct).abs() < 1e-9,
            "point {i}: {} % vs {want_pct} %",
            pt.extra_energy_pct
        );
        if let Some(cap) = pt.cap_pct {
            assert!(
                ev.energy_j <= fixed_least_j * (1.0 + cap / 100.0) * (1.0 + 1e-9),
                "point {i}: {} J over its cap of {cap} %",
                ev.energy_j
            );
        }
        if i > 0 {
            let b = pt.plan.best_effort.as_ref().expect("a best effort");
            assert!((b.least_energy_j - fixed_least_j).abs() <= 1e-9 * fixed_least_j);
            assert_eq!(b.max_extra_energy_pct, pt.cap_pct);
        }
        let s = ResolutionShortfall::new(&m, &ev);
        assert_eq!(s, pt.shortfall, "point {i}");
        assert!(
            s.total_deficit_m <= deficit * (1.0 + 1e-9),
            "point {i}: deficit {} after {deficit}",
            s.total_deficit_m
        );
        deficit = s.total_deficit_m;
        // never worse than the fixed curve's point in both energy and deficit
        let f = &fixed_points[i];
        assert!(
            ev.energy_j <= f.plan.evaluation.energy_j * (1.0 + 1e-9)
                || s.total_deficit_m <= f.shortfall.total_deficit_m * (1.0 + 1e-9),
            "point {i}: {} J and {} m against the fixed curve's {} J and {} m",
            ev.energy_j,
            s.total_deficit_m,
            f.plan.evaluation.energy_j,
            f.shortfall.total_deficit_m
        );
        eprintln!(
            "fixed point {i}: {:.1} J ({:+.2} %), deficit {:.1} m, {} unresolved windows",
            f.plan.evaluation.energy_j,
            f.extra_energy_pct,
            f.shortfall.total_deficit_m,
            f.shortfall.unresolved_windows
        );
        eprintln!(
            "point {i}: cap {:?}, {:.1} J ({:+.2} %), deficit {:.1} m, {} unresolved windows, H {:.0}..{:.0} m",
            pt.cap_pct,
            ev.energy_j,
            pt.extra_energy_pct,
            s.total_deficit_m,
            s.unresolved_windows,
            z.iter().copied().fold(f64::MAX, f64::min),
            z.iter().copied().fold(f64::MIN, f64::max)
        );
    }
    // the best effort resolves more than the least-energy plan within 2 %
    assert!(points[1].shortfall.total_deficit_m < points[0].shortfall.total_deficit_m);
    // a cap a point stays well below is not planned again: the next point is that plan or a
    // better one (of less merit)
    let merit =
        |p: &TradeoffPoint| p.plan.evaluation.energy_j + weight * p.shortfall.total_deficit_m;
    for w in points.windows(2).skip(1) {
        if let Some(cap) = w[0].cap_pct {
            if cap - w[0].extra_energy_pct > UNUSED_CAP_PCT {
                assert!(merit(&w[1]) <= merit(&w[0]) * (1.0 + 1e-9));
            }
        }
    }
}

/// The plot's title and energy axis of the free curve `points` name the free least-energy plan
/// and the fixed-altitude plan its percentages are of (`fixed_least_j` at `altitude_m`); the
/// fixed curve's keep the least-energy plan.
fn labels_name_the_basis(
    points: &[TradeoffPoint],
    fixed_points: &[TradeoffPoint],
    fixed_least_j: f64,
    altitude_m: f64,
) {
    for pt in points {
        assert_eq!(pt.basis, EnergyBasis::FixedAltitude { altitude_m });
        assert!((pt.basis_energy_j - fixed_least_j).abs() <= 1e-9 * fixed_least_j);
    }
    let title = plot_title("free", points);
    let want = format!(
        "free: free altitude (free least-energy plan {:.0} J)",
        points[0].plan.evaluation.energy_j
    );
    assert_eq!(title, want);
    assert_eq!(
        energy_axis_label(points),
        format!(
            "extra energy over the least-energy plan at {altitude_m:.0} m ({fixed_least_j:.0} J) / %"
        )
    );
    for pt in fixed_points {
        assert_eq!(pt.basis, EnergyBasis::LeastEnergy);
        assert_eq!(pt.basis_energy_j, fixed_least_j);
    }
    assert_eq!(
        plot_title("fixed", fixed_points),
        format!("fixed: resolution against energy (least-energy plan {fixed_least_j:.0} J)")
    );
    assert_eq!(
        energy_axis_label(fixed_points),
        "extra energy over the least-energy plan / %"
    );
}
