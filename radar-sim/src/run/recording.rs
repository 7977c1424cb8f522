//! The recording's CSV tables: `pulses.csv` and `truth.csv` (written by `simulate`, read by
//! `process`) and `detections.csv`, each a serde row type with the number formats of its
//! columns.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::DetectionRow;
use crate::error::Result;
use crate::io::{read_csv_rows, write_csv_rows, write_json, Fixed, Sci};
use crate::scene::SceneObject;
use crate::track::PulseMeta;

/// Columns of `pulses.csv`, the fields of [`PulseRow`] in order.
const PULSE_COLUMNS: [&str; 14] = [
    "index",
    "aperture",
    "look",
    "t_s",
    "symbol",
    "x_m",
    "y_m",
    "z_m",
    "vx_mps",
    "vy_mps",
    "vz_mps",
    "heading_x",
    "heading_y",
    "window_delay_samples",
];

/// One row of `pulses.csv`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
struct PulseRow {
    index: usize,
    aperture: usize,
    look: usize,
    t_s: Fixed<9>,
    symbol: u64,
    x_m: Fixed<6>,
    y_m: Fixed<6>,
    z_m: Fixed<6>,
    vx_mps: Fixed<6>,
    vy_mps: Fixed<6>,
    vz_mps: Fixed<6>,
    heading_x: Fixed<12>,
    heading_y: Fixed<12>,
    window_delay_samples: i64,
}

impl From<&PulseMeta> for PulseRow {
    fn from(p: &PulseMeta) -> Self {
        Self {
            index: p.index,
            aperture: p.aperture,
            look: p.look,
            t_s: Fixed(p.t_s),
            symbol: p.symbol,
            x_m: Fixed(p.pos_m[0]),
            y_m: Fixed(p.pos_m[1]),
            z_m: Fixed(p.pos_m[2]),
            vx_mps: Fixed(p.vel_mps[0]),
            vy_mps: Fixed(p.vel_mps[1]),
            vz_mps: Fixed(p.vel_mps[2]),
            heading_x: Fixed(p.heading[0]),
            heading_y: Fixed(p.heading[1]),
            window_delay_samples: p.window_delay_samples,
        }
    }
}

impl PulseRow {
    /// The pulse with every float as written (`as_written`: rounded to its column's format).
    fn to_pulse(self, as_written: bool) -> PulseMeta {
        let f = |v: Fixed<6>| if as_written { v.as_written() } else { v.0 };
        let (t_s, hx, hy) = if as_written {
            (
                self.t_s.as_written(),
                self.heading_x.as_written(),
                self.heading_y.as_written(),
            )
        } else {
            (self.t_s.0, self.heading_x.0, self.heading_y.0)
        };
        PulseMeta {
            index: self.index,
            aperture: self.aperture,
            look: self.look,
            t_s,
            symbol: self.symbol,
            pos_m: [f(self.x_m), f(self.y_m), f(self.z_m)],
            vel_mps: [f(self.vx_mps), f(self.vy_mps), f(self.vz_mps)],
            heading: [hx, hy],
            window_delay_samples: self.window_delay_samples,
        }
    }
}

/// Columns of `truth.csv`, the fields of [`TruthRow`] in order.
const TRUTH_COLUMNS: [&str; 6] = ["id", "x_m", "y_m", "rcs_m2", "phase_rad", "landmark"];

/// One row of `truth.csv`; `phase_rad` and `landmark` may be absent when reading (0 and none),
/// and a landmark that is no index reads as none.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
struct TruthRow {
    id: usize,
    x_m: Fixed<6>,
    y_m: Fixed<6>,
    rcs_m2: Sci<6>,
    #[serde(default)]
    phase_rad: Fixed<9>,
    #[serde(default, deserialize_with = "csv::invalid_option")]
    landmark: Option<usize>,
}

impl From<&SceneObject> for TruthRow {
    fn from(o: &SceneObject) -> Self {
        Self {
            id: o.id,
            x_m: Fixed(o.x_m),
            y_m: Fixed(o.y_m),
            rcs_m2: Sci(o.rcs_m2),
            phase_rad: Fixed(o.phase_rad),
            landmark: o.landmark,
        }
    }
}

