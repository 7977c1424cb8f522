//! SVG plots: trajectories with landmarks, BS and sensing circles; line plots (energy per slot,
//! convergence, power vs speed, E\[d_min\] vs R, ...); the altitude side view of a
//! free-altitude plan.

use std::ops::Range;
use std::path::Path;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{write_file, ReportError};
use planner::geometry::sensing_centre_m;
use planner::Mission;
use planner::Trajectory;

/// Colours used for successive series (Tableau 10 and two more: twelve that are told apart;
/// none is the base station's [`BS_COLOUR`]).
pub const PALETTE: [RGBColor; 12] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(0, 0, 0),
    RGBColor(0, 0, 128),
    RGBColor(128, 0, 0),
];

/// The base station's marker colour in trajectory plots (not in [`PALETTE`]).
pub const BS_COLOUR: RGBColor = RGBColor(227, 0, 180);

/// One line of a line plot.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// (x, y) points; NaN/∞ points are skipped.
    pub points: Vec<(f64, f64)>,
    /// Draw markers at the points as well (always drawn for a series of one point).
    pub markers: bool,
    /// Dashed line.
    pub dashed: bool,
    /// Index into [`PALETTE`] (several series of one group can share a colour and differ in
    /// style); `None`: the series' position in the plot.
    pub colour: Option<usize>,
}

impl Series {
    /// A plain line.
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            markers: false,
            dashed: false,
            colour: None,
        }
    }
}

fn err<E: std::fmt::Display>(path: &Path) -> impl Fn(E) -> ReportError + '_ {
    move |e| ReportError::Plot {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

fn finite_bounds(points: impl Iterator<Item = (f64, f64)>) -> Option<(f64, f64, f64, f64)> {
    let mut b: Option<(f64, f64, f64, f64)> = None;
    for (x, y) in points.filter(|(x, y)| x.is_finite() && y.is_finite()) {
        b = Some(match b {
            None => (x, x, y, y),
            Some((x0, x1, y0, y1)) => (x0.min(x), x1.max(x), y0.min(y), y1.max(y)),
        });
    }
    b
}

fn pad(lo: f64, hi: f64, frac: f64) -> (f64, f64) {
    let span = (hi - lo).abs().max(1e-9 * (1.0 + lo.abs()));
    let span = if span < 1e-12 { 1.0 } else { span };
    (lo - frac * span, hi + frac * span)
}

/// The legend's sample of a series: a line (two dashes if dashed) with a dot if it has markers.
fn legend_sample<'a, DB: DrawingBackend + 'a>(
    x: i32,
    y: i32,
    color: RGBColor,
    dashed: bool,
    markers: bool,
) -> impl IntoDynElement<'a, DB, (i32, i32)> {
    let style = color.stroke_width(2);
    // one solid line is two segments that meet
    let (end_a, start_b) = if dashed { (7, 13) } else { (10, 10) };
    EmptyElement::at((x, y))
        + PathElement::new(vec![(0, 0), (end_a, 0)], style)
        + PathElement::new(vec![(start_b, 0), (20, 0)], style)
        + Circle::new((10, 0), if markers { 3 } else { 0 }, color.filled())
}

/// The corner of the plot where a legend of `entries` rows covers the fewest of `points`
/// (given in plot fractions: 0..1 from the lower left).
fn emptiest_corner(points: &[(f64, f64)], entries: usize) -> SeriesLabelPosition {
    // the legend's size in plot fractions (about 22 px per row of a ~450 px high plot area,
    // and a third of its width)
    let h = (0.05 * entries as f64 + 0.04).min(0.9);
    let w = 0.36;
    let corners = [
        (SeriesLabelPosition::UpperRight, 1.0 - w, 1.0, 1.0 - h, 1.0),
        (SeriesLabelPosition::UpperLeft, 0.0, w, 1.0 - h, 1.0),
        (SeriesLabelPosition::LowerRight, 1.0 - w, 1.0, 0.0, h),
        (SeriesLabelPosition::LowerLeft, 0.0, w, 0.0, h),
    ];
    let mut best = (usize::MAX, SeriesLabelPosition::UpperRight);
    for (pos, xa, xb, ya, yb) in corners {
        let covered = points
            .iter()
            .filter(|(x, y)| *x >= xa && *x <= xb && *y >= ya && *y <= yb)
            .count();
        if covered < best.0 {
            best = (covered, pos);
        }
    }
    best.1
}

