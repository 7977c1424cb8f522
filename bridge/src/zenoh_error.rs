//! Zenoh's errors, kept whole as the cause of this crate's errors ([`ZenohError`]).
//!
//! Zenoh reports every failure as `zenoh::Error` (a boxed `std::error::Error`) whose text is
//! written for Zenoh's developers: each message ends with the source location it was raised
//! at (` at /…/zenoh-config-1.10.2/src/lib.rs:1484.`), a JSON5 error is embedded as its Debug
//! output (`Message { msg: "…", location: Some(Location { … }) }`) and a parser error as a
//! multi-line report. Zenoh gives no access to the message without these (its error type's
//! fields are private and its Debug is its Display), so [`ZenohError`] keeps the error whole
//! (for [`ZenohError::get_ref`], `{:?}` and logs) and prints it, as the last link of an error
//! chain, in one line for a person. That is the only place where Zenoh's text is reworded:
//! errors carry the error, not a reworded string.

use std::fmt;

/// An error of Zenoh, kept whole.
///
/// `Display` is Zenoh's message on one line without its source locations (see the module
/// documentation); `Debug` and [`ZenohError::get_ref`] give Zenoh's error as it is. It has no
/// `source()` of its own: Zenoh's message already includes its causes.
pub struct ZenohError(zenoh::Error);

impl ZenohError {
    /// Keeps `error`: a `zenoh::Error` or any error type of Zenoh's (an endpoint's parse
    /// error, for one).
    pub fn new(error: impl Into<zenoh::Error>) -> Self {
        ZenohError(error.into())
    }

    /// Zenoh's error as it is (source locations included).
    pub fn get_ref(&self) -> &(dyn std::error::Error + Send + Sync + 'static) {
        self.0.as_ref()
    }

    /// Zenoh's error, given back.
    pub fn into_inner(self) -> zenoh::Error {
        self.0
    }
}

impl From<zenoh::Error> for ZenohError {
    fn from(e: zenoh::Error) -> Self {
        ZenohError(e)
    }
}

impl fmt::Display for ZenohError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&user_text(&self.0.to_string()))
    }
}

impl fmt::Debug for ZenohError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("ZenohError").field(&self.0).finish()
    }
}

impl std::error::Error for ZenohError {}

