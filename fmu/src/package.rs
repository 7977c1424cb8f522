//! Packaging: the `.fmu` zip archive (written with the `zip` crate, deflated) holding
//! `modelDescription.xml`, the shared library under `binaries/<platform>/<modelIdentifier>.so`
//! and `resources/`.

use std::io::{Cursor, Write as _};

use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime};

use crate::core::{FmiVersion, ModelInfo};
use crate::xml;

/// The binaries folder of the platform for an FMI version (Linux x86-64 only).
pub fn platform_dir(version: FmiVersion) -> &'static str {
    match version {
        FmiVersion::Fmi2 => "linux64",
        FmiVersion::Fmi3 => "x86_64-linux",
    }
}

/// The archive entries of an FMU: (path, content, executable).
pub fn entries(
    info: &ModelInfo,
    version: FmiVersion,
    library: &[u8],
) -> Vec<(String, Vec<u8>, bool)> {
    let mut e = vec![(
        "modelDescription.xml".to_string(),
        xml::model_description(info, version).into_bytes(),
        false,
    )];
    e.push((
        format!("binaries/{}/{}.so", platform_dir(version), info.identifier),
        library.to_vec(),
        true,
    ));
    for (name, content) in info.resources {
        e.push((
            format!("resources/{name}"),
            content.as_bytes().to_vec(),
            false,
        ));
    }
    e
}

/// An error while writing an FMU archive, naming the archive entry it concerns (the zip
/// writer's error is in the message, not also a `source()`).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PackageError {
    /// Adding an entry (header or data) to the archive failed.
    #[error("adding {name} to the FMU archive: {error}")]
    Entry {
        /// The entry's path inside the archive.
        name: String,
        /// The zip writer's error (in the message).
        error: zip::result::ZipError,
    },
    /// Writing the central directory failed.
    #[error("finishing the FMU archive (central directory): {0}")]
    Finish(zip::result::ZipError),
}

/// The `.fmu` archive of a model.
pub fn fmu_archive(
    info: &ModelInfo,
    version: FmiVersion,
    library: &[u8],
) -> Result<Vec<u8>, PackageError> {
    let mut zip = ZipWriter::default();
    for (name, data, exec) in entries(info, version, library) {
        zip.add(&name, &data, exec)?;
    }
    zip.finish()
}

/// A zip writer for FMU archives (over the `zip` crate): deflated files, UTF-8 names, a fixed
/// timestamp (1980-01-01) so archives are reproducible, Unix permissions (0755 for the shared
/// library, 0644 otherwise). Entries of 4 GiB or more are written as zip64.
pub struct ZipWriter {
    inner: zip::ZipWriter<Cursor<Vec<u8>>>,
}

impl Default for ZipWriter {
    fn default() -> Self {
        Self {
            inner: zip::ZipWriter::new(Cursor::new(Vec::new())),
        }
    }
}

impl ZipWriter {
    /// Adds a file; errors name it.
    pub fn add(&mut self, name: &str, data: &[u8], executable: bool) -> Result<(), PackageError> {
        let entry_err = |error| PackageError::Entry {
            name: name.to_string(),
            error,
        };
        let options = SimpleFileOptions::default()
            .compression_method(CompressionMethod::Deflated)
            .last_modified_time(DateTime::default())
            .unix_permissions(if executable { 0o755 } else { 0o644 })
            .large_file(u32::try_from(data.len()).is_err());
        self.inner.start_file(name, options).map_err(entry_err)?;
        self.inner
            .write_all(data)
            .map_err(|e| entry_err(zip::result::ZipError::Io(e)))
    }

    /// Writes the central directory and returns the archive.
    pub fn finish(self) -> Result<Vec<u8>, PackageError> {
        self.inner
            .finish()
            .map(Cursor::into_inner)
            .map_err(PackageError::Finish)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::{MOVER_INFO, PLANNER_INFO};

    #[test]
    fn entries_of_both_versions() {
        let names = |v| {
            entries(&PLANNER_INFO, v, b"lib")
                .into_iter()
                .map(|e| e.0)
                .collect::<Vec<_>>()
        };
        assert_eq!(
            names(FmiVersion::Fmi2),
            [
                "modelDescription.xml",
                "binaries/linux64/CellsarPlanner.so",
                "resources/default_mission.toml"
            ]
        );
        assert_eq!(
            names(FmiVersion::Fmi3)[1],
            "binaries/x86_64-linux/CellsarPlanner.so"
        );
        assert_eq!(entries(&MOVER_INFO, FmiVersion::Fmi3, b"").len(), 2);
    }

    #[test]
    fn archive_layout() {
        let mut z = ZipWriter::default();
        let big = vec![b'a'; 10_000];
        z.add("a/b.txt", &big, false).unwrap();
        z.add("x", b"y", true).unwrap();
        let bytes = z.finish().unwrap();
        assert_eq!(&bytes[..4], &[0x50, 0x4b, 0x03, 0x04]);
        // deflated: far smaller than the content
        assert!(bytes.len() < 1000, "{}", bytes.len());
        let eocd = &bytes[bytes.len() - 22..];
        assert_eq!(&eocd[..4], &0x0605_4b50u32.to_le_bytes());
        assert_eq!(u16::from_le_bytes([eocd[10], eocd[11]]), 2);
    }

    #[test]
    fn archive_round_trip() {
        let bytes = fmu_archive(&PLANNER_INFO, FmiVersion::Fmi3, b"library").unwrap();
        let mut a = zip::ZipArchive::new(Cursor::new(bytes)).unwrap();
        assert_eq!(a.len(), 3);
        let lib = a
            .by_name("binaries/x86_64-linux/CellsarPlanner.so")
            .unwrap();
        assert_eq!(lib.unix_mode().map(|m| m & 0o777), Some(0o755));
        drop(lib);
        let mut xml = String::new();
        std::io::Read::read_to_string(&mut a.by_name("modelDescription.xml").unwrap(), &mut xml)
            .unwrap();
        assert_eq!(xml, xml::model_description(&PLANNER_INFO, FmiVersion::Fmi3));
    }
}
