//! Every equation tag that a comment in `src/` or `tests/` cites resolves inside the
//! repository: a tag `An` (align), `Bn` (bed) or `Cn` (blast) must be the tag of a heading in
//! `docs/align.md`, `docs/bed.md` or `docs/blast.md`, written as `(An)` in the heading line.
//!
//! The scanner is hand-written (no regex dependency). It reads comments only (`//`, `///`,
//! `//!` and block comments; string and character literals are skipped), takes a letter A, B
//! or C followed by one or two digits as a tag when neither neighbour is a letter, digit or
//! underscore, and expands ranges such as `A5–A7` or `C9-C10` (en dash or hyphen, same letter).

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// The docs file that states the equations of each tag letter.
fn docs_file(letter: char) -> &'static str {
    match letter {
        'A' => "docs/align.md",
        'B' => "docs/bed.md",
        'C' => "docs/blast.md",
        _ => unreachable!("tags are A, B or C"),
    }
}

/// One equation tag, e.g. ('A', 4).
type Tag = (char, u32);

fn show(tag: &Tag) -> String {
    format!("{}{}", tag.0, tag.1)
}

/// Every `.rs` file under `dir`, recursively, in a fixed order.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for path in paths {
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The comment text of a Rust source, one entry per comment line: (1-based line, text).
/// String, raw-string and character literals are skipped, so `"// (A4)"` in code is no
/// citation.
fn comments(source: &str) -> Vec<(usize, String)> {
    let c: Vec<char> = source.chars().collect();
    let mut out = Vec::new();
    let (mut k, mut line) = (0, 1);
    let is_ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    while k < c.len() {
        let ch = c[k];
        if ch == '\n' {
            line += 1;
            k += 1;
        } else if ch == '/' && c.get(k + 1) == Some(&'/') {
            let start = k;
            while k < c.len() && c[k] != '\n' {
                k += 1;
            }
            out.push((line, c[start..k].iter().collect()));
        } else if ch == '/' && c.get(k + 1) == Some(&'*') {
            let mut depth = 0usize;
            let mut text = String::new();
            while k < c.len() {
                if c[k] == '/' && c.get(k + 1) == Some(&'*') {
                    depth += 1;
                    k += 2;
                    continue;
                }
                if c[k] == '*' && c.get(k + 1) == Some(&'/') {
                    depth -= 1;
                    k += 2;
                    if depth == 0 {
                        break;
                    }
                    continue;
                }
                if c[k] == '\n' {
                    out.push((line, std::mem::take(&mut text)));
                    line += 1;
                } else {
                    text.push(c[k]);
                }
                k += 1;
            }
            out.push((line, text));
        } else if ch == 'r'
            && (k == 0
                || !is_ident(c[k - 1])
                || (c[k - 1] == 'b' && (k < 2 || !is_ident(c[k - 2]))))
            && matches!(c.get(k + 1), Some('"') | Some('#'))
        {
            // possibly a raw string r"…" or r#"…"#
            let mut j = k + 1;
            let mut hashes = 0;
            while c.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if c.get(j) != Some(&'"') {
                k += 1;
                continue;
            }
            j += 1;
            loop {
                match c.get(j) {
                    None => break,
                    Some('\n') => line += 1,
                    Some('"') if (1..=hashes).all(|h| c.get(j + h) == Some(&'#')) => {
                        j += 1 + hashes;
                        break;
                    }
                    _ => {}
                }
                j += 1;
            }
            k = j;
        } else if ch == '"' {
            k += 1;
            while k < c.len() && c[k] != '"' {
                if c[k] == '\\' {
                    k += 1;
                }
                if k < c.len() && c[k] == '\n' {
                    line += 1;
                }
                k += 1;
            }
            k += 1;
        } else if ch == '\'' {
            // a character literal ('"', '\'', '\u{..}') or a lifetime ('a)
            if c.get(k + 1) == Some(&'\\') {
                let close = (k + 3..(k + 12).min(c.len())).find(|&j| c[j] == '\'');
                k = close.map_or(k + 1, |j| j + 1);
            } else if c.get(k + 2) == Some(&'\'') {
                k += 3;
            } else {
                k += 1;
            }
        } else {
            k += 1;
        }
    }
    out
}

/// The tags cited in one comment text, ranges expanded.
fn tags_in(text: &str) -> Vec<Tag> {
    let c: Vec<char> = text.chars().collect();
    let is_ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    // a tag starting at k: (tag, index after it)
    let tag_at = |k: usize| -> Option<(Tag, usize)> {
        let letter = *c.get(k)?;
        if !matches!(letter, 'A' | 'B' | 'C') || (k > 0 && is_ident(c[k - 1])) {
            return None;
        }
        let mut j = k + 1;
        while j < c.len() && c[j].is_ascii_digit() && j - k <= 2 {
            j += 1;
        }
        let digits = j - k - 1;
        if !(1..=2).contains(&digits) || c.get(j).is_some_and(|&ch| is_ident(ch)) {
            return None;
        }
        let number: String = c[k + 1..j].iter().collect();
        Some(((letter, number.parse().ok()?), j))
    };
    let mut out = Vec::new();
    let mut k = 0;
    while k < c.len() {
        let Some((first, end)) = tag_at(k) else {
            k += 1;
            continue;
        };
        out.push(first);
        k = end;
        // a range: A5–A7, (A5–A7), A5-A7
        if matches!(c.get(end), Some('–') | Some('-')) {
            if let Some(((letter, last), after)) = tag_at(end + 1) {
                if letter == first.0 && last > first.1 && last - first.1 <= 20 {
                    out.extend((first.1 + 1..=last).map(|n| (letter, n)));
                    k = after;
                }
            }
        }
    }
    out
}

