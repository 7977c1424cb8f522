//! Packaging: the `.fmu` zip archive (written here with deflate, no zip dependency) holding
//! `modelDescription.xml`, the shared library under `binaries/<platform>/<modelIdentifier>.so`
//! and `resources/`.

use std::io::Write as _;

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

/// The `.fmu` archive of a model.
pub fn fmu_archive(
    info: &ModelInfo,
    version: FmiVersion,
    library: &[u8],
) -> std::io::Result<Vec<u8>> {
    let mut zip = ZipWriter::default();
    for (name, data, exec) in entries(info, version, library) {
        zip.add(&name, &data, exec)?;
    }
    Ok(zip.finish())
}

struct CentralEntry {
    name: String,
    crc: u32,
    compressed: u32,
    size: u32,
    method: u16,
    offset: u32,
    mode: u32,
}

/// A minimal zip writer: deflated (or stored, when deflate does not help) files, UTF-8 names,
/// a fixed timestamp (1980-01-01) so archives are reproducible. No zip64: each file and the whole
/// archive must stay below 4 GiB.
#[derive(Default)]
pub struct ZipWriter {
    out: Vec<u8>,
    entries: Vec<CentralEntry>,
}

fn u32_of(n: usize) -> std::io::Result<u32> {
    u32::try_from(n).map_err(|_| std::io::Error::other("zip entry larger than 4 GiB"))
}

const DOS_TIME: u16 = 0;
const DOS_DATE: u16 = (1 << 5) | 1; // 1980-01-01

impl ZipWriter {
    /// Adds a file.
    pub fn add(&mut self, name: &str, data: &[u8], executable: bool) -> std::io::Result<()> {
        let crc = crc32fast::hash(data);
        let mut enc = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::best());
        enc.write_all(data)?;
        let deflated = enc.finish()?;
        let (method, body) = if deflated.len() < data.len() {
            (8u16, deflated)
        } else {
            (0u16, data.to_vec())
        };
        let offset = u32_of(self.out.len())?;
        let e = CentralEntry {
            name: name.to_string(),
            crc,
            compressed: u32_of(body.len())?,
            size: u32_of(data.len())?,
            method,
            offset,
            mode: if executable { 0o100755 } else { 0o100644 },
        };
        let o = &mut self.out;
        o.extend_from_slice(&0x0403_4b50u32.to_le_bytes());
        o.extend_from_slice(&20u16.to_le_bytes()); // version needed
        o.extend_from_slice(&0x0800u16.to_le_bytes()); // UTF-8 names
        o.extend_from_slice(&e.method.to_le_bytes());
        o.extend_from_slice(&DOS_TIME.to_le_bytes());
        o.extend_from_slice(&DOS_DATE.to_le_bytes());
        o.extend_from_slice(&e.crc.to_le_bytes());
        o.extend_from_slice(&e.compressed.to_le_bytes());
        o.extend_from_slice(&e.size.to_le_bytes());
        o.extend_from_slice(
            &(u16::try_from(name.len()).map_err(std::io::Error::other)?).to_le_bytes(),
        );
        o.extend_from_slice(&0u16.to_le_bytes());
        o.extend_from_slice(name.as_bytes());
        o.extend_from_slice(&body);
        self.entries.push(e);
        Ok(())
    }

    /// Writes the central directory and returns the archive.
    pub fn finish(mut self) -> Vec<u8> {
        let cd_start = self.out.len();
        for e in &self.entries {
            let o = &mut self.out;
            o.extend_from_slice(&0x0201_4b50u32.to_le_bytes());
            o.extend_from_slice(&((3u16 << 8) | 20).to_le_bytes()); // made by: unix, 2.0
            o.extend_from_slice(&20u16.to_le_bytes());
            o.extend_from_slice(&0x0800u16.to_le_bytes());
            o.extend_from_slice(&e.method.to_le_bytes());
            o.extend_from_slice(&DOS_TIME.to_le_bytes());
            o.extend_from_slice(&DOS_DATE.to_le_bytes());
            o.extend_from_slice(&e.crc.to_le_bytes());
            o.extend_from_slice(&e.compressed.to_le_bytes());
            o.extend_from_slice(&e.size.to_le_bytes());
            o.extend_from_slice(&(e.name.len() as u16).to_le_bytes());
            o.extend_from_slice(&0u16.to_le_bytes()); // extra
            o.extend_from_slice(&0u16.to_le_bytes()); // comment
            o.extend_from_slice(&0u16.to_le_bytes()); // disk
            o.extend_from_slice(&0u16.to_le_bytes()); // internal attributes
            o.extend_from_slice(&(e.mode << 16).to_le_bytes());
            o.extend_from_slice(&e.offset.to_le_bytes());
            o.extend_from_slice(e.name.as_bytes());
        }
        let cd_size = self.out.len() - cd_start;
        let n = self.entries.len() as u16;
        let o = &mut self.out;
        o.extend_from_slice(&0x0605_4b50u32.to_le_bytes());
        o.extend_from_slice(&0u16.to_le_bytes());
        o.extend_from_slice(&0u16.to_le_bytes());
        o.extend_from_slice(&n.to_le_bytes());
        o.extend_from_slice(&n.to_le_bytes());
        o.extend_from_slice(&(cd_size as u32).to_le_bytes());
        o.extend_from_slice(&(cd_start as u32).to_le_bytes());
        o.extend_from_slice(&0u16.to_le_bytes());
        self.out
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
        let bytes = z.finish();
        assert_eq!(&bytes[..4], &[0x50, 0x4b, 0x03, 0x04]);
        // deflated: far smaller than the content
        assert!(bytes.len() < 1000, "{}", bytes.len());
        let eocd = &bytes[bytes.len() - 22..];
        assert_eq!(&eocd[..4], &0x0605_4b50u32.to_le_bytes());
        assert_eq!(u16::from_le_bytes([eocd[10], eocd[11]]), 2);
    }
}
