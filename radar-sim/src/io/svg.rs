//! Annotated SVG views of the PNG images: ground axes in metres and a colour bar in dB.

use std::path::Path;

use super::atomic::write_bytes;
use super::image::{check_image_shape, peak_db, viridis};
use crate::error::Result;

/// Where an image lies on the ground: centre, pixel spacing and size (as
/// [`crate::backproject::Grid`], repeated here so that the image writers need no processor types).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageFrame {
    /// Aperture index (the title).
    pub aperture: usize,
    /// Ground position of the centre pixel, m.
    pub centre_m: [f64; 2],
    /// Pixel spacing, m.
    pub spacing_m: f64,
    /// Columns (east).
    pub nx: usize,
    /// Rows (north).
    pub ny: usize,
}

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

/// Writes an annotated SVG of a power image that [`write_png_db`](super::write_png_db) wrote to `png_name` in the
/// same directory (referenced by that relative name, so the SVG stays small and shows the same
/// pixels): ground axes in metres (x east, y north, the pixel centres' coordinates), a colour
/// bar of the PNG's mapping in dB over the image's noise (the processor normalises each image to
/// unit thermal noise), and a title naming the aperture.
pub fn write_image_svg(
    path: &Path,
    png_name: &str,
    frame: &ImageFrame,
    power: &[f32],
    range_db: f64,
) -> Result<()> {
    use std::fmt::Write as _;
    let (nx, ny) = (frame.nx, frame.ny);
    check_image_shape(path, power, nx, ny)?;
    let top_db = peak_db(power);
    // the pixels' extent on the ground (half a pixel beyond the outer centres)
    let half_x = nx as f64 * frame.spacing_m / 2.0;
    let half_y = ny as f64 * frame.spacing_m / 2.0;
    let (x0, x1) = (frame.centre_m[0] - half_x, frame.centre_m[0] + half_x);
    let (y0, y1) = (frame.centre_m[1] - half_y, frame.centre_m[1] + half_y);
    let scale = 420.0 / nx.max(ny) as f64;
    let (w, h) = (nx as f64 * scale, ny as f64 * scale);
    let (left, top) = (70.0, 40.0);
    let bar_x = left + w + 24.0;
    let width = bar_x + 80.0;
    let height = top + h + 55.0;
    let px = |x: f64| left + (x - x0) / (x1 - x0) * w;
    let py = |y: f64| top + (y1 - y) / (y1 - y0) * h;
    let mut o = String::new();
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(
        o,
        r#"<rect width="100%" height="100%" fill="white"/><text x="{left:.1}" y="24" font-size="14">aperture {}: multilook power, dB over noise (+ detections)</text>"#,
        frame.aperture
    );
    let _ = writeln!(
        o,
        r#"<image x="{left:.1}" y="{top:.1}" width="{w:.1}" height="{h:.1}" preserveAspectRatio="none" style="image-rendering:pixelated" href="{png_name}" xlink:href="{png_name}"/>"#
    );
    let _ = writeln!(
        o,
        r#"<rect x="{left:.1}" y="{top:.1}" width="{w:.1}" height="{h:.1}" fill="none" stroke="black"/>"#
    );
    let step = tick_step((x1 - x0).max(y1 - y0), 5.0);
    for x in ticks(x0, x1, step) {
        let sx = px(x);
        let _ = writeln!(
            o,
            r#"<line x1="{sx:.1}" y1="{:.1}" x2="{sx:.1}" y2="{:.1}" stroke="black"/><text x="{sx:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            top + h,
            top + h + 5.0,
            top + h + 18.0,
            tick_label(x)
        );
    }
    for y in ticks(y0, y1, step) {
        let sy = py(y);
        let _ = writeln!(
            o,
            r#"<line x1="{:.1}" y1="{sy:.1}" x2="{left:.1}" y2="{sy:.1}" stroke="black"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
            left - 5.0,
            left - 8.0,
            sy + 4.0,
            tick_label(y)
        );
    }
    let _ = writeln!(
        o,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">x (m, east)</text><text transform="translate(16 {:.1}) rotate(-90)" text-anchor="middle">y (m, north)</text>"#,
        left + w / 2.0,
        top + h + 40.0,
        top + h / 2.0
    );
    // colour bar: the PNG's mapping, top_db − range_db … top_db
    let _ = writeln!(
        o,
        r#"<defs><linearGradient id="cbar" x1="0" y1="1" x2="0" y2="0">"#
    );
    for k in 0..=8 {
        let t = k as f64 / 8.0;
        let c = viridis(t);
        let _ = writeln!(
            o,
            r#"<stop offset="{t:.3}" stop-color="rgb({},{},{})"/>"#,
            c[0], c[1], c[2]
        );
    }
    let _ = writeln!(
        o,
        r#"</linearGradient></defs><rect x="{bar_x:.1}" y="{top:.1}" width="16" height="{h:.1}" fill="url(#cbar)" stroke="black"/>"#
    );
    let db_step = tick_step(range_db, 4.0);
    for d in ticks(top_db - range_db, top_db, db_step) {
        let sy = top + (top_db - d) / range_db * h;
        let _ = writeln!(
            o,
            r#"<line x1="{:.1}" y1="{sy:.1}" x2="{:.1}" y2="{sy:.1}" stroke="black"/><text x="{:.1}" y="{:.1}">{}</text>"#,
            bar_x + 16.0,
            bar_x + 21.0,
            bar_x + 24.0,
            sy + 4.0,
            tick_label(d)
        );
    }
    let _ = writeln!(
        o,
        r#"<text x="{bar_x:.1}" y="{:.1}">dB</text></svg>"#,
        top + h + 18.0
    );
    write_bytes(path, o.as_bytes())
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
        let svg = std::fs::read_to_string(&p).unwrap();
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
        assert_eq!(svg.matches("<stop ").count(), 9);
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