/// A line plot with a legend.
pub fn line_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<(), ReportError> {
    let e = err(path);
    let all = series.iter().flat_map(|s| s.points.iter().copied());
    let (x0, x1, y0, y1) = finite_bounds(all).unwrap_or((0.0, 1.0, 0.0, 1.0));
    let (x0, x1) = pad(x0, x1, 0.02);
    let (y0, y1) = pad(y0, y1, 0.05);
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (900, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(&e)?;
        let mut chart = chart_on(&root, title, (x0..x1, y0..y1), (x_label, y_label), path)?;
        for (i, s) in series.iter().enumerate() {
            let color = PALETTE[s.colour.unwrap_or(i) % PALETTE.len()];
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .collect();
            // a lone point has no line to show: mark it
            let markers = s.markers || pts.len() < 2;
            let style = ShapeStyle::from(&color).stroke_width(2);
            let anno = if s.dashed {
                chart
                    .draw_series(DashedLineSeries::new(pts.clone(), 6, 4, style))
                    .map_err(&e)?
            } else {
                chart
                    .draw_series(LineSeries::new(pts.clone(), style))
                    .map_err(&e)?
            };
            let dashed = s.dashed;
            anno.label(s.name.clone())
                .legend(move |(x, y)| legend_sample(x, y, color, dashed, markers));
            if markers {
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                    .map_err(&e)?;
            }
        }
        let all: Vec<(f64, f64)> = series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .map(|(x, y)| ((x - x0) / (x1 - x0), (y - y0) / (y1 - y0)))
            .collect();
        finish(&mut chart, &root, emptiest_corner(&all, series.len()), path)?;
    }
    write_file(path, &text)
}

/// The altitude profile of a free-altitude plan (`altitude = "free"`) against time: the
/// altitude `profile_m` ((t_s, z_m) points, the start first) as a line with markers, the
/// bounds `min_altitude_m` and `max_altitude_m` as dashed lines, and the climb and descent
/// limits in the title.
pub fn altitude_plot(
    path: &Path,
    title: &str,
    mission: &Mission,
    profile_m: &[(f64, f64)],
) -> Result<(), ReportError> {
    let p = mission.params();
    let (lo_m, hi_m) = planner::altitude::bounds_m(p);
    let t_end_s = profile_m
        .iter()
        .map(|(t, _)| *t)
        .filter(|t| t.is_finite())
        .fold(p.horizon_s, f64::max);
    let bound = |name: String, z_m: f64, colour: usize| Series {
        dashed: true,
        colour: Some(colour),
        ..Series::line(name, vec![(0.0, z_m), (t_end_s, z_m)])
    };
    let series = [
        Series {
            markers: profile_m.len() <= 60,
            colour: Some(0),
            ..Series::line("altitude z_m", profile_m.to_vec())
        },
        bound(format!("max_altitude_m = {hi_m:.0} m"), hi_m, 1),
        bound(format!("min_altitude_m = {lo_m:.0} m"), lo_m, 2),
    ];
    let title = format!(
        "{title} (climb ≤ {:.1} m/s, descent ≤ {:.1} m/s)",
        p.max_climb_mps, p.max_descent_mps
    );
    line_plot(path, &title, "t (s)", "altitude (m)", &series)
}

/// The chart of a plot on `root`: the caption `title`, axes over `ranges` (x, y) described by
/// `labels` (x, y), and a light grid.
fn chart_on<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, Shift>,
    title: &str,
    ranges: (Range<f64>, Range<f64>),
    labels: (&str, &str),
    path: &Path,
) -> Result<GroundChart<'a, 'b>, ReportError> {
    let e = err(path);
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(ranges.0, ranges.1)
        .map_err(&e)?;
    chart
        .configure_mesh()
        .x_desc(labels.0)
        .y_desc(labels.1)
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(&e)?;
    Ok(chart)
}

/// Draws the legend of `chart` at `position` (on a white, framed background) and finishes the
/// drawing.
fn finish<'a, 'b: 'a>(
    chart: &mut GroundChart<'a, 'b>,
    root: &DrawingArea<SVGBackend<'b>, Shift>,
    position: SeriesLabelPosition,
    path: &Path,
) -> Result<(), ReportError> {
    let e = err(path);
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(&e)?;
    root.present().map_err(&e)
}