/// Every tag cited in the comments of `src/` and `tests/`, with where (file:line) it is cited.
fn cited_tags(root: &Path) -> BTreeMap<Tag, Vec<String>> {
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    rust_files(&root.join("tests"), &mut files);
    assert!(!files.is_empty(), "no .rs files under {}", root.display());
    let mut cited: BTreeMap<Tag, Vec<String>> = BTreeMap::new();
    for file in files {
        let source = fs::read_to_string(&file).unwrap();
        let name = file
            .strip_prefix(root)
            .unwrap_or(&file)
            .display()
            .to_string();
        for (line, text) in comments(&source) {
            for tag in tags_in(&text) {
                cited.entry(tag).or_default().push(format!("{name}:{line}"));
            }
        }
    }
    cited
}

/// Tags written as `(Xn)` in the heading lines (starting with `#`) of a markdown text, with
/// the number of headings that carry each.
fn heading_tags(markdown: &str) -> BTreeMap<Tag, usize> {
    let mut found = BTreeMap::new();
    let mut fenced = false;
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        if fenced || !line.starts_with('#') {
            continue;
        }
        let c: Vec<char> = line.chars().collect();
        for k in 0..c.len() {
            if c[k] != '(' {
                continue;
            }
            let Some(close) = (k + 1..c.len()).find(|&j| c[j] == ')') else {
                continue;
            };
            let inner: String = c[k + 1..close].iter().collect();
            let mut chars = inner.chars();
            if let Some(letter @ ('A' | 'B' | 'C')) = chars.next() {
                let digits = chars.as_str();
                if (1..=2).contains(&digits.len()) && digits.chars().all(|d| d.is_ascii_digit()) {
                    *found.entry((letter, digits.parse().unwrap())).or_insert(0) += 1;
                }
            }
        }
    }
    found
}

#[test]
fn every_cited_equation_tag_has_a_heading_in_docs() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cited = cited_tags(root);
    assert!(
        cited.keys().any(|t| t.0 == 'A') && cited.keys().any(|t| t.0 == 'B'),
        "the scanner found no align or bed tags at all: is it broken? {:?}",
        cited.keys().map(show).collect::<Vec<_>>()
    );
    let mut unresolved = Vec::new();
    let mut duplicated = Vec::new();
    for letter in ['A', 'B', 'C'] {
        let path = root.join(docs_file(letter));
        let headings = fs::read_to_string(&path)
            .map(|text| heading_tags(&text))
            .unwrap_or_default();
        for (tag, places) in cited.iter().filter(|(t, _)| t.0 == letter) {
            match headings.get(tag) {
                None => unresolved.push(format!(
                    "{} (cited at {}) has no heading `({})` in {}",
                    show(tag),
                    places.join(", "),
                    show(tag),
                    docs_file(letter)
                )),
                Some(&n) if n > 1 => duplicated.push(format!(
                    "{} has {n} headings in {}",
                    show(tag),
                    docs_file(letter)
                )),
                _ => {}
            }
        }
    }
    assert!(
        unresolved.is_empty(),
        "{} equation tag(s) cited in comments do not resolve in docs/:\n  {}",
        unresolved.len(),
        unresolved.join("\n  ")
    );
    assert!(
        duplicated.is_empty(),
        "ambiguous equation headings:\n  {}",
        duplicated.join("\n  ")
    );
}

#[test]
fn docs_index_exists_and_names_every_model_file() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let index = fs::read_to_string(root.join("docs/README.md")).expect("docs/README.md");
    for file in [
        "align.md",
        "bed.md",
        "blast.md",
        "analytic.md",
        "analysis.md",
    ] {
        assert!(index.contains(file), "docs/README.md does not name {file}");
        assert!(
            root.join("docs").join(file).is_file(),
            "docs/{file} is missing"
        );
    }
}

#[test]
fn scanner_finds_tags_ranges_and_skips_look_alikes() {
    let tags = |text: &str| -> Vec<String> { tags_in(text).iter().map(show).collect() };
    assert_eq!(tags("Hertz law (A4), walls"), ["A4"]);
    assert_eq!(tags("spec align.md, A1–A3)."), ["A1", "A2", "A3"]);
    assert_eq!(tags("(C9, C10) and (B4–B5)"), ["C9", "C10", "B4", "B5"]);
    assert_eq!(tags("C9-C10"), ["C9", "C10"]);
    assert_eq!(tags("B1 pairs, B2 walls"), ["B1", "B2"]);
    // look-alikes: hex, identifiers, longer numbers, a letter inside a word, other letters
    assert!(tags("0xA4 ALPHA0 my_B2 B123 CA4 D1 H0 A4x Table B.1").is_empty());
    // a range across letters is two tags, not an expansion
    assert_eq!(tags("A5–B7"), ["A5", "B7"]);

    let source = "let s = \"// (A9)\"; // (B3)\n/// text (C2)\nlet c = '\"'; // A1\n\
                  let r = r#\"// C7 \"# ; /* (B1) */";
    let found: Vec<(usize, Vec<String>)> = comments(source)
        .into_iter()
        .map(|(line, text)| (line, tags(&text)))
        .filter(|(_, t)| !t.is_empty())
        .collect();
    assert_eq!(
        found,
        [
            (1, vec!["B3".to_string()]),
            (2, vec!["C2".to_string()]),
            (3, vec!["A1".to_string()]),
            (4, vec!["B1".to_string()]),
        ]
    );

    let md =
        "# Title\n### (A4) Hertz\n## (A5)–(A7) not a tag heading?\ntext (A6)\n```\n# (A9)\n```";
    let headings: BTreeSet<String> = heading_tags(md).keys().map(show).collect();
    assert_eq!(
        headings,
        ["A4", "A5", "A7"].iter().map(|s| s.to_string()).collect()
    );
}
