//! PNG images of power in dB through a perceptual colormap.

use std::path::Path;

use super::atomic::write_atomic;
use crate::error::{RadarError, Result};

/// A perceptual colormap (viridis, 9 anchors, linear between them): t ∈ [0, 1] → RGB.
pub fn viridis(t: f64) -> [u8; 3] {
    const A: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * 8.0;
    let i = (x.floor() as usize).min(7);
    let f = x - i as f64;
    let mut o = [0u8; 3];
    for k in 0..3 {
        o[k] = (A[i][k] + f * (A[i + 1][k] - A[i][k])).round() as u8;
    }
    o
}

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

/// `Err` naming `path` unless `power` holds a non-empty `ny × nx` image.
pub fn check_image_shape(path: &Path, power: &[f32], nx: usize, ny: usize) -> Result<()> {
    if power.len() != nx * ny || power.is_empty() {
        return Err(RadarError::Shape {
            what: format!("image {}", path.display()),
            expected: format!("{ny} × {nx} (non-empty)"),
            found: power.len().to_string(),
        });
    }
    Ok(())
}

/// The image's peak in dB (of the power's unit), the top of its colour mapping.
pub fn peak_db(power: &[f32]) -> f64 {
    10.0 * (power.iter().cloned().fold(f32::MIN_POSITIVE, f32::max) as f64).log10()
}

/// Writes a power image (ny × nx, row 0 = south) as PNG in dB: the top `range_db` below the
/// peak mapped through [`viridis`], north up, with optional marker pixels (white crosses).
pub fn write_png_db(
    path: &Path,
    power: &[f32],
    nx: usize,
    ny: usize,
    range_db: f64,
    markers: &[(usize, usize)],
) -> Result<()> {
    check_image_shape(path, power, nx, ny)?;
    let top = peak_db(power);
    let mut rgb = vec![0u8; nx * ny * 3];
    for y in 0..ny {
        for x in 0..nx {
            let v = power[y * nx + x].max(1e-30) as f64;
            let t = (10.0 * v.log10() - (top - range_db)) / range_db;
            let c = viridis(t);
            let o = ((ny - 1 - y) * nx + x) * 3;
            rgb[o..o + 3].copy_from_slice(&c);
        }
    }
    for &(mx, my) in markers {
        for d in -3i64..=3 {
            for (x, y) in [(mx as i64 + d, my as i64), (mx as i64, my as i64 + d)] {
                if x >= 0 && y >= 0 && (x as usize) < nx && (y as usize) < ny {
                    let o = ((ny - 1 - y as usize) * nx + x as usize) * 3;
                    rgb[o..o + 3].copy_from_slice(&[255, 255, 255]);
                }
            }
        }
    }
    write_atomic(path, |f| {
        let png_err = |e: png::EncodingError| match e {
            png::EncodingError::IoError(e) => RadarError::io(path, e),
            e => RadarError::format(path.display().to_string(), "PNG", e.to_string()),
        };
        let mut enc = png::Encoder::new(f, nx as u32, ny as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(png_err)?;
        w.write_image_data(&rgb).map_err(png_err)?;
        // the end chunk and its flush: an error here is returned (dropping the writer would
        // swallow it)
        w.finish().map_err(png_err)
    })
}

/// Dynamic range of the image files, dB below each image's peak (PNG and its SVG's colour bar).
pub const IMAGE_RANGE_DB: f64 = 40.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_writes() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("i.png");
        let img: Vec<f32> = (0..30 * 20).map(|i| (i % 30) as f32 + 1.0).collect();
        write_png_db(&p, &img, 30, 20, 30.0, &[(5, 5)]).unwrap();
        assert!(std::fs::metadata(&p).unwrap().len() > 50);
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
    }

    /// The PNG's bytes are what the png crate writes for the pixels (decoded back here), and a
    /// failure names the file and leaves no partial file.
    #[test]
    fn png_decodes_to_the_mapped_pixels_and_errors_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("i.png");
        let img: Vec<f32> = (0..4 * 3).map(|i| 10f32.powi(i % 5)).collect();
        write_png_db(&p, &img, 4, 3, 40.0, &[]).unwrap();
        let dec = png::Decoder::new(std::fs::File::open(&p).unwrap());
        let mut r = dec.read_info().unwrap();
        let mut buf = vec![0u8; r.output_buffer_size()];
        let info = r.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (4, 3));
        // row 0 of the file is the northernmost row (y = 2); pixel (0, 2) is 10^(8 % 5) = 1e3:
        // 10 dB below the 1e4 peak → t = 0.75
        assert_eq!(&buf[..3], &viridis(0.75));
        let e = write_png_db(&dir.path().join("no/i.png"), &img, 4, 3, 40.0, &[]).unwrap_err();
        assert!(
            matches!(e, RadarError::Io { .. }) && e.to_string().contains("i.png"),
            "{e}"
        );
        let e = write_png_db(&p, &img, 5, 3, 40.0, &[]).unwrap_err();
        assert!(e.to_string().contains("i.png"), "{e}");
    }
}
