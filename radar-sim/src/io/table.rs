//! CSV tables of serde rows (the `csv` crate), with fixed number formats for float columns.

use std::path::Path;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::atomic::write_atomic;
use crate::error::{RadarError, Result};

/// A float written with `D` decimals (`{:.D}`) and read back as any number.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Fixed<const D: usize>(pub f64);

/// A float written in scientific notation with `D` decimals (`{:.De}`, e.g. `1.000000e1`) and
/// read back as any number.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Sci<const D: usize>(pub f64);

impl<const D: usize> Serialize for Fixed<D> {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.collect_str(&format_args!("{:.*}", D, self.0))
    }
}

impl<'de, const D: usize> Deserialize<'de> for Fixed<D> {
    fn deserialize<De: Deserializer<'de>>(d: De) -> std::result::Result<Self, De::Error> {
        f64::deserialize(d).map(Fixed)
    }
}

impl<const D: usize> Serialize for Sci<D> {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.collect_str(&format_args!("{:.*e}", D, self.0))
    }
}

impl<'de, const D: usize> Deserialize<'de> for Sci<D> {
    fn deserialize<De: Deserializer<'de>>(d: De) -> std::result::Result<Self, De::Error> {
        f64::deserialize(d).map(Sci)
    }
}

impl<const D: usize> Fixed<D> {
    /// The value as written and read back: rounded to `D` decimals (NaN stays NaN).
    pub fn as_written(self) -> f64 {
        format!("{:.*}", D, self.0).parse().unwrap_or(f64::NAN)
    }
}

impl<const D: usize> Sci<D> {
    /// The value as written and read back: rounded to `D + 1` significant digits.
    pub fn as_written(self) -> f64 {
        format!("{:.*e}", D, self.0).parse().unwrap_or(f64::NAN)
    }
}

/// Writes `rows` under `header` as CSV (atomically). The header is written even without rows;
/// it must name the row type's fields in order (each table's tests check that).
pub fn write_csv_rows<R: Serialize>(
    path: &Path,
    header: &[&str],
    rows: impl IntoIterator<Item = R>,
) -> Result<()> {
    write_atomic(path, |f| {
        let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(f);
        let err = |row: usize, e: csv::Error| {
            let why = e.to_string();
            match e.into_kind() {
                csv::ErrorKind::Io(e) => RadarError::io(path, e),
                _ => RadarError::format(path.display().to_string(), format!("row {row}"), why),
            }
        };
        w.write_record(header).map_err(|e| err(0, e))?;
        for (i, r) in rows.into_iter().enumerate() {
            w.serialize(r).map_err(|e| err(i + 1, e))?;
        }
        w.flush().map_err(|e| RadarError::io(path, e))
    })
}

/// Reads the CSV file `path` into rows, the columns matched by name (extra columns ignored,
/// cells trimmed). A missing or malformed value is an error naming the file, the line and the
/// column.
pub fn read_csv_rows<R: DeserializeOwned>(path: &Path) -> Result<Vec<R>> {
    let shown = path.display().to_string();
    let f = std::fs::File::open(path).map_err(|e| RadarError::read(path, e))?;
    let mut rd = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(std::io::BufReader::new(f));
    let header = rd.headers().map_err(|e| read_error(path, None, e))?.clone();
    if header.iter().all(str::is_empty) {
        return Err(RadarError::format(shown, "line 1", "empty file"));
    }
    rd.deserialize()
        .map(|r| r.map_err(|e| read_error(path, Some(&header), e)))
        .collect()
}

/// A CSV reading error as [`RadarError`]: I/O as [`RadarError::Read`], the rest as
/// [`RadarError::Format`] at its line (and column, by its header name).
fn read_error(path: &Path, header: Option<&csv::StringRecord>, e: csv::Error) -> RadarError {
    let line = e
        .position()
        .map(|p| format!("line {}", p.line()))
        .unwrap_or_else(|| "CSV".into());
    let (loc, why) = match e.kind() {
        csv::ErrorKind::Deserialize { err, .. } => {
            let col = err
                .field()
                .and_then(|k| header?.get(usize::try_from(k).ok()?));
            let loc = match col {
                Some(c) => format!("{line}, column {c}"),
                None => line,
            };
            (loc, err.kind().to_string())
        }
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => (
            line,
            format!("{len} fields where the header has {expected_len}"),
        ),
        _ => (line, e.to_string()),
    };
    match e.into_kind() {
        csv::ErrorKind::Io(e) => RadarError::read(path, e),
        _ => RadarError::format(path.display().to_string(), loc, why),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Row {
        id: usize,
        x_m: Fixed<3>,
        rcs: Sci<2>,
        #[serde(default, deserialize_with = "csv::invalid_option")]
        tag: Option<usize>,
    }

    #[test]
    fn rows_round_trip_with_fixed_formats() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        let rows = [
            Row {
                id: 1,
                x_m: Fixed(-0.0454),
                rcs: Sci(10.0),
                tag: Some(3),
            },
            Row {
                id: 2,
                x_m: Fixed(f64::NAN),
                rcs: Sci(0.5),
                tag: None,
            },
        ];
        write_csv_rows(&p, &["id", "x_m", "rcs", "tag"], &rows).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert_eq!(text, "id,x_m,rcs,tag\n1,-0.045,1.00e1,3\n2,NaN,5.00e-1,\n");
        let back: Vec<Row> = read_csv_rows(&p).unwrap();
        assert_eq!(
            back[0],
            Row {
                x_m: Fixed(-0.045),
                ..rows[0]
            }
        );
        assert!(back[1].x_m.0.is_nan() && back[1].tag.is_none());
        // header only
        write_csv_rows::<Row>(&p, &["id", "x_m", "rcs", "tag"], []).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "id,x_m,rcs,tag\n");
        assert!(read_csv_rows::<Row>(&p).unwrap().is_empty());
    }

    #[test]
    fn reading_errors_name_file_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        let check = |text: &str, want: &[&str]| {
            std::fs::write(&p, text).unwrap();
            let e = read_csv_rows::<Row>(&p).unwrap_err();
            assert!(e.is_bad_input(), "{e:?}");
            let s = e.to_string();
            for w in want {
                assert!(s.contains(w), "{w}: {s}");
            }
        };
        check(
            "id,x_m,rcs\n1,2,3\n2, zz ,3\n",
            &["t.csv", "line 3", "column x_m", "float"],
        );
        check("id,rcs\n1,3\n", &["t.csv", "line 2", "x_m"]);
        check("id,x_m,rcs\n1,2\n", &["t.csv", "line 2", "2 fields"]);
        check("", &["t.csv", "empty file"]);
        // columns by name, in any order, extra ones ignored, cells trimmed; a bad optional
        // value is no value
        std::fs::write(&p, "rcs, x_m ,extra,id,tag\n1e1, 2.5 ,x,4,zz\n").unwrap();
        let r: Vec<Row> = read_csv_rows(&p).unwrap();
        assert_eq!(
            r,
            vec![Row {
                id: 4,
                x_m: Fixed(2.5),
                rcs: Sci(10.0),
                tag: None
            }]
        );
        let e = read_csv_rows::<Row>(&dir.path().join("none.csv")).unwrap_err();
        assert!(matches!(e, RadarError::Read { .. }), "{e:?}");
    }
}
