#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]
//! The documentation against the program and against itself: every long flag and subcommand
//! that a documented binary's `--help` lists appears in the user guide's command-line
//! reference, and every relative link and anchor of every Markdown file in the repository
//! resolves. Needs the binaries: `cargo build -p pipeline --bins -p fmu` first (or
//! `cargo test --workspace`).
//!
//! The Markdown is read by a small scanner below rather than a CommonMark crate, which no
//! crate of the workspace depends on: the repository's Markdown uses inline links, reference
//! definitions, ATX headings, `<a id>` anchors and fenced code, and nothing else that matters
//! for links.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};
use std::process::Command;

/// The binaries the documentation presents, with the Markdown file and section (an ATX heading
/// line) that is their reference.
const REFERENCE: (&str, &str) = ("docs/user-guide.md", "## Command-line reference");
const BINARIES: [&str; 5] = [
    "cellsar",
    "cellsar-planner",
    "cellsar-radar-sim",
    "cellsar-bridge",
    "package-fmu",
];

fn help(bin: &str, sub: &[&str]) -> String {
    let o = Command::new(harness::bin(bin))
        .args(sub)
        .arg("--help")
        .output()
        .unwrap();
    assert!(o.status.success(), "{bin} {sub:?} --help failed");
    String::from_utf8(o.stdout).unwrap()
}

/// The subcommands a clap help lists under `Commands:`, `help` left out.
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| l.trim() != "Commands:")
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| l.starts_with("  ") && !l.starts_with("      "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|s| *s != "help")
        .map(str::to_owned)
        .collect()
}

/// The long flags a clap help defines (the lines that begin with `--name` or `-x, --name`),
/// `--help` and `--version` left out.
fn long_flags(help: &str) -> Vec<String> {
    help.lines()
        .filter_map(|l| {
            let t = l.trim_start();
            let t = match t.as_bytes() {
                [b'-', c, b',', b' ', ..] if c.is_ascii_alphanumeric() => &t[4..],
                _ => t,
            };
            let name: String = t
                .strip_prefix("--")?
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
                .collect();
            (!name.is_empty()).then(|| format!("--{name}"))
        })
        .filter(|f| f != "--help" && f != "--version")
        .collect()
}