impl From<TruthRow> for SceneObject {
    fn from(r: TruthRow) -> Self {
        Self {
            id: r.id,
            x_m: r.x_m.0,
            y_m: r.y_m.0,
            rcs_m2: r.rcs_m2.0,
            phase_rad: r.phase_rad.0,
            landmark: r.landmark,
        }
    }
}

/// Columns of `detections.csv`, the fields of [`DetectionCsvRow`] in order.
const DETECTION_COLUMNS: [&str; 7] = [
    "aperture", "x_m", "y_m", "snr_db", "pixels", "truth_id", "error_m",
];

/// One row of `detections.csv` ([`DetectionRow`] with the CSV's number formats).
#[derive(Debug, Clone, Copy, Serialize)]
struct DetectionCsvRow {
    aperture: usize,
    x_m: Fixed<3>,
    y_m: Fixed<3>,
    snr_db: Fixed<2>,
    pixels: usize,
    truth_id: Option<usize>,
    error_m: Option<Fixed<3>>,
}

impl From<&DetectionRow> for DetectionCsvRow {
    fn from(d: &DetectionRow) -> Self {
        Self {
            aperture: d.aperture,
            x_m: Fixed(d.x_m),
            y_m: Fixed(d.y_m),
            snr_db: Fixed(d.snr_db),
            pixels: d.pixels,
            truth_id: d.truth_id,
            error_m: d.error_m.map(Fixed),
        }
    }
}

/// Writes `pulses.csv`.
pub(super) fn write_pulses(path: &Path, pulses: &[PulseMeta]) -> Result<()> {
    write_csv_rows(path, &PULSE_COLUMNS, pulses.iter().map(PulseRow::from))
}

/// Writes `truth.csv`.
pub(super) fn write_truth(path: &Path, objects: &[SceneObject]) -> Result<()> {
    write_csv_rows(path, &TRUTH_COLUMNS, objects.iter().map(TruthRow::from))
}

/// Reads `truth.csv` (columns id,x_m,y_m,rcs_m2; phase_rad and landmark optional).
pub fn read_truth(path: &Path) -> Result<Vec<SceneObject>> {
    let rows: Vec<TruthRow> = read_csv_rows(path)?;
    Ok(rows.into_iter().map(SceneObject::from).collect())
}

/// Reads `pulses.csv`.
pub fn read_pulses(path: &Path) -> Result<Vec<PulseMeta>> {
    let rows: Vec<PulseRow> = read_csv_rows(path)?;
    Ok(rows.into_iter().map(|r| r.to_pulse(false)).collect())
}

/// The pulse as [`read_pulses`] reads it back from `pulses.csv` (every float rounded to its
/// column's format), so that a processor fed directly sees the file-based one's inputs.
pub fn pulse_as_recorded(p: &PulseMeta) -> PulseMeta {
    PulseRow::from(p).to_pulse(true)
}

/// The object as [`read_truth`] reads it back from `truth.csv` (same number formats).
pub fn object_as_recorded(o: &SceneObject) -> SceneObject {
    let r = TruthRow::from(o);
    SceneObject {
        x_m: r.x_m.as_written(),
        y_m: r.y_m.as_written(),
        rcs_m2: r.rcs_m2.as_written(),
        phase_rad: r.phase_rad.as_written(),
        ..*o
    }
}

