//! Reading the figures that docs/paper-notes.md and docs/user-guide.md quote, and the runs that
//! make them: shared by `paper_notes_figures.rs` and `user_guide_figures.rs` (each test crate
//! uses a part, hence `dead_code` allowed).

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use planner::evaluate::ResolutionMode;
use planner::{plan, Dynamics, Mission, MissionFile, PlanOptions, PlanResult, Scheme};

pub const NOTES: &str = "docs/paper-notes.md";

pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the workspace root")
        .to_path_buf()
}

pub const GUIDE: &str = "docs/user-guide.md";

/// The text of `doc` (NOTES or GUIDE) with every run of white space made one space: line
/// breaks are where the text wraps, and patterns are written with single spaces.
fn text_of(doc: &str) -> &'static str {
    static NOTES_TEXT: OnceLock<String> = OnceLock::new();
    static GUIDE_TEXT: OnceLock<String> = OnceLock::new();
    let cell = if doc == NOTES {
        &NOTES_TEXT
    } else {
        &GUIDE_TEXT
    };
    cell.get_or_init(|| {
        let text = std::fs::read_to_string(repo().join(doc)).expect(doc);
        text.split_whitespace().collect::<Vec<_>>().join(" ")
    })
}

pub fn mission(file: &str) -> Mission {
    Mission::from_path(&repo().join("missions").join(file)).expect(file)
}

/// `file` with its `[params]` changed by `edit`.
pub fn mission_with(file: &str, edit: impl FnOnce(&mut MissionFile)) -> Mission {
    let text = std::fs::read_to_string(repo().join("missions").join(file)).expect(file);
    let mut f = MissionFile::from_toml_str(&text).expect(file);
    edit(&mut f);
    Mission::from_file_struct(&f).expect(file)
}

/// The options of `cellsar-planner plan --scheme S --resolution R --dynamics D` (and of
/// `cellsar-planner reproduce`, which plans every scheme with the paper's dynamics).
pub fn options(scheme: Scheme, resolution: ResolutionMode, dynamics: Dynamics) -> PlanOptions {
    PlanOptions {
        scheme,
        resolution,
        dynamics,
        ..PlanOptions::default()
    }
}

pub fn run(m: &Mission, o: &PlanOptions) -> PlanResult {
    plan(m, o).unwrap_or_else(|e| panic!("{}: {e}", m.name()))
}

// ---------------------------------------------------------------------------------------------
// Reading a figure out of the text

/// A number as the notes write it: an optional minus sign, digits grouped by single spaces in
/// threes, an optional decimal part. Returns the number, its text and its length in bytes.
fn number_at(s: &str) -> Option<(f64, String, usize)> {
    let b = s.as_bytes();
    let mut i = 0;
    let mut text = String::new();
    if s.starts_with('−') {
        i += '−'.len_utf8();
        text.push('-');
    } else if s.starts_with('-') {
        i += 1;
        text.push('-');
    }
    let digits = |i: usize| b[i..].iter().take_while(|c| c.is_ascii_digit()).count();
    let n = digits(i);
    if n == 0 {
        return None;
    }
    text.push_str(&s[i..i + n]);
    i += n;
    // groups of three after a space, not followed by another digit
    while i + 4 <= b.len() && b[i] == b' ' && digits(i + 1) == 3 {
        text.push_str(&s[i + 1..i + 4]);
        i += 4;
    }
    if i + 1 < b.len() && b[i] == b'.' && b[i + 1].is_ascii_digit() {
        let n = digits(i + 1);
        text.push_str(&s[i..i + 1 + n]);
        i += 1 + n;
    }
    Some((text.parse().ok()?, s[..i].to_string(), i))
}

enum Token<'a> {
    Text(&'a str),
    Figure,
    Other,
}

