//! The annotated SVG view of a SAR image (`aperture_NNN.svg`), drawn with plotters: the PNG that
//! radar-sim wrote beside it, referenced by its relative name (so the SVG stays small and shows
//! the same pixels), under ground axes in metres, with a colour bar in dB and a title naming
//! the aperture.

use std::ops::Range;
use std::path::Path;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use radar_sim::io::{check_image_shape, peak_db, viridis, write_bytes, ImageFrame, IMAGE_RANGE_DB};
use radar_sim::RadarError;

/// Font sizes as plotters takes them (its SVG text comes out 1/1.24 of this: 14 and 12 px).
const TITLE_FONT_PX: f64 = 17.4;
/// See [`TITLE_FONT_PX`].
const LABEL_FONT_PX: f64 = 14.9;
/// Bands of the colour bar.
const BAR_BANDS: usize = 64;
/// Space above the charts, under the title, px.
const MARGIN_TOP_PX: u32 = 10;
/// Longest side of the image on the page, px.
const IMAGE_PX: f64 = 420.0;

/// The tick step of 1, 2 or 5 × 10^k whose number of intervals over `span` is closest to
/// `target`.
fn tick_step(span: f64, target: f64) -> f64 {
    let raw = (span / target).max(f64::MIN_POSITIVE);
    let mag = 10f64.powf(raw.log10().floor());
    let intervals_off = |s: f64| (span / s - target).abs();
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .fold(mag, |best, s| {
            if intervals_off(s) < intervals_off(best) {
                s
            } else {
                best
            }
        })
}

/// A tick value without floating-point noise (`0.6`, not `0.6000000000000001`).
fn tick_label(v: f64) -> String {
    let r = (v * 1e6).round() / 1e6;
    format!("{}", if r == 0.0 { 0.0 } else { r })
}

/// Ticks `k step` within `[lo, hi]`.
fn ticks(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// Writes an annotated SVG of a power image that
/// [`write_png_db`](radar_sim::io::write_png_db) wrote to `png_name` in the same directory:
/// ground axes in metres (x east, y north, the pixels' extent), a colour bar of the PNG's
/// mapping in dB over the image's noise (the processor normalises each image to unit thermal
/// noise), from the peak down by `range_db`, and a title naming the aperture.
pub fn write_image_svg(
    path: &Path,
    png_name: &str,
    frame: &ImageFrame,
    power: &[f32],
    range_db: f64,
) -> radar_sim::Result<()> {
    check_image_shape(path, power, frame.nx, frame.ny)?;
    let svg = image_svg(png_name, frame, peak_db(power), range_db)
        .map_err(|e| RadarError::io(path, std::io::Error::other(format!("plot: {e}"))))?;
    write_bytes(path, svg.as_bytes())
}

/// Writes `aperture_NNN.svg` in `dir`, the view of `aperture_NNN.png` beside it with
/// [`IMAGE_RANGE_DB`]: the [`ImageViews`](radar_sim::run::ImageViews) that a processed
/// directory gets.
pub fn write_aperture_view(dir: &Path, frame: &ImageFrame, power: &[f32]) -> radar_sim::Result<()> {
    let stem = format!("aperture_{:03}", frame.aperture);
    write_image_svg(
        &dir.join(format!("{stem}.svg")),
        &format!("{stem}.png"),
        frame,
        power,
        IMAGE_RANGE_DB,
    )
}

/// The SVG text (see [`write_image_svg`]).
fn image_svg(
    png_name: &str,
    frame: &ImageFrame,
    top_db: f64,
    range_db: f64,
) -> Result<String, Box<dyn std::error::Error>> {
    let (nx, ny) = (frame.nx as f64, frame.ny as f64);
    // the pixels' extent on the ground (half a pixel beyond the outer centres)
    let (half_x, half_y) = (nx * frame.spacing_m / 2.0, ny * frame.spacing_m / 2.0);
    let xs = frame.centre_m[0] - half_x..frame.centre_m[0] + half_x;
    let ys = frame.centre_m[1] - half_y..frame.centre_m[1] + half_y;
    let scale = IMAGE_PX / nx.max(ny);
    let (left, bottom, bar_w, title) = (70u32, 45u32, 110u32, 40u32);
    let (w, h) = ((nx * scale).round() as u32, (ny * scale).round() as u32);
    let size = (left + w + bar_w, title + h + bottom);
    let mut text = String::new();
    let image_px;
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(
            &format!(
                "aperture {}: multilook power, dB over noise (+ detections)",
                frame.aperture
            ),
            ("sans-serif", TITLE_FONT_PX),
        )?;
        let (main, bar) = root.split_horizontally(left + w);
        let step = tick_step((xs.end - xs.start).max(ys.end - ys.start), 5.0);
        let mut chart = ChartBuilder::on(&main)
            .margin_top(MARGIN_TOP_PX)
            .x_label_area_size(bottom)
            .y_label_area_size(left)
            .build_cartesian_2d(keyed(xs.clone(), step), keyed(ys.clone(), step))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x (m, east)")
            .y_desc("y (m, north)")
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .label_style(("sans-serif", LABEL_FONT_PX))
            .draw()?;
        image_px = chart.plotting_area().get_pixel_range();
        colour_bar(&bar, top_db, range_db, MARGIN_TOP_PX, bottom)?;
        root.present()?;
    }
    Ok(with_image(&text, png_name, &image_px))
}

/// `range` with ticks at the multiples of `step` in it.
fn keyed(range: Range<f64>, step: f64) -> Keyed {
    Keyed {
        points: ticks(range.start, range.end, step),
        coord: range.into(),
    }
}