/// Writes `detections.csv` and `detections.json` into `out`.
pub fn write_detections(out: &Path, rows: &[DetectionRow]) -> Result<()> {
    write_csv_rows(
        &out.join("detections.csv"),
        &DETECTION_COLUMNS,
        rows.iter().map(DetectionCsvRow::from),
    )?;
    write_json(&out.join("detections.json"), &rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The header each table writes is its row type's field names (what serde reads by).
    fn serde_header<R: Serialize>(row: R) -> String {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(row).unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        text.lines().next().unwrap().to_string()
    }

    fn pulse() -> PulseMeta {
        PulseMeta {
            index: 7,
            aperture: 1,
            look: 2,
            t_s: 0.015_000_000_4,
            symbol: 720,
            pos_m: [-1_000.101_326_4, -499.747_686, 1_000.0],
            vel_mps: [-6.755_076, 16.820_923_4, 0.0],
            heading: [-0.372_660_444_772_3, 0.927_967_775_789],
            window_delay_samples: -465,
        }
    }

    fn object() -> SceneObject {
        SceneObject {
            id: 1,
            x_m: -15.112_006_2,
            y_m: 30.698_073,
            rcs_m2: 5.0,
            phase_rad: 0.525_511_558_3,
            landmark: None,
        }
    }

    #[test]
    fn headers_are_the_row_fields() {
        assert_eq!(
            serde_header(PulseRow::from(&pulse())),
            PULSE_COLUMNS.join(",")
        );
        assert_eq!(
            serde_header(TruthRow::from(&object())),
            TRUTH_COLUMNS.join(",")
        );
        let d = DetectionRow {
            aperture: 0,
            x_m: 0.0,
            y_m: 0.0,
            snr_db: 0.0,
            pixels: 1,
            truth_id: None,
            error_m: None,
        };
        assert_eq!(
            serde_header(DetectionCsvRow::from(&d)),
            DETECTION_COLUMNS.join(",")
        );
    }

    /// The formats of every column, as the files have always had them, and the round trip to
    /// the `*_as_recorded` values.
    #[test]
    fn tables_keep_their_formats_and_read_back_as_recorded() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("pulses.csv");
        write_pulses(&p, &[pulse()]).unwrap();
        assert_eq!(
            std::fs::read_to_string(&p).unwrap(),
            format!(
                "{}\n7,1,2,0.015000000,720,-1000.101326,-499.747686,1000.000000,-6.755076,16.820923,0.000000,-0.372660444772,0.927967775789,-465\n",
                PULSE_COLUMNS.join(",")
            )
        );
        assert_eq!(read_pulses(&p).unwrap(), vec![pulse_as_recorded(&pulse())]);
        let t = dir.path().join("truth.csv");
        let lm = SceneObject {
            id: 0,
            rcs_m2: 10.0,
            landmark: Some(0),
            ..object()
        };
        write_truth(&t, &[lm, object()]).unwrap();
        let text = std::fs::read_to_string(&t).unwrap();
        assert_eq!(
            text,
            "id,x_m,y_m,rcs_m2,phase_rad,landmark\n\
             0,-15.112006,30.698073,1.000000e1,0.525511558,0\n\
             1,-15.112006,30.698073,5.000000e0,0.525511558,\n"
        );
        assert_eq!(
            read_truth(&t).unwrap(),
            vec![object_as_recorded(&lm), object_as_recorded(&object())]
        );
        // the old optional columns: absent → phase 0, no landmark
        std::fs::write(&t, "id,x_m,y_m,rcs_m2\n3,1.5,-2,1e1\n").unwrap();
        let o = read_truth(&t).unwrap();
        assert_eq!((o[0].id, o[0].phase_rad, o[0].landmark), (3, 0.0, None));
        let rows = [
            DetectionRow {
                aperture: 0,
                x_m: -0.0454,
                y_m: 0.005,
                snr_db: 43.856,
                pixels: 3404,
                truth_id: Some(0),
                error_m: Some(0.0454),
            },
            DetectionRow {
                aperture: 2,
                x_m: 10.0,
                y_m: f64::NAN,
                snr_db: 13.0,
                pixels: 1,
                truth_id: None,
                error_m: None,
            },
        ];
        write_detections(dir.path(), &rows).unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.path().join("detections.csv")).unwrap(),
            "aperture,x_m,y_m,snr_db,pixels,truth_id,error_m\n\
             0,-0.045,0.005,43.86,3404,0,0.045\n\
             2,10.000,NaN,13.00,1,,\n"
        );
        write_detections(dir.path(), &[]).unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.path().join("detections.csv")).unwrap(),
            "aperture,x_m,y_m,snr_db,pixels,truth_id,error_m\n"
        );
    }

    /// A malformed pulses.csv names the file, the line and the column.
    #[test]
    fn bad_tables_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("pulses.csv");
        write_pulses(&p, &[pulse(), pulse()]).unwrap();
        let text = std::fs::read_to_string(&p)
            .unwrap()
            .replace("-6.755076", "fast");
        std::fs::write(&p, text).unwrap();
        let e = read_pulses(&p).unwrap_err();
        assert!(e.is_bad_input(), "{e:?}");
        let s = e.to_string();
        for w in ["pulses.csv", "line 2", "column vx_mps"] {
            assert!(s.contains(w), "{w}: {s}");
        }
    }
}
