//! File formats: NPY v1 (complex64 `<c8`, `<f4`, `<f8`; streaming writer; reading by npyz),
//! CSV tables of serde rows, JSON, PNG images in dB with a perceptual colormap and where they lie on
//! the ground ([`ImageFrame`], for the apps layer's annotated SVG views). Every output file is written atomically ([`AtomicFile`]).

use std::path::Path;

use serde::Serialize;

use crate::error::{RadarError, Result};

mod atomic;
mod image;
mod npy;
mod table;

pub use atomic::{write_atomic, write_bytes, AtomicFile};
pub use image::{check_image_shape, peak_db, viridis, write_png_db, ImageFrame, IMAGE_RANGE_DB};
pub use npy::{NpyReader, NpyType, NpyWriter};
pub use table::{read_csv_rows, write_csv_rows, Fixed, Sci};

/// Writes `value` as pretty JSON (and a final newline), atomically.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| RadarError::format(path.display().to_string(), "JSON", e.to_string()))?;
    write_bytes(path, (text + "\n").as_bytes())
}