/// A linear axis ticked at given points (plotters' `WithKeyPoints` has no default label
/// format, which its mesh needs even when the labels are formatted by hand).
struct Keyed {
    coord: RangedCoordf64,
    points: Vec<f64>,
}

impl Ranged for Keyed {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.coord.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, _hint: Hint) -> Vec<f64> {
        self.points.clone()
    }

    fn range(&self) -> Range<f64> {
        self.coord.range()
    }
}

/// The colour bar: the PNG's mapping (radar-sim's viridis, so that the bar matches the
/// pixels exactly) from `top_db − range_db` to `top_db`, ticked in dB on its right.
fn colour_bar(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    top_db: f64,
    range_db: f64,
    margin_top: u32,
    bottom: u32,
) -> Result<(), Box<dyn std::error::Error>> {
    let lo = top_db - range_db;
    let mut bar = ChartBuilder::on(area)
        .margin_top(margin_top)
        .margin_left(24)
        .margin_right(54)
        .x_label_area_size(bottom)
        .right_y_label_area_size(30)
        .build_cartesian_2d(0f64..1f64, keyed(lo..top_db, tick_step(range_db, 4.0)))?;
    bar.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_label_formatter(&|v| tick_label(*v))
        .y_desc("dB")
        .label_style(("sans-serif", LABEL_FONT_PX))
        .draw()?;
    bar.draw_series((0..BAR_BANDS).map(|k| {
        let (t0, t1) = (
            k as f64 / BAR_BANDS as f64,
            (k + 1) as f64 / BAR_BANDS as f64,
        );
        let c = viridis((t0 + t1) / 2.0);
        Rectangle::new(
            [(0.0, lo + t0 * range_db), (1.0, lo + t1 * range_db)],
            RGBColor(c[0], c[1], c[2]).filled(),
        )
    }))?;
    Ok(())
}

/// `svg` with the image `png_name` stretched over the pixel rectangle `px` (plotters draws no
/// linked image: the element is added after the page's background).
fn with_image(svg: &str, png_name: &str, px: &(Range<i32>, Range<i32>)) -> String {
    let (x, y) = (px.0.start, px.1.start);
    let (w, h) = (px.0.end - px.0.start, px.1.end - px.1.start);
    let image = format!(
        "<image x=\"{x}\" y=\"{y}\" width=\"{w}\" height=\"{h}\" preserveAspectRatio=\"none\" \
         style=\"image-rendering:pixelated\" href=\"{png_name}\" xlink:href=\"{png_name}\"/>\n"
    );
    let svg = svg.replacen(
        "xmlns=\"http://www.w3.org/2000/svg\"",
        "xmlns=\"http://www.w3.org/2000/svg\" xmlns:xlink=\"http://www.w3.org/1999/xlink\"",
        1,
    );
    // the background is the first element after the opening tag
    match svg
        .find("<rect")
        .and_then(|i| svg[i..].find("/>").map(|j| i + j + 2))
    {
        Some(at) => format!("{}\n{image}{}", &svg[..at], &svg[at..]),
        None => svg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The annotated SVG: the PNG by its relative name, ground ticks at the pixels' extent,
    /// the colour bar from the peak's dB over noise down by the range; bad shapes refused.
    #[test]
    fn image_svg_has_axes_and_colour_bar() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.svg");
        let frame = ImageFrame {
            aperture: 7,
            centre_m: [100.0, -30.0],
            spacing_m: 0.4,
            nx: 251,
            ny: 251,
        };
        let mut img = vec![1.0f32; 251 * 251];
        img[125 * 251 + 125] = 1e4; // 40 dB over noise
        write_image_svg(&p, "aperture_007.png", &frame, &img, 40.0).unwrap();
        // plotters puts each text on a line of its own
        let svg = std::fs::read_to_string(&p)
            .unwrap()
            .replace(">\n", ">")
            .replace("\n<", "<");
        assert!(svg.contains(r#"href="aperture_007.png""#), "{svg}");
        assert!(svg.contains("aperture 7"));
        // extent 100 ± 50.2 m east, −30 ± 50.2 m north; 20 m ticks
        for label in [">60<", ">140<", ">-60<", ">0<", ">-20<"] {
            assert!(svg.contains(label), "{label}: {svg}");
        }
        // colour bar 0 … 40 dB in steps of 10
        for label in [">0</text>", ">10</text>", ">40</text>"] {
            assert!(svg.contains(label), "{label}");
        }
        // the bar's bands run through the PNG's mapping, from its bottom to its top colour
        let fill = |c: [u8; 3]| format!("fill=\"#{:02X}{:02X}{:02X}\"", c[0], c[1], c[2]);
        let first = viridis(0.5 / BAR_BANDS as f64);
        let last = viridis(1.0 - 0.5 / BAR_BANDS as f64);
        assert!(svg.contains(&fill(first)), "{}: {svg}", fill(first));
        assert!(svg.contains(&fill(last)), "{}", fill(last));
        // the image lies under the axes, inside the page
        let image = svg.find("<image").unwrap();
        assert!(image < svg.find(">60<").unwrap());
        let e = write_image_svg(&p, "x.png", &frame, &img[..10], 40.0).unwrap_err();
        assert!(e.to_string().contains("251 × 251"), "{e}");
        assert_eq!(tick_step(100.4, 5.0), 20.0);
        assert_eq!(tick_step(40.0, 4.0), 10.0);
        assert_eq!(
            ticks(49.8, 150.2, 20.0),
            vec![60.0, 80.0, 100.0, 120.0, 140.0]
        );
        assert_eq!(tick_label(3.0 * 0.2), "0.6");
        assert_eq!(tick_label(-0.0), "0");
    }
}
