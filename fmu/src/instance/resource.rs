//! Resource locations: FMI 2 `file:` URIs and FMI 3 resource paths as directories.

use super::*;

/// Parses an FMI 2 resource location (a `file:` URI, or a plain path) or an FMI 3 resource path
/// into a directory. `Err` says why it is unusable.
pub fn parse_resource_location(text: &str) -> Result<PathBuf, String> {
    let raw = if let Some(rest) = text.strip_prefix("file://") {
        if let Some(r) = rest.strip_prefix("localhost/") {
            format!("/{r}")
        } else if rest.starts_with('/') {
            rest.to_string()
        } else {
            return Err(format!(
                "`{text}`: file URIs with a remote host are not supported"
            ));
        }
    } else if let Some(rest) = text.strip_prefix("file:") {
        rest.to_string()
    } else if text.contains("://") {
        return Err(format!("`{text}`: only file: URIs are supported"));
    } else {
        text.to_string()
    };
    let decoded = percent_decode(&raw).ok_or_else(|| format!("`{text}`: bad %-escape"))?;
    let path = PathBuf::from(decoded);
    if path.is_dir() {
        Ok(path)
    } else {
        Err(format!("{} is not a directory", path.display()))
    }
}

fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = s.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}
