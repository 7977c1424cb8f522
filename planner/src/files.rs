//! Reading the text files a user hands in (missions, trajectories, scenes) with a bound on their
//! size, checked before the text is held in memory.

use std::io::Read;
use std::path::Path;

/// The largest mission, trajectory or scene file read, bytes (16 MiB: a 600-slot trajectory
/// CSV with every column is about 200 KiB, an explicit scene of 10 000 objects about 1 MiB).
pub const MAX_INPUT_FILE_BYTES: u64 = 16 << 20;

/// The text of `path`, refused with an [`std::io::ErrorKind::InvalidData`] error that gives
/// the limit when the file is longer than `limit_bytes` (read up to one byte past it, never
/// more), or is not UTF-8.
pub fn read_text_bounded(path: &Path, limit_bytes: u64) -> std::io::Result<String> {
    let mut text = String::new();
    std::fs::File::open(path)?
        .take(limit_bytes.saturating_add(1))
        .read_to_string(&mut text)?;
    if text.len() as u64 > limit_bytes {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("larger than the limit of {limit_bytes} bytes"),
        ));
    }
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_past_the_limit_is_refused_and_one_at_it_is_read() {
        let dir = std::env::temp_dir().join(format!("cellsar-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("mission.toml");
        std::fs::write(&path, "x".repeat(100)).unwrap();
        assert_eq!(read_text_bounded(&path, 100).unwrap().len(), 100);
        let e = read_text_bounded(&path, 99).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidData);
        assert!(e.to_string().contains("limit of 99 bytes"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
