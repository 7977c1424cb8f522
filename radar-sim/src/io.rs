//! File formats: NPY v1 (complex64 `<c8`, `<f4`, `<f8`; streaming writer), CSV and JSON
//! helpers, PNG images in dB with a perceptual colormap.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::Path;

use rustfft::num_complex::Complex32;
use serde::Serialize;

use crate::error::{RadarError, Result};

/// Element type of an NPY array.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NpyType {
    /// `<c8`: complex64 (f32 re, f32 im), little-endian.
    C8,
    /// `<f4`.
    F4,
    /// `<f8`.
    F8,
}

impl NpyType {
    fn descr(self) -> &'static str {
        match self {
            NpyType::C8 => "<c8",
            NpyType::F4 => "<f4",
            NpyType::F8 => "<f8",
        }
    }
    fn size(self) -> usize {
        match self {
            NpyType::C8 | NpyType::F8 => 8,
            NpyType::F4 => 4,
        }
    }
}

fn npy_header(t: NpyType, shape: &[usize]) -> Vec<u8> {
    let dims = match shape.len() {
        1 => format!("({},)", shape[0]),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut dict = format!(
        "{{'descr': '{}', 'fortran_order': False, 'shape': {}, }}",
        t.descr(),
        dims
    );
    // total header (10-byte preamble + dict + '\n') a multiple of 64
    let len = 10 + dict.len() + 1;
    dict.push_str(&" ".repeat((64 - len % 64) % 64));
    dict.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
}

/// Streaming NPY writer: the shape is fixed up front, data is appended in row-major order.
#[derive(Debug)]
pub struct NpyWriter {
    out: BufWriter<File>,
    path: String,
    t: NpyType,
    expected: usize,
    written: usize,
}

impl NpyWriter {
    /// Creates `path` with element type `t` and `shape`.
    pub fn create(path: &Path, t: NpyType, shape: &[usize]) -> Result<Self> {
        let f = File::create(path).map_err(|e| RadarError::io(path, e))?;
        let mut out = BufWriter::new(f);
        out.write_all(&npy_header(t, shape))
            .map_err(|e| RadarError::io(path, e))?;
        Ok(Self {
            out,
            path: path.display().to_string(),
            t,
            expected: shape.iter().product(),
            written: 0,
        })
    }

    fn check(&mut self, t: NpyType, n: usize) -> Result<()> {
        if t != self.t {
            return Err(RadarError::format(
                &self.path,
                "descr",
                "element type mismatch",
            ));
        }
        if self.written + n > self.expected {
            return Err(RadarError::format(
                &self.path,
                "data",
                format!(
                    "more than the {} elements of the declared shape",
                    self.expected
                ),
            ));
        }
        self.written += n;
        Ok(())
    }

    fn io(&self, e: std::io::Error) -> RadarError {
        RadarError::Io {
            path: self.path.clone(),
            source: e,
        }
    }

    /// Appends complex64 elements.
    pub fn write_c8(&mut self, v: &[Complex32]) -> Result<()> {
        self.check(NpyType::C8, v.len())?;
        let mut buf = Vec::with_capacity(v.len() * 8);
        for c in v {
            buf.extend_from_slice(&c.re.to_le_bytes());
            buf.extend_from_slice(&c.im.to_le_bytes());
        }
        self.out.write_all(&buf).map_err(|e| self.io(e))
    }

    /// Appends f32 elements.
    pub fn write_f4(&mut self, v: &[f32]) -> Result<()> {
        self.check(NpyType::F4, v.len())?;
        let buf: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.out.write_all(&buf).map_err(|e| self.io(e))
    }

    /// Appends f64 elements.
    pub fn write_f8(&mut self, v: &[f64]) -> Result<()> {
        self.check(NpyType::F8, v.len())?;
        let buf: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.out.write_all(&buf).map_err(|e| self.io(e))
    }

    /// Flushes; errors if fewer elements than the shape declares were written.
    pub fn finish(mut self) -> Result<()> {
        if self.written != self.expected {
            return Err(RadarError::format(
                &self.path,
                "data",
                format!("{} of {} elements written", self.written, self.expected),
            ));
        }
        self.out.flush().map_err(|e| self.io(e))
    }
}

/// An NPY file opened for reading: type, shape and the data offset.
#[derive(Debug)]
pub struct NpyReader {
    file: BufReader<File>,
    path: String,
    /// Element type.
    pub t: NpyType,
    /// Shape.
    pub shape: Vec<usize>,
    data_offset: u64,
}

impl NpyReader {
    /// Opens `path` and parses its header (v1/v2, C order, `<c8`/`<f4`/`<f8` only).
    pub fn open(path: &Path) -> Result<Self> {
        let shown = path.display().to_string();
        let bad = |loc: &str, why: String| RadarError::format(&shown, loc, why);
        let f = File::open(path).map_err(|e| RadarError::read(path, e))?;
        let mut file = BufReader::new(f);
        let mut pre = [0u8; 8];
        file.read_exact(&mut pre)
            .map_err(|e| RadarError::read(path, e))?;
        if &pre[..6] != b"\x93NUMPY" {
            return Err(bad("magic", "not an NPY file".into()));
        }
        let hlen = match pre[6] {
            1 => {
                let mut b = [0u8; 2];
                file.read_exact(&mut b)
                    .map_err(|e| RadarError::read(path, e))?;
                u16::from_le_bytes(b) as usize
            }
            2 | 3 => {
                let mut b = [0u8; 4];
                file.read_exact(&mut b)
                    .map_err(|e| RadarError::read(path, e))?;
                u32::from_le_bytes(b) as usize
            }
            v => return Err(bad("version", format!("unsupported NPY version {v}"))),
        };
        let mut h = vec![0u8; hlen];
        file.read_exact(&mut h)
            .map_err(|e| RadarError::read(path, e))?;
        let h = String::from_utf8_lossy(&h).to_string();
        let field = |key: &str| -> Result<String> {
            let k = format!("'{key}':");
            let i = h
                .find(&k)
                .ok_or_else(|| bad("header", format!("no `{key}`")))?;
            Ok(h[i + k.len()..].trim_start().to_string())
        };
        let descr = field("descr")?;
        let t = if descr.starts_with("'<c8'") {
            NpyType::C8
        } else if descr.starts_with("'<f4'") {
            NpyType::F4
        } else if descr.starts_with("'<f8'") {
            NpyType::F8
        } else {
            return Err(bad(
                "descr",
                format!("unsupported dtype {}", &descr[..descr.len().min(8)]),
            ));
        };
        if !field("fortran_order")?.starts_with("False") {
            return Err(bad("fortran_order", "only C order is supported".into()));
        }
        let sh = field("shape")?;
        let end = sh
            .find(')')
            .ok_or_else(|| bad("shape", "unterminated tuple".into()))?;
        let shape = sh[1..end]
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(|s| {
                s.parse::<usize>()
                    .map_err(|_| bad("shape", format!("`{s}` is not a size")))
            })
            .collect::<Result<Vec<_>>>()?;
        let data_offset = file
            .stream_position()
            .map_err(|e| RadarError::read(path, e))?;
        let bytes = shape
            .iter()
            .try_fold(t.size() as u64, |a, &d| a.checked_mul(d as u64))
            .ok_or_else(|| bad("shape", format!("{shape:?} overflows")))?;
        let len = std::fs::metadata(path)
            .map_err(|e| RadarError::read(path, e))?
            .len();
        if len < data_offset.saturating_add(bytes) {
            return Err(bad("data", format!("file too short for shape {shape:?}")));
        }
        Ok(Self {
            file,
            path: shown,
            t,
            shape,
            data_offset,
        })
    }

    fn read_bytes(&mut self, first: usize, count: usize, t: NpyType) -> Result<Vec<u8>> {
        if t != self.t {
            return Err(RadarError::format(
                &self.path,
                "descr",
                format!("expected {}", t.descr()),
            ));
        }
        let n: usize = self.shape.iter().product();
        if first.checked_add(count).is_none_or(|e| e > n) {
            return Err(RadarError::format(
                &self.path,
                "data",
                format!("{count} elements from {first} go beyond {n}"),
            ));
        }
        let path = self.path.clone();
        let io = |e| RadarError::Read {
            path: path.clone(),
            source: e,
        };
        self.file
            .seek(SeekFrom::Start(
                self.data_offset + (first * t.size()) as u64,
            ))
            .map_err(io)?;
        let mut b = vec![0u8; count * t.size()];
        self.file.read_exact(&mut b).map_err(io)?;
        Ok(b)
    }

    /// Reads `count` complex64 elements starting at element `first`.
    pub fn read_c8(&mut self, first: usize, count: usize) -> Result<Vec<Complex32>> {
        let b = self.read_bytes(first, count, NpyType::C8)?;
        Ok(b.chunks_exact(8)
            .map(|c| {
                Complex32::new(
                    f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                    f32::from_le_bytes([c[4], c[5], c[6], c[7]]),
                )
            })
            .collect())
    }

    /// Reads `count` f32 elements starting at element `first`.
    pub fn read_f4(&mut self, first: usize, count: usize) -> Result<Vec<f32>> {
        let b = self.read_bytes(first, count, NpyType::F4)?;
        Ok(b.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }

    /// Reads `count` f64 elements starting at element `first`.
    pub fn read_f8(&mut self, first: usize, count: usize) -> Result<Vec<f64>> {
        let b = self.read_bytes(first, count, NpyType::F8)?;
        Ok(b.chunks_exact(8)
            .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
            .collect())
    }
}

/// Writes `value` as pretty JSON.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| RadarError::format(path.display().to_string(), "JSON", e.to_string()))?;
    std::fs::write(path, text + "\n").map_err(|e| RadarError::io(path, e))
}

/// Writes CSV `rows` under `header` (values already formatted).
pub fn write_csv(path: &Path, header: &[&str], rows: &[Vec<String>]) -> Result<()> {
    let mut s = header.join(",");
    s.push('\n');
    for r in rows {
        s.push_str(&r.join(","));
        s.push('\n');
    }
    std::fs::write(path, s).map_err(|e| RadarError::io(path, e))
}

/// Reads a CSV file into (header, rows); the error names the file and line.
pub fn read_csv(path: &Path) -> Result<(Vec<String>, Vec<Vec<String>>)> {
    let text = std::fs::read_to_string(path).map_err(|e| RadarError::read(path, e))?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<String> = lines
        .next()
        .ok_or_else(|| RadarError::format(path.display().to_string(), "line 1", "empty file"))?
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|s| s.trim().to_string()).collect())
        .collect();
    Ok((header, rows))
}