fn tokens(pattern: &str) -> Vec<Token<'_>> {
    let mut out = Vec::new();
    let mut rest = pattern;
    while !rest.is_empty() {
        let next = [rest.find("{}"), rest.find('#')]
            .into_iter()
            .flatten()
            .min()
            .unwrap_or(rest.len());
        if next > 0 {
            out.push(Token::Text(&rest[..next]));
            rest = &rest[next..];
        } else if let Some(r) = rest.strip_prefix("{}") {
            out.push(Token::Figure);
            rest = r;
        } else {
            out.push(Token::Other);
            rest = &rest[1..];
        }
    }
    out
}

/// The figure `pattern` marks in `text`, where the pattern matches at `start`.
fn match_at(text: &str, start: usize, pattern: &[Token]) -> Option<(f64, String)> {
    // a figure at the start of a pattern is a whole number, not the tail of one
    if start > 0
        && text[..start].ends_with(|c: char| c.is_ascii_digit())
        && !matches!(pattern.first(), Some(Token::Text(_)))
    {
        return None;
    }
    let mut at = start;
    let mut figure = None;
    for t in pattern {
        match t {
            Token::Text(s) => {
                if !text[at..].starts_with(s) {
                    return None;
                }
                at += s.len();
            }
            Token::Figure | Token::Other => {
                let (v, shown, n) = number_at(&text[at..])?;
                if matches!(t, Token::Figure) {
                    figure = Some((v, shown));
                }
                at += n;
            }
        }
    }
    figure
}

/// The figure the notes quote where `pattern` matches (exactly once): its value and its text.
pub fn quoted(pattern: &str) -> Result<(f64, String), String> {
    quoted_in(NOTES, pattern)
}

/// The figure `doc` quotes where `pattern` matches (exactly once).
pub fn quoted_in(doc: &str, pattern: &str) -> Result<(f64, String), String> {
    let text = text_of(doc);
    let toks = tokens(pattern);
    let hits: Vec<_> = text
        .char_indices()
        .filter_map(|(i, _)| match_at(text, i, &toks))
        .collect();
    match hits.as_slice() {
        [one] => Ok(one.clone()),
        [] => Err(format!(
            "{doc}: no text matches `{pattern}` (its figure was moved or reworded: update \
             this test's pattern)"
        )),
        many => Err(format!(
            "{doc}: `{pattern}` matches {} times; make it unique",
            many.len()
        )),
    }
}

/// `value` written with `decimals` decimals, grouped in threes by spaces when `grouped`.
pub fn shown(value: f64, decimals: usize, grouped: bool) -> String {
    let s = format!("{:.*}", decimals, value.abs());
    let (int, frac) = s.split_once('.').map_or((s.as_str(), ""), |(i, f)| (i, f));
    let mut out = String::new();
    for (k, c) in int.chars().enumerate() {
        if grouped && k > 0 && (int.len() - k) % 3 == 0 {
            out.push(' ');
        }
        out.push(c);
    }
    if !frac.is_empty() {
        out.push('.');
        out.push_str(frac);
    }
    if value < 0.0 && out.chars().any(|c| c != '0' && c != '.' && c != ' ') {
        out.insert(0, '−');
    }
    out
}

/// Checks the figures of one run: each `(pattern, value)` against the notes. `command` is
/// what makes the run, for the message.
pub fn check(command: &str, figures: &[(&str, f64)]) {
    check_in(NOTES, command, figures);
}

/// [`check`] against `doc`.
pub fn check_in(doc: &str, command: &str, figures: &[(&str, f64)]) {
    let mut failures = Vec::new();
    for &(pattern, value) in figures {
        match quoted_in(doc, pattern) {
            Err(e) => failures.push(e),
            Ok((q, text)) => {
                let decimals = text.split_once('.').map_or(0, |(_, f)| f.len());
                let half_unit = 0.5 * 10f64.powi(-(decimals as i32));
                if (value - q).abs() > half_unit * (1.0 + 1e-9) {
                    failures.push(format!(
                        "{doc} quotes {text} at `{pattern}`; `{command}` gives {value}: \
                         write {}",
                        shown(value, decimals, text.contains(' '))
                    ));
                }
            }
        }
    }
    for f in &failures {
        eprintln!("{f}");
    }
    assert!(
        failures.is_empty(),
        "{} figure(s) differ from the run:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