/// One trajectory of a trajectory plot.
#[derive(Debug, Clone, Copy)]
pub struct TrackStyle<'a> {
    /// Legend label.
    pub name: &'a str,
    /// The trajectory.
    pub traj: &'a Trajectory,
    /// Slots (1-based) whose sensing circle is drawn.
    pub circle_slots: &'a [usize],
    /// Dashed track.
    pub dashed: bool,
}

/// The chart every plot draws on (a trajectory plot's: ground x, y in metres).
type GroundChart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Trajectories with landmarks (dots), the BS (triangle), the start (square), the true sensing
/// centre track, and sensing circles at chosen slots; equal axis scales.
pub fn trajectory_plot(
    path: &Path,
    title: &str,
    mission: &Mission,
    tracks: &[TrackStyle<'_>],
) -> Result<(), ReportError> {
    let e = err(path);
    let (cx, cy, half) = ground_view(mission, tracks);
    let (w, h) = (900u32, 900u32);
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(&e)?;
        let view = (cx - half..cx + half, cy - half..cy + half);
        let mut chart = chart_on(&root, title, view, ("x (m)", "y (m)"), path)?;
        for (i, tr) in tracks.iter().enumerate() {
            draw_track(&mut chart, path, mission, tr, PALETTE[i % PALETTE.len()])?;
        }
        draw_mission_marks(&mut chart, path, mission, tracks)?;
        finish(&mut chart, &root, SeriesLabelPosition::UpperLeft, path)?;
    }
    write_file(path, &text)
}

/// The square view of a trajectory plot, (centre x, centre y, half side) in m: everything
/// drawn (landmarks, BS, start, tracks, the sensing centres ~1 km to their side) and a sensing
/// radius more, equal scales (the shorter side extended).
fn ground_view(mission: &Mission, tracks: &[TrackStyle<'_>]) -> (f64, f64, f64) {
    let p = mission.params();
    let offset = p.centre_offset_m();
    let mut pts: Vec<(f64, f64)> = mission
        .schedule()
        .landmarks
        .iter()
        .map(|l| (l.x_m, l.y_m))
        .collect();
    pts.push((p.bs_m[0], p.bs_m[1]));
    pts.push((p.start_m[0], p.start_m[1]));
    for tr in tracks {
        pts.extend(tr.traj.pos_m.iter().map(|q| (q[0], q[1])));
        // the sensing centres lie ~1 km to the side of the track: keep them in the frame
        let headings = tr.traj.headings_rad();
        pts.extend((1..=tr.traj.slots()).map(|t| {
            let c = sensing_centre_m(tr.traj.q(t), headings[t - 1], offset);
            (c[0], c[1])
        }));
    }
    let (x0, x1, y0, y1) = finite_bounds(pts.into_iter()).unwrap_or((0.0, 1.0, 0.0, 1.0));
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let half = 0.5 * (x1 - x0).max(y1 - y0) * 1.08 + p.sensing_radius_m;
    (cx, cy, half)
}

/// One track of a trajectory plot in `color`: its line (with the legend entry), every 4th
/// true sensing centre, and at its chosen slots the UAV, its sensing circle and the line
/// between them.
fn draw_track<'a, 'b: 'a>(
    chart: &mut GroundChart<'a, 'b>,
    path: &Path,
    mission: &Mission,
    tr: &TrackStyle<'_>,
    color: RGBColor,
) -> Result<(), ReportError> {
    let e = err(path);
    let p = mission.params();
    let offset = p.centre_offset_m();
    let r = p.sensing_radius_m;
    // sensing circles (as polylines, so they stay circles in data units)
    let circle = |c: [f64; 2]| -> Vec<(f64, f64)> {
        (0..=72)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 72.0;
                (c[0] + r * a.cos(), c[1] + r * a.sin())
            })
            .collect()
    };
    let style = ShapeStyle::from(&color).stroke_width(2);
    let line: Vec<(f64, f64)> = std::iter::once(tr.traj.start_m)
        .chain(tr.traj.pos_m.iter().copied())
        .map(|q| (q[0], q[1]))
        .collect();
    let anno = if tr.dashed {
        chart
            .draw_series(DashedLineSeries::new(line, 8, 5, style))
            .map_err(&e)?
    } else {
        chart
            .draw_series(LineSeries::new(line, style))
            .map_err(&e)?
    };
    anno.label(tr.name.to_string())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    let headings = tr.traj.headings_rad();
    let centres: Vec<(f64, f64)> = (1..=tr.traj.slots())
        .map(|t| {
            let c = sensing_centre_m(tr.traj.q(t), headings[t - 1], offset);
            (c[0], c[1])
        })
        .collect();
    chart
        .draw_series(
            centres
                .iter()
                .step_by(4)
                .map(|&c| Circle::new(c, 1, color.mix(0.5).filled())),
        )
        .map_err(&e)?;
    for &t in tr.circle_slots {
        if t == 0 || t > tr.traj.slots() {
            continue;
        }
        let c = sensing_centre_m(tr.traj.q(t), headings[t - 1], offset);
        chart
            .draw_series(LineSeries::new(circle(c), color.mix(0.7).stroke_width(1)))
            .map_err(&e)?;
        let q = tr.traj.q(t);
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(q[0], q[1]), (c[0], c[1])],
                color.mix(0.4).stroke_width(1),
            )))
            .map_err(&e)?;
        chart
            .draw_series(std::iter::once(TriangleMarker::new(
                (q[0], q[1]),
                5,
                color.filled(),
            )))
            .map_err(&e)?;
    }
    Ok(())
}