/// Column accessor for [`read_csv`] output with errors naming file, line and column.
pub fn csv_f64(
    path: &Path,
    header: &[String],
    row: &[String],
    line: usize,
    col: &str,
) -> Result<f64> {
    let shown = path.display().to_string();
    let i = header
        .iter()
        .position(|h| h == col)
        .ok_or_else(|| RadarError::format(&shown, "header", format!("missing column `{col}`")))?;
    let s = row.get(i).ok_or_else(|| {
        RadarError::format(
            &shown,
            format!("line {line}, column {col}"),
            "missing value",
        )
    })?;
    s.parse::<f64>().map_err(|_| {
        RadarError::format(
            &shown,
            format!("line {line}, column {col}"),
            format!("`{s}` is not a number"),
        )
    })
}

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

/// `Err` naming `path` unless `power` holds a non-empty `ny × nx` image.
fn check_image_shape(path: &Path, power: &[f32], nx: usize, ny: usize) -> Result<()> {
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
fn peak_db(power: &[f32]) -> f64 {
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
    let f = File::create(path).map_err(|e| RadarError::io(path, e))?;
    let mut enc = png::Encoder::new(BufWriter::new(f), nx as u32, ny as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let shown = path.display().to_string();
    let mut w = enc
        .write_header()
        .map_err(|e| RadarError::format(&shown, "PNG", e.to_string()))?;
    w.write_image_data(&rgb)
        .map_err(|e| RadarError::format(&shown, "PNG", e.to_string()))
}

/// Dynamic range of the image files, dB below each image's peak (PNG and its SVG's colour bar).
pub const IMAGE_RANGE_DB: f64 = 40.0;

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

/// Writes an annotated SVG of a power image that [`write_png_db`] wrote to `png_name` in the
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
    std::fs::write(path, o).map_err(|e| RadarError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_round_trip_all_types() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.npy");
        let v: Vec<Complex32> = (0..12)
            .map(|i| Complex32::new(i as f32, -(i as f32) / 2.0))
            .collect();
        let mut w = NpyWriter::create(&p, NpyType::C8, &[3, 4]).unwrap();
        w.write_c8(&v[..5]).unwrap();
        w.write_c8(&v[5..]).unwrap();
        w.finish().unwrap();
        let mut r = NpyReader::open(&p).unwrap();
        assert_eq!(r.shape, vec![3, 4]);
        assert_eq!(r.read_c8(0, 12).unwrap(), v);
        assert_eq!(r.read_c8(4, 4).unwrap(), v[4..8].to_vec());
        // header length is a multiple of 64
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!((bytes.len() - 12 * 8) % 64, 0);
        let p2 = dir.path().join("b.npy");
        let mut w = NpyWriter::create(&p2, NpyType::F4, &[3]).unwrap();
        w.write_f4(&[1.0, 2.0, 3.5]).unwrap();
        w.finish().unwrap();
        assert_eq!(
            NpyReader::open(&p2).unwrap().read_f4(0, 3).unwrap(),
            vec![1.0, 2.0, 3.5]
        );
        let p3 = dir.path().join("c.npy");
        let mut w = NpyWriter::create(&p3, NpyType::F8, &[2, 1]).unwrap();
        w.write_f8(&[1.0, -2.0]).unwrap();
        w.finish().unwrap();
        assert_eq!(
            NpyReader::open(&p3).unwrap().read_f8(0, 2).unwrap(),
            vec![1.0, -2.0]
        );
    }

    #[test]
    fn npy_errors_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.npy");
        let w = NpyWriter::create(&p, NpyType::F4, &[4]).unwrap();
        let e = w.finish().unwrap_err().to_string();
        assert!(e.contains("a.npy") && e.contains("0 of 4"), "{e}");
        std::fs::write(&p, b"hello").unwrap();
        let e = NpyReader::open(&p).unwrap_err();
        assert!(e.to_string().contains("a.npy"), "{e}");
        assert!(e.is_bad_input(), "{e:?}");
        // a missing input is a read error (bad input), not a write error
        let e = NpyReader::open(&dir.path().join("none.npy")).unwrap_err();
        assert!(matches!(e, RadarError::Read { .. }), "{e:?}");
        // a header whose shape overflows: a named error, no panic
        let mut bytes = npy_header(NpyType::C8, &[usize::MAX / 2, 3]);
        bytes.extend_from_slice(&[0u8; 16]);
        std::fs::write(&p, &bytes).unwrap();
        let e = NpyReader::open(&p).unwrap_err().to_string();
        assert!(e.contains("a.npy") && e.contains("overflows"), "{e}");
        // reads beyond the data: named, also when first + count overflows
        let mut w = NpyWriter::create(&p, NpyType::F4, &[2]).unwrap();
        w.write_f4(&[1.0, 2.0]).unwrap();
        w.finish().unwrap();
        let mut r = NpyReader::open(&p).unwrap();
        let e = r.read_f4(usize::MAX, 2).unwrap_err().to_string();
        assert!(e.contains("go beyond 2"), "{e}");
    }

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
}
