//! NPY files (v1 written; v1–v3 read): complex64 `<c8`, `<f4` and `<f8` arrays in C order.
//! Header parsing by [`npyz`]; reading and writing stream whole slices (files of gigabytes).

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom, Write};
use std::path::Path;

use npyz::{DType, NpyHeader, Order};
use rustfft::num_complex::Complex32;

use super::atomic::AtomicFile;
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

    /// The type of a header's dtype (either byte order: the reader swaps).
    fn of(dtype: &DType) -> Option<Self> {
        let DType::Plain(t) = dtype else {
            return None;
        };
        match t.to_string().as_str() {
            "<c8" | ">c8" => Some(NpyType::C8),
            "<f4" | ">f4" => Some(NpyType::F4),
            "<f8" | ">f8" => Some(NpyType::F8),
            _ => None,
        }
    }
}

/// The v1 header that `numpy.save` writes, byte for byte: `(3, 4)` / `(3,)` shapes and the
/// header padded to a multiple of 64 bytes. Hand-made because npyz's writer pads to 16 and
/// writes `(3, 4, )`, which would change every NPY file's bytes.
pub(crate) fn npy_header(t: NpyType, shape: &[usize]) -> Vec<u8> {
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

/// Streaming NPY writer: the shape is fixed up front, data is appended in row-major order;
/// the file appears (atomically) at [`NpyWriter::finish`].
///
/// Each `write_*` converts its whole slice to little-endian bytes and writes them in one call:
/// npyz's writer goes element by element through its type writer, several times slower on the
/// IQ arrays (pulses × samples complex64, tens of MB per aperture).
#[derive(Debug)]
pub struct NpyWriter {
    out: AtomicFile,
    path: String,
    t: NpyType,
    expected: usize,
    written: usize,
}

impl NpyWriter {
    /// Starts `path` with element type `t` and `shape`.
    pub fn create(path: &Path, t: NpyType, shape: &[usize]) -> Result<Self> {
        let mut out = AtomicFile::create(path)?;
        out.write_all(&npy_header(t, shape))
            .map_err(|e| out.error(e))?;
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

    fn put(&mut self, buf: &[u8]) -> Result<()> {
        self.out.write_all(buf).map_err(|e| self.out.error(e))
    }

    /// Appends complex64 elements.
    pub fn write_c8(&mut self, v: &[Complex32]) -> Result<()> {
        self.check(NpyType::C8, v.len())?;
        let mut buf = Vec::with_capacity(v.len() * 8);
        for c in v {
            buf.extend_from_slice(&c.re.to_le_bytes());
            buf.extend_from_slice(&c.im.to_le_bytes());
        }
        self.put(&buf)
    }

    /// Appends f32 elements.
    pub fn write_f4(&mut self, v: &[f32]) -> Result<()> {
        self.check(NpyType::F4, v.len())?;
        let buf: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.put(&buf)
    }

    /// Appends f64 elements.
    pub fn write_f8(&mut self, v: &[f64]) -> Result<()> {
        self.check(NpyType::F8, v.len())?;
        let buf: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.put(&buf)
    }

    /// Writes the file; errors if fewer elements than the shape declares were written (the
    /// file is then not created).
    pub fn finish(self) -> Result<()> {
        if self.written != self.expected {
            return Err(RadarError::format(
                &self.path,
                "data",
                format!("{} of {} elements written", self.written, self.expected),
            ));
        }
        self.out.commit()
    }
}

/// Bytes read from an NPY file per `read_exact` call.
const READ_CHUNK_BYTES: usize = 8 << 20;

/// The f32 of 4 bytes (big- or little-endian).
fn f32_bytes(c: &[u8], big_endian: bool) -> f32 {
    let a: [u8; 4] = std::array::from_fn(|i| c[i]);
    if big_endian {
        f32::from_be_bytes(a)
    } else {
        f32::from_le_bytes(a)
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
    /// The data is big-endian (`>` in the dtype).
    big_endian: bool,
}

/// The header's bytes (preamble and dictionary), at most the file's length: the NPY framing
/// (magic, version, header length) read here so that a corrupt length cannot make the reader
/// allocate more than the file holds, and so that the shape can be checked before npyz
/// multiplies it out (unchecked: a panic in debug builds on a hostile header).
fn header_bytes(r: &mut impl Read, file_len: u64, shown: &str) -> Result<Vec<u8>> {
    let bad = |why: String| RadarError::format(shown, "header", why);
    let io = |e: std::io::Error| bad(format!("truncated ({e})"));
    let mut head = vec![0u8; 8];
    r.read_exact(&mut head).map_err(io)?;
    if &head[..6] != b"\x93NUMPY" {
        return Err(RadarError::format(shown, "magic", "not an NPY file"));
    }
    let text_len = match head[6] {
        1 => {
            let mut b = [0u8; 2];
            r.read_exact(&mut b).map_err(io)?;
            head.extend_from_slice(&b);
            u64::from(u16::from_le_bytes(b))
        }
        2 | 3 => {
            let mut b = [0u8; 4];
            r.read_exact(&mut b).map_err(io)?;
            head.extend_from_slice(&b);
            u64::from(u32::from_le_bytes(b))
        }
        v => {
            return Err(RadarError::format(
                shown,
                "version",
                format!("unsupported NPY version {v}"),
            ))
        }
    };
    if head.len() as u64 + text_len > file_len {
        return Err(bad(format!(
            "{text_len} header bytes declared, the file has {file_len} in all"
        )));
    }
    let start = head.len();
    head.resize(start + text_len as usize, 0);
    r.read_exact(&mut head[start..]).map_err(io)?;
    check_shape_product(&head[start..], shown)?;
    Ok(head)
}

/// `Err` naming the file when the header's `shape` multiplies out beyond u64. Anything else
/// wrong with the header is left to npyz, which reports it.
fn check_shape_product(text: &[u8], shown: &str) -> Result<()> {
    use py_literal::Value;
    let Some(Value::Dict(dict)) = std::str::from_utf8(text)
        .ok()
        .and_then(|s| s.trim_end().parse::<Value>().ok())
    else {
        return Ok(());
    };
    let dims = dict.iter().find_map(|(k, v)| match (k, v) {
        (Value::String(k), Value::Tuple(d) | Value::List(d)) if k == "shape" => Some(d),
        _ => None,
    });
    let dims: Option<Vec<u64>> = dims.and_then(|d| {
        d.iter()
            .map(|v| match v {
                Value::Integer(i) => u64::try_from(i).ok(),
                _ => None,
            })
            .collect()
    });
    match dims {
        Some(d) if d.iter().try_fold(1u64, |a, &x| a.checked_mul(x)).is_none() => Err(
            RadarError::format(shown, "shape", format!("{d:?} overflows")),
        ),
        _ => Ok(()),
    }
}

impl NpyReader {
    /// Opens `path` and parses its header (v1–v3, C order, `<c8`/`<f4`/`<f8` only, either
    /// byte order); checks that the file holds the data its shape declares.
    pub fn open(path: &Path) -> Result<Self> {
        let shown = path.display().to_string();
        let bad = |loc: &str, why: String| RadarError::format(&shown, loc, why);
        let f = File::open(path).map_err(|e| RadarError::read(path, e))?;
        let len = f.metadata().map_err(|e| RadarError::read(path, e))?.len();
        let mut file = BufReader::new(f);
        let head = header_bytes(&mut file, len, &shown)?;
        let header =
            NpyHeader::from_reader(head.as_slice()).map_err(|e| bad("header", e.to_string()))?;
        let t = NpyType::of(&header.dtype()).ok_or_else(|| {
            bad(
                "descr",
                format!("unsupported dtype {}", header.dtype().descr()),
            )
        })?;
        if header.order() != Order::C {
            return Err(bad("fortran_order", "only C order is supported".into()));
        }
        let shape = header
            .shape()
            .iter()
            .map(|&d| usize::try_from(d))
            .collect::<std::result::Result<Vec<usize>, _>>()
            .map_err(|_| bad("shape", format!("{:?} overflows", header.shape())))?;
        let data_offset = head.len() as u64;
        let bytes = shape
            .iter()
            .try_fold(t.size() as u64, |a, &d| a.checked_mul(d as u64))
            .ok_or_else(|| bad("shape", format!("{shape:?} overflows")))?;
        if len < data_offset.saturating_add(bytes) {
            return Err(bad("data", format!("file too short for shape {shape:?}")));
        }
        let big_endian =
            matches!(header.dtype(), DType::Plain(p) if p.to_string().starts_with('>'));
        Ok(Self {
            file,
            path: shown,
            t,
            shape,
            data_offset,
            big_endian,
        })
    }

    /// `count` elements of type `t` from element `first`, as their raw bytes converted by
    /// `convert` (its second argument: the file is big-endian) into `out`, in chunks of at most
    /// [`READ_CHUNK_BYTES`]: one `read_exact` per chunk, no per-element reader (the IQ arrays
    /// are gigabytes).
    fn read<T>(
        &mut self,
        first: usize,
        count: usize,
        t: NpyType,
        convert: fn(&[u8], bool, &mut Vec<T>),
    ) -> Result<Vec<T>> {
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
            error: e,
        };
        let size = t.size();
        let big_endian = self.big_endian;
        // first + count ≤ n and the file holds n elements (checked at open): no overflow
        self.file
            .seek(SeekFrom::Start(self.data_offset + (first * size) as u64))
            .map_err(io)?;
        let mut out = Vec::with_capacity(count);
        let per_chunk = (READ_CHUNK_BYTES / size).max(1);
        let mut buf = vec![0u8; per_chunk.min(count) * size];
        let mut left = count;
        while left > 0 {
            let k = left.min(per_chunk);
            let bytes = &mut buf[..k * size];
            self.file.read_exact(bytes).map_err(io)?;
            convert(bytes, big_endian, &mut out);
            left -= k;
        }
        Ok(out)
    }

    /// Reads `count` complex64 elements starting at element `first`.
    pub fn read_c8(&mut self, first: usize, count: usize) -> Result<Vec<Complex32>> {
        self.read(first, count, NpyType::C8, |b, be, out| {
            out.extend(b.chunks_exact(8).map(|c| {
                let (re, im) = (f32_bytes(&c[..4], be), f32_bytes(&c[4..], be));
                Complex32::new(re, im)
            }))
        })
    }

    /// Reads `count` f32 elements starting at element `first`.
    pub fn read_f4(&mut self, first: usize, count: usize) -> Result<Vec<f32>> {
        self.read(first, count, NpyType::F4, |b, be, out| {
            out.extend(b.chunks_exact(4).map(|c| f32_bytes(c, be)))
        })
    }

    /// Reads `count` f64 elements starting at element `first`.
    pub fn read_f8(&mut self, first: usize, count: usize) -> Result<Vec<f64>> {
        self.read(first, count, NpyType::F8, |b, be, out| {
            out.extend(b.chunks_exact(8).map(|c| {
                let a: [u8; 8] = std::array::from_fn(|i| c[i]);
                if be {
                    f64::from_be_bytes(a)
                } else {
                    f64::from_le_bytes(a)
                }
            }))
        })
    }
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

    /// The header is numpy.save's, byte for byte; npyz reads it; files that npyz (or numpy in
    /// another layout: v2, big-endian) wrote read back.
    #[test]
    fn headers_match_numpy_and_other_writers_read_back() {
        let h = npy_header(NpyType::C8, &[3, 4]);
        assert_eq!(
            &h[10..],
            format!(
                "{{'descr': '<c8', 'fortran_order': False, 'shape': (3, 4), }}{}\n",
                " ".repeat(58)
            )
            .as_bytes()
        );
        assert_eq!(h.len(), 128);
        let hdr = NpyHeader::from_reader(h.as_slice()).unwrap();
        assert_eq!(hdr.shape(), &[3, 4]);
        assert_eq!(NpyType::of(&hdr.dtype()), Some(NpyType::C8));
        let tail = format!("'shape': (7,), }}{}\n", " ".repeat(60));
        assert!(npy_header(NpyType::F4, &[7]).ends_with(tail.as_bytes()));

        let dir = tempfile::tempdir().unwrap();
        // npyz's own layout: `(2, 3, )`, 16-byte alignment
        let p = dir.path().join("npyz.npy");
        let mut bytes = Vec::new();
        {
            use npyz::WriterBuilder;
            let mut w = npyz::WriteOptions::new()
                .default_dtype()
                .shape(&[2, 3])
                .writer(&mut bytes)
                .begin_nd()
                .unwrap();
            for x in 0..6 {
                w.push(&(x as f64 * 0.5)).unwrap();
            }
            w.finish().unwrap();
        }
        std::fs::write(&p, &bytes).unwrap();
        let mut r = NpyReader::open(&p).unwrap();
        assert_eq!((r.t, r.shape.clone()), (NpyType::F8, vec![2, 3]));
        assert_eq!(r.read_f8(1, 3).unwrap(), vec![0.5, 1.0, 1.5]);
        // version 2 (u32 header length), big-endian complex64
        let dict = "{'descr': '>c8', 'fortran_order': False, 'shape': (2,), }\n";
        let mut b = b"\x93NUMPY\x02\x00".to_vec();
        b.extend_from_slice(&(dict.len() as u32).to_le_bytes());
        b.extend_from_slice(dict.as_bytes());
        for x in [1.0f32, -2.0, 3.0, 0.25] {
            b.extend_from_slice(&x.to_be_bytes());
        }
        std::fs::write(&p, &b).unwrap();
        let mut r = NpyReader::open(&p).unwrap();
        assert_eq!(
            r.read_c8(0, 2).unwrap(),
            vec![Complex32::new(1.0, -2.0), Complex32::new(3.0, 0.25)]
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
        // the wrong element type for the file
        let e = r.read_c8(0, 1).unwrap_err().to_string();
        assert!(e.contains("a.npy") && e.contains("<c8"), "{e}");
    }

    /// Bad headers: each a format error (bad input) naming the file and what is wrong.
    #[test]
    fn bad_headers_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.npy");
        let with_dict = |version: u8, dict: &str, data: usize| {
            let mut b = vec![0x93, b'N', b'U', b'M', b'P', b'Y', version, 0];
            b.extend_from_slice(&(dict.len() as u16).to_le_bytes());
            b.extend_from_slice(dict.as_bytes());
            b.extend(std::iter::repeat_n(0u8, data));
            b
        };
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (b"\x93NUMPX\x01\x00\x10\x00".to_vec(), "not an NPY file"),
            (with_dict(7, "{}", 0), "version 7"),
            (with_dict(1, "{'descr': '<f4', 'shape': (2,)", 8), "header"),
            (
                with_dict(1, "{'descr': '<f4', 'shape': (2,), }\n", 8),
                "fortran_order",
            ),
            (
                with_dict(
                    1,
                    "{'descr': '<i2', 'fortran_order': False, 'shape': (2,), }\n",
                    8,
                ),
                "unsupported dtype",
            ),
            (
                with_dict(
                    1,
                    "{'descr': '<f4', 'fortran_order': True, 'shape': (2, 2), }\n",
                    16,
                ),
                "only C order",
            ),
            (
                with_dict(
                    1,
                    "{'descr': '<f4', 'fortran_order': False, 'shape': (-2,), }\n",
                    8,
                ),
                "negative",
            ),
            (
                with_dict(
                    1,
                    "{'descr': '<f4', 'fortran_order': False, 'shape': (3,), }\n",
                    8,
                ),
                "too short",
            ),
        ];
        for (bytes, why) in cases {
            std::fs::write(&p, &bytes).unwrap();
            let e = NpyReader::open(&p).unwrap_err();
            assert!(e.is_bad_input(), "{why}: {e:?}");
            let s = e.to_string();
            assert!(s.contains("bad.npy") && s.contains(why), "{why}: {s}");
        }
        // a header length beyond the file: refused before anything is allocated
        let mut b = b"\x93NUMPY\x02\x00".to_vec();
        b.extend_from_slice(&u32::MAX.to_le_bytes());
        std::fs::write(&p, &b).unwrap();
        let s = NpyReader::open(&p).unwrap_err().to_string();
        assert!(
            s.contains("bad.npy") && s.contains("header bytes declared"),
            "{s}"
        );
    }

    /// A writer dropped or finished short leaves no file (and no partial one).
    #[test]
    fn unfinished_writers_leave_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.npy");
        let mut w = NpyWriter::create(&p, NpyType::F4, &[4]).unwrap();
        w.write_f4(&[1.0]).unwrap();
        drop(w);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let e = NpyWriter::create(&dir.path().join("no/a.npy"), NpyType::F4, &[1]).unwrap_err();
        assert!(
            matches!(e, RadarError::Io { .. }) && e.to_string().contains("a.npy"),
            "{e}"
        );
    }
}