/// Zenoh's error text on one line for a person: the source locations Zenoh appends to every
/// message (` at /…/src/lib.rs:183.`) removed, the text of a Debug-printed JSON5 error
/// (`Message { msg: "…", location: … }`) unwrapped, and a multi-line parser report
/// (` --> 1:24 | … = expected …`) joined into one line.
fn user_text(raw: &str) -> String {
    let s = unwrap_debug_message(raw);
    let s = strip_source_locations(&s);
    let s = if s.contains('\n') {
        join_parser_report(&s)
    } else {
        s
    };
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// `… Message { msg: "text", location: Some(Location { line: 1, column: 2 }) } …` →
/// `… text (line 1, column 2) …`.
fn unwrap_debug_message(raw: &str) -> String {
    const OPEN: &str = "Message { msg: \"";
    let Some(i) = raw.find(OPEN) else {
        return raw.to_string();
    };
    let mut msg = String::new();
    let mut chars = raw[i + OPEN.len()..].char_indices();
    let mut end = None;
    while let Some((j, c)) = chars.next() {
        match c {
            '\\' => match chars.next() {
                Some((_, 'n' | 't')) => msg.push(' '),
                Some((_, o)) => msg.push(o),
                None => {}
            },
            '"' => {
                end = Some(i + OPEN.len() + j + 1);
                break;
            }
            c => msg.push(c),
        }
    }
    let Some(end) = end else {
        return raw.to_string();
    };
    let mut rest = &raw[end..];
    if let Some(r) = rest.strip_prefix(", location: None }") {
        rest = r;
    } else if let Some(r) = rest.strip_prefix(", location: Some(Location { line: ") {
        let (line, r) = split_digits(r);
        if let Some(r) = r.strip_prefix(", column: ") {
            let (column, r) = split_digits(r);
            if let (false, false, Some(r)) =
                (line.is_empty(), column.is_empty(), r.strip_prefix(" }) }"))
            {
                msg.push_str(&format!(" (line {line}, column {column})"));
                rest = r;
            }
        }
    }
    format!("{}{msg}{rest}", &raw[..i])
}

fn split_digits(s: &str) -> (&str, &str) {
    let n = s.bytes().take_while(u8::is_ascii_digit).count();
    s.split_at(n)
}

/// Removes every ` at <path>.rs:<line>` (and its full stop).
fn strip_source_locations(raw: &str) -> String {
    let mut s = raw.to_string();
    let mut from = 0;
    while let Some(k) = s[from..].find(".rs:").map(|k| k + from) {
        let (digits, _) = split_digits(&s[k + 4..]);
        let mut end = k + 4 + digits.len();
        let start = s[..k]
            .rfind(" at ")
            .filter(|&a| !s[a + 4..k].contains(char::is_whitespace));
        match (start, digits.is_empty()) {
            (Some(a), false) => {
                if s[end..].starts_with('.') {
                    end += 1;
                }
                s.replace_range(a..end, "");
                from = a;
            }
            _ => from = k + 4,
        }
    }
    s
}

/// A pest-style report (` --> 1:24`, `  |`, `1 | source`, `  = expected …`) on one line.
fn join_parser_report(s: &str) -> String {
    let mut parts = Vec::new();
    for line in s.lines().map(str::trim) {
        if line.is_empty() || line.starts_with('|') {
            continue;
        }
        let (digits, after) = split_digits(line);
        if !digits.is_empty() && after.trim_start().starts_with('|') {
            continue; // the source line echoed
        }
        if let Some(pos) = line.strip_prefix("-->") {
            match pos.trim().split_once(':') {
                Some((l, c)) => parts.push(format!("line {l}, column {c}")),
                None => parts.push(format!("at {}", pos.trim())),
            }
        } else if let Some(r) = line.strip_prefix("= ") {
            parts.push(r.to_string());
        } else {
            parts.push(line.to_string());
        }
    }
    parts.join(": ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zenoh_text_loses_debug_output_and_source_paths() {
        assert_eq!(
            user_text(
                "JSON error: Message { msg: \"Endpoints must be of the form <protocol>/<address>: garbage at /root/.cargo/registry/src/x/zenoh-protocol-1.10.2/src/core/endpoint.rs:615.\", location: Some(Location { line: 1, column: 37 }) } at /root/.cargo/registry/src/x/zenoh-config-1.10.2/src/lib.rs:1484."
            ),
            "JSON error: Endpoints must be of the form <protocol>/<address>: garbage (line 1, column 37)"
        );
        assert_eq!(
            user_text(
                "Can not create a new TCP listener bound to tcp/8.8.8.8:1: [8.8.8.8:1: Cannot assign requested address (os error 99) at /r/zenoh-link-commons-1.10.2/src/tcp.rs:61.] at /r/zenoh-link-tcp-1.10.2/src/unicast.rs:338."
            ),
            "Can not create a new TCP listener bound to tcp/8.8.8.8:1: [8.8.8.8:1: Cannot assign requested address (os error 99)]"
        );
        assert_eq!(
            user_text(
                " --> 1:24\n  |\n1 | { mode: 'peer', bogus: 1 \n  |                        ^---\n  |\n  = expected boolean, null, or string at /r/zenoh-config-1.10.2/src/lib.rs:1486."
            ),
            "line 1, column 24: expected boolean, null, or string"
        );
    }

    /// A real Zenoh error: printed without its location, kept whole underneath.
    #[test]
    fn a_zenoh_error_prints_for_people_and_keeps_its_text() {
        let raw = "garbage"
            .parse::<zenoh::config::EndPoint>()
            .expect_err("not an endpoint");
        let whole = raw.to_string();
        let e = ZenohError::new(raw);
        let shown = e.to_string();
        assert!(shown.contains("garbage"), "{shown}");
        assert!(!shown.contains(".rs:"), "{shown}");
        assert_eq!(e.get_ref().to_string(), whole);
        assert!(format!("{e:?}").contains(&whole));
        assert!(std::error::Error::source(&e).is_none());
    }
}