/// The text of the section that begins with the heading line `heading`, up to the next heading
/// of the same or a higher level.
fn section(text: &str, heading: &str) -> String {
    let level = heading.chars().take_while(|c| *c == '#').count();
    let mut lines = text.lines().skip_while(|l| l.trim_end() != heading);
    assert!(lines.next().is_some(), "no section {heading:?}");
    lines
        .take_while(|l| {
            let h = l.chars().take_while(|c| *c == '#').count();
            !(h > 0 && h <= level && l[h..].starts_with(' '))
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// `needle` occurs in `hay` not followed by a character that would make it a longer flag or
/// name (`--out` is not found in `--out-dir`).
fn mentions(hay: &str, needle: &str) -> bool {
    hay.match_indices(needle).any(|(i, _)| {
        !hay[i + needle.len()..]
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    })
}

#[test]
fn the_command_line_reference_lists_every_flag_and_subcommand() {
    let guide = std::fs::read_to_string(harness::root().join(REFERENCE.0)).unwrap();
    let reference = section(&guide, REFERENCE.1);
    let mut missing = Vec::new();
    for bin in BINARIES {
        let mut todo = vec![Vec::<String>::new()];
        while let Some(path) = todo.pop() {
            let args: Vec<&str> = path.iter().map(String::as_str).collect();
            let text = help(bin, &args);
            let name = std::iter::once(bin)
                .chain(args.iter().copied())
                .collect::<Vec<_>>()
                .join(" ");
            if !path.is_empty() && !mentions(&reference, &name) {
                missing.push(format!("subcommand `{name}`"));
            }
            for flag in long_flags(&text) {
                if !mentions(&reference, &flag) {
                    missing.push(format!("`{name} {flag}`"));
                }
            }
            for sub in subcommands(&text) {
                let mut p = path.clone();
                p.push(sub);
                todo.push(p);
            }
        }
    }
    assert!(
        missing.is_empty(),
        "{} ({:?}) does not mention:\n  {}",
        REFERENCE.0,
        REFERENCE.1,
        missing.join("\n  ")
    );
}

/// Every file of the working tree that git tracks or would track (not ignored), relative to the
/// root; without git (a source archive), every file outside `target/`, `.git/` and hidden
/// directories.
fn repository_files() -> BTreeSet<PathBuf> {
    let root = harness::root();
    let git = Command::new("git")
        .args([
            "ls-files",
            "-z",
            "--cached",
            "--others",
            "--exclude-standard",
        ])
        .current_dir(&root)
        .output()
        .ok()
        .filter(|o| o.status.success() && !o.stdout.is_empty());
    let Some(o) = git else {
        let mut out = BTreeSet::new();
        walk(&root, Path::new(""), &mut out);
        return out;
    };
    o.stdout
        .split(|b| *b == 0)
        .filter(|p| !p.is_empty())
        .map(|p| PathBuf::from(String::from_utf8_lossy(p).into_owned()))
        .filter(|p| root.join(p).exists())
        .collect()
}

fn walk(root: &Path, rel: &Path, out: &mut BTreeSet<PathBuf>) {
    for entry in std::fs::read_dir(root.join(rel)).unwrap().flatten() {
        let name = entry.file_name();
        let path = rel.join(&name);
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            if !(name.to_string_lossy().starts_with('.') || path == Path::new("target")) {
                walk(root, &path, out);
            }
        } else {
            out.insert(path);
        }
    }
}

/// A Markdown file's lines outside fenced code blocks, with inline code spans blanked out, each
/// with its line number.
fn prose_lines(text: &str) -> Vec<(usize, String)> {
    let mut fence: Option<String> = None;
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let t = line.trim_start();
        let marker: String = t.chars().take_while(|c| *c == '`' || *c == '~').collect();
        if let Some(f) = &fence {
            if marker.len() >= f.len()
                && marker.starts_with(&f[..1])
                && t[marker.len()..].trim().is_empty()
            {
                fence = None;
            }
            continue;
        }
        if marker.len() >= 3
            && (marker.chars().all(|c| c == '`') || marker.chars().all(|c| c == '~'))
        {
            fence = Some(marker);
            continue;
        }
        out.push((k + 1, blank_code_spans(line)));
    }
    out
}

/// The line with every inline code span (`` `…` ``, any run length) replaced by spaces.
fn blank_code_spans(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut rest = line;
    while let Some(i) = rest.find('`') {
        out.push_str(&rest[..i]);
        let run = rest[i..].chars().take_while(|c| *c == '`').count();
        let tick = "`".repeat(run);
        match rest[i + run..].find(&tick) {
            Some(j) => {
                out.push_str(&" ".repeat(run + j + run));
                rest = &rest[i + run + j + run..];
            }
            None => {
                out.push_str(&rest[i..i + run]);
                rest = &rest[i + run..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// The link targets of one line: inline links and images `[…](target "title")` and reference
/// definitions `[label]: target`.
fn link_targets(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let t = line.trim_start();
    if t.starts_with('[') {
        if let Some(i) = t.find("]:") {
            if let Some(target) = t[i + 2..].split_whitespace().next() {
                out.push(target.trim_matches(['<', '>']).to_owned());
            }
        }
    }
    let mut rest = line;
    while let Some(i) = rest.find("](") {
        let after = &rest[i + 2..];
        let target = if let Some(a) = after.strip_prefix('<') {
            a.split('>').next().unwrap_or("").to_owned()
        } else {
            // up to the matching ')' or the first space (a title follows)
            let mut depth = 0usize;
            let mut end = after.len();
            for (j, c) in after.char_indices() {
                match c {
                    '(' => depth += 1,
                    ')' if depth == 0 => {
                        end = j;
                        break;
                    }
                    ')' => depth -= 1,
                    ' ' => {
                        end = j;
                        break;
                    }
                    _ => {}
                }
            }
            after[..end].to_owned()
        };
        out.push(target);
        rest = after;
    }
    out
}

/// GitHub's anchor of a heading's text: lower case, every character other than a letter, a
/// digit, a space, '-' or '_' removed, spaces to '-'.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// A heading's visible text: links reduced to their text, code spans to their content.
fn heading_text(raw: &str) -> String {
    let mut s = raw.trim().trim_end_matches('#').trim_end().to_owned();
    while let Some(i) = s.find("](") {
        let Some(open) = s[..i].rfind('[') else { break };
        let Some(close) = s[i..].find(')') else { break };
        s = format!("{}{}{}", &s[..open], &s[open + 1..i], &s[i + close + 1..]);
    }
    s.replace('`', "")
}

/// The anchors of a Markdown file: its headings' slugs (duplicates numbered -1, -2, … as GitHub
/// does) and the ids and names of its HTML anchors.
fn anchors(text: &str) -> BTreeSet<String> {
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut out = BTreeSet::new();
    let mut fence: Option<char> = None;
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with("```") || t.starts_with("~~~") {
            let c = t.chars().next().unwrap();
            fence = match fence {
                Some(f) if f == c => None,
                None => Some(c),
                f => f,
            };
            continue;
        }
        if fence.is_some() {
            continue;
        }
        let level = t.chars().take_while(|c| *c == '#').count();
        if (1..=6).contains(&level) && t[level..].starts_with(' ') && line.len() - t.len() < 4 {
            let base = slug(&heading_text(&t[level..]));
            let n = seen.entry(base.clone()).or_insert(0);
            out.insert(if *n == 0 {
                base.clone()
            } else {
                format!("{base}-{n}")
            });
            *n += 1;
        }
        for attr in ["id=\"", "name=\""] {
            let mut rest = t;
            while let Some(i) = rest.find(attr) {
                let v = &rest[i + attr.len()..];
                if let Some(j) = v.find('"') {
                    out.insert(v[..j].to_owned());
                }
                rest = v;
            }
        }
    }
    out
}

/// `base/rel` with `.` and `..` resolved lexically; `None` when it leaves the repository.
fn join_inside(base: &Path, rel: &str) -> Option<PathBuf> {
    let mut out = Vec::new();
    for c in base.join(rel).components() {
        match c {
            Component::Normal(p) => out.push(p.to_owned()),
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop()?;
            }
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    Some(out.iter().collect())
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = std::str::from_utf8(&b[i + 1..i + 3]).unwrap_or("");
            if let Ok(v) = u8::from_str_radix(hex, 16) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[test]
fn every_relative_link_and_anchor_resolves() {
    let root = harness::root();
    let files = repository_files();
    let dirs: BTreeSet<PathBuf> = files
        .iter()
        .flat_map(|f| f.ancestors().skip(1).map(Path::to_path_buf))
        .collect();
    let markdown: Vec<&PathBuf> = files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "md"))
        .collect();
    assert!(
        markdown.iter().any(|f| f.as_os_str() == "README.md"),
        "no README.md among the repository's files"
    );
    let mut anchor_cache: BTreeMap<PathBuf, BTreeSet<String>> = BTreeMap::new();
    let mut broken = Vec::new();
    for md in &markdown {
        let text = std::fs::read_to_string(root.join(md)).unwrap();
        let dir = md.parent().unwrap_or(Path::new(""));
        for (line, prose) in prose_lines(&text) {
            for target in link_targets(&prose) {
                if target.is_empty()
                    || target.contains("://")
                    || target.starts_with("mailto:")
                    || target.starts_with("tel:")
                {
                    continue;
                }
                let at = format!("{}:{line}: ({target})", md.display());
                let (path, anchor) = match target.split_once('#') {
                    Some((p, a)) => (p, Some(a)),
                    None => (target.as_str(), None),
                };
                let file = if path.is_empty() {
                    md.to_path_buf()
                } else {
                    match join_inside(dir, &percent_decode(path)) {
                        Some(p) => p,
                        None => {
                            broken.push(format!("{at} leaves the repository"));
                            continue;
                        }
                    }
                };
                if !files.contains(&file) && !dirs.contains(&file) {
                    broken.push(format!("{at}: no file {}", file.display()));
                    continue;
                }
                let Some(anchor) = anchor else { continue };
                if file.extension().is_none_or(|e| e != "md") {
                    continue; // anchors into source files (line numbers) are not checked
                }
                let known = anchor_cache.entry(file.clone()).or_insert_with(|| {
                    anchors(&std::fs::read_to_string(root.join(&file)).unwrap())
                });
                if !known.contains(&percent_decode(anchor)) {
                    broken.push(format!("{at}: no anchor #{anchor} in {}", file.display()));
                }
            }
        }
    }
    assert!(
        broken.is_empty(),
        "{} broken links:\n  {}",
        broken.len(),
        broken.join("\n  ")
    );
}

/// The committed `reproduce` report names its figures in code, not as links: each must be
/// committed beside it (`docs/example/regenerate.sh` copies what that line names).
#[test]
fn the_reproduce_example_holds_every_figure_its_report_names() {
    let dir = harness::root().join("docs/example/reproduce");
    let report = std::fs::read_to_string(dir.join("REPORT.md")).unwrap();
    let line = report
        .lines()
        .find_map(|l| l.strip_prefix("Figures: "))
        .expect("REPORT.md has a `Figures:` line");
    let files = repository_files();
    let missing: Vec<&str> = line
        .split(',')
        .map(|f| f.trim().trim_matches('`'))
        .filter(|f| !files.contains(&Path::new("docs/example/reproduce").join(f)))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/example/reproduce/REPORT.md names figures that are not there: {missing:?}"
    );
}

#[test]
fn the_link_scanner_reads_what_github_renders() {
    assert_eq!(
        slug("Before/after the layering refactor"),
        "beforeafter-the-layering-refactor"
    );
    assert_eq!(slug(&heading_text("`metrics.json`")), "metricsjson");
    assert_eq!(slug(&heading_text("`[params]`")), "params");
    assert_eq!(
        slug("Resolution: paper or general"),
        "resolution-paper-or-general"
    );
    assert_eq!(
        link_targets("see [a](x.md#b) and ![i](d/p.png \"t\") and [c](<s p.md>)"),
        ["x.md#b", "d/p.png", "s p.md"]
    );
    assert_eq!(link_targets("[ref]: ../a.md#x"), ["../a.md#x"]);
    assert_eq!(blank_code_spans("a `[x](y)` b"), "a          b");
    let a = anchors("# T\n## A b\n```\n## Not\n```\n## A b\n<a id=\"e-1\"></a>\n");
    assert_eq!(
        a.into_iter().collect::<Vec<_>>(),
        ["a-b", "a-b-1", "e-1", "t"]
    );
    assert_eq!(
        join_inside(Path::new("docs"), "../README.md"),
        Some(PathBuf::from("README.md"))
    );
    assert_eq!(join_inside(Path::new("docs"), "../../x"), None);
    assert_eq!(
        long_flags("  -l, --listen <E>\n      --out <DIR>  x --not-this\n  -h, --help\n"),
        ["--listen", "--out"]
    );
}