/// The marks of the mission itself, each with its legend entry: landmarks, the base station,
/// what the per-track marks mean, and the start.
fn draw_mission_marks<'a, 'b: 'a>(
    chart: &mut GroundChart<'a, 'b>,
    path: &Path,
    mission: &Mission,
    tracks: &[TrackStyle<'_>],
) -> Result<(), ReportError> {
    let e = err(path);
    let p = mission.params();
    let r = p.sensing_radius_m;
    let landmarks: Vec<(f64, f64)> = mission
        .schedule()
        .landmarks
        .iter()
        .map(|l| (l.x_m, l.y_m))
        .collect();
    chart
        .draw_series(landmarks.iter().map(|&l| Circle::new(l, 3, BLACK.filled())))
        .map_err(&e)?
        .label("landmarks")
        .legend(|(x, y)| Circle::new((x + 10, y), 3, BLACK.filled()));
    chart
        .draw_series(std::iter::once(TriangleMarker::new(
            (p.bs_m[0], p.bs_m[1]),
            9,
            BS_COLOUR.filled(),
        )))
        .map_err(&e)?
        .label("base station")
        .legend(|(x, y)| TriangleMarker::new((x + 10, y), 6, BS_COLOUR.filled()));
    // what the per-track marks mean (legend entries only, in grey)
    let grey = RGBColor(110, 110, 110);
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
        .map_err(&e)?
        .label("true sensing centre (every 4th slot)")
        .legend(move |(x, y)| Circle::new((x + 10, y), 2, grey.filled()));
    if tracks.iter().any(|t| !t.circle_slots.is_empty()) {
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(&e)?
            .label(format!(
                "UAV (▲) and its sensing disc (r_s = {r:.0} m) at chosen slots"
            ))
            .legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + TriangleMarker::new((4, 0), 4, grey.filled())
                    + Circle::new((14, 0), 6, grey.stroke_width(1))
            });
    }
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [
                (p.start_m[0] - 20.0, p.start_m[1] - 20.0),
                (p.start_m[0] + 20.0, p.start_m[1] + 20.0),
            ],
            BLACK.stroke_width(2),
        )))
        .map_err(&e)?
        .label("start")
        .legend(|(x, y)| Rectangle::new([(x + 5, y - 5), (x + 15, y + 5)], BLACK.stroke_width(2)));
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn the_legend_goes_where_the_data_are_not() {
        // a curve falling from the upper left to the lower right leaves the other corners free
        let falling: Vec<(f64, f64)> = (0..=100)
            .map(|k| (k as f64 / 100.0, 1.0 - k as f64 / 100.0))
            .collect();
        let pos = emptiest_corner(&falling, 4);
        assert!(
            matches!(
                pos,
                SeriesLabelPosition::UpperRight | SeriesLabelPosition::LowerLeft
            ),
            "{pos:?}"
        );
        // data crowding the top: the legend goes to the bottom
        let top: Vec<(f64, f64)> = (0..=100).map(|k| (k as f64 / 100.0, 0.95)).collect();
        let pos = emptiest_corner(&top, 4);
        assert!(
            matches!(
                pos,
                SeriesLabelPosition::LowerRight | SeriesLabelPosition::LowerLeft
            ),
            "{pos:?}"
        );
    }

    /// The points of the first `<polyline>` stroked in `colour`, in pixels.
    fn polyline_px(svg: &str, colour: RGBColor) -> Vec<(f64, f64)> {
        let hex = format!("#{:02X}{:02X}{:02X}", colour.0, colour.1, colour.2);
        let tag = svg
            .split("<polyline")
            .skip(1)
            .map(|t| &t[..t.find('>').unwrap()])
            .find(|t| t.to_uppercase().contains(&hex))
            .unwrap();
        let points = tag.split("points=\"").nth(1).unwrap();
        let points = &points[..points.find('"').unwrap()];
        points
            .split_whitespace()
            .map(|xy| {
                let (x, y) = xy.split_once(',').unwrap();
                (x.parse().unwrap(), y.parse().unwrap())
            })
            .collect()
    }

    /// The side view draws every (t, z) point of the profile on linear axes (pixel x rising
    /// with t, pixel y falling with z, both affine) and names the bounds and the rates.
    #[test]
    fn the_altitude_plot_holds_the_profile_bounds_and_rates() {
        let m = Mission::preset(planner::Preset::Default, 200.0).unwrap();
        let mut p = m.params().clone();
        p.altitude = planner::AltitudeMode::Free;
        p.min_altitude_m = Some(600.0);
        p.max_altitude_m = Some(1200.0);
        p.max_climb_mps = 2.5;
        let m = m.with_params(p).unwrap();
        // down at 1 m/s for 100 s, level, up at 2.5 m/s
        let profile: Vec<(f64, f64)> = (0..=30)
            .map(|k| {
                let t = 10.0 * k as f64;
                let z = if t <= 100.0 {
                    1000.0 - t
                } else if t <= 200.0 {
                    900.0
                } else {
                    900.0 + 2.5 * (t - 200.0)
                };
                (t, z)
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("altitude.svg");
        altitude_plot(&path, "altitude", &m, &profile).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        for text in [
            "min_altitude_m = 600 m",
            "max_altitude_m = 1200 m",
            "climb ≤ 2.5 m/s",
            "descent ≤ 1.0 m/s",
        ] {
            assert!(svg.contains(text), "{text} missing");
        }
        let px = polyline_px(&svg, PALETTE[0]);
        assert_eq!(px.len(), profile.len());
        let (first, last) = (profile[0], profile[profile.len() - 1]);
        let sx = (px[px.len() - 1].0 - px[0].0) / (last.0 - first.0);
        let (lowest, high) = (profile[10], profile[30]);
        let sy = (px[30].1 - px[10].1) / (high.1 - lowest.1);
        assert!(sx > 0.0 && sy < 0.0, "{sx} {sy}");
        for (k, (&(t, z), &(x, y))) in profile.iter().zip(&px).enumerate() {
            assert!(
                (x - (px[0].0 + sx * (t - first.0))).abs() <= 1.0,
                "point {k}"
            );
            assert!(
                (y - (px[10].1 + sy * (z - lowest.1))).abs() <= 1.0,
                "point {k}"
            );
        }
    }

    #[test]
    fn a_lone_point_is_drawn_and_colours_can_be_shared() {
        let dir = std::env::temp_dir().join(format!("cellsar-plot-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.svg");
        let series = [
            Series {
                colour: Some(1),
                ..Series::line("one point", vec![(1.0, 2.0)])
            },
            Series {
                colour: Some(1),
                dashed: true,
                ..Series::line("line", vec![(0.0, 0.0), (2.0, 3.0)])
            },
        ];
        line_plot(&path, "t", "x (m)", "y (m)", &series).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        // the lone point has a marker (a circle), in the shared colour
        let c = PALETTE[1];
        let hex = format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
        let marks = svg
            .match_indices("<circle")
            .filter(|(i, _)| {
                let tag = &svg[*i..svg[*i..].find('>').map_or(svg.len(), |j| i + j)];
                tag.contains("r=\"3\"") && tag.to_uppercase().contains(&hex)
            })
            .count();
        // its marker in the plot and in the legend; the line has none
        assert_eq!(marks, 2, "{svg}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
