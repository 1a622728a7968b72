//! Measured figures typed into the prose of README.md and docs/*.md must say where they come
//! from: a file under `results/`.
//!
//! Outside the generated tables (between [`crate::OPEN`] and [`crate::CLOSE`]) and fenced code
//! blocks, a *measured figure* is a number written the way measurements are written:
//!
//! - a time: `12.5 ms`, `40 us`, `7 µs`, `3 ns`, or decimal seconds `0.97 s` (not `t = 1.5 s`);
//! - a decimal memory size: `81.1 MiB`, `4.7 GB` (whole sizes such as `128 MiB` are limits);
//! - a ratio written with `x`: `8.2x`, `37x` (not a size such as `64x48`);
//! - a number in scientific notation with a decimal mantissa: `1.09e-6` (tolerances are
//!   written `1e-4`);
//! - an error pair `0.33 / 0.17` (two decimals around a slash), or a decimal after the words
//!   `FLIP` or `relMSE` (`FLIP 0.060`);
//! - decimal frames per second: `2.12 fps`.
//!
//! Text in inline code (`` `--vct-step 0.25` ``) and link targets are not read. A paragraph
//! that holds such a figure must name a file under `results/`; a list item or a table may
//! instead follow a paragraph that does (the paragraph introducing it). A paragraph, list item
//! or table whose figures are not measurements (sizes computed from a layout, a paper's
//! figures) says so with [`NOT_MEASURED`] anywhere in it.

use anyhow::{Context, Result};
use std::path::Path;

/// The marker that exempts a paragraph, list item or table: its figures are not measured.
pub const NOT_MEASURED: &str = "<!-- not measured here -->";

/// A measured figure without a source.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Uncited {
    /// The document, relative to the repository.
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// The figure as written.
    pub figure: String,
}

impl std::fmt::Display for Uncited {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}: {}", self.file, self.line, self.figure)
    }
}

/// Every measured figure in `root`'s README.md and docs/*.md whose paragraph (or introducing
/// paragraph) cites no file under `results/`.
pub fn uncited(root: &Path) -> Result<Vec<Uncited>> {
    let mut found = Vec::new();
    for (file, text) in documents(root)? {
        found.extend(scan(&text).into_iter().map(|(line, figure)| Uncited {
            file: file.clone(),
            line,
            figure,
        }));
    }
    Ok(found)
}

/// Every path under `results/` that `root`'s README.md and docs/*.md cite outside inline code
/// (in prose or a link) and that does not exist: (document, 1-based line, path).
pub fn missing_sources(root: &Path) -> Result<Vec<Uncited>> {
    let mut missing = Vec::new();
    for (file, text) in documents(root)? {
        for (i, line) in text.lines().enumerate() {
            for cited in cited_paths(line) {
                if !root.join(&cited).exists() {
                    missing.push(Uncited {
                        file: file.clone(),
                        line: i + 1,
                        figure: cited,
                    });
                }
            }
        }
    }
    Ok(missing)
}

/// README.md and docs/*.md of `root`: (path relative to `root`, text).
fn documents(root: &Path) -> Result<Vec<(String, String)>> {
    crate::documents(root)?
        .into_iter()
        .map(|path| {
            let text = std::fs::read_to_string(&path)
                .with_context(|| format!("reading {}", path.display()))?;
            let file = path
                .strip_prefix(root)
                .unwrap_or(&path)
                .display()
                .to_string();
            Ok((file, text))
        })
        .collect()
}

/// The `results/...` paths of a line, outside inline code (`../results/x` as `results/x`).
fn cited_paths(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut code = false;
    let chars: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        if chars[i] == '`' {
            code = !code;
            i += 1;
            continue;
        }
        let starts = !code
            && chars[i..].starts_with(&['r', 'e', 's', 'u', 'l', 't', 's', '/'])
            && (i == 0 || !(chars[i - 1].is_alphanumeric() || chars[i - 1] == '_'));
        if !starts {
            i += 1;
            continue;
        }
        let start = i;
        while i < chars.len()
            && (chars[i].is_alphanumeric() || matches!(chars[i], '/' | '.' | '-' | '_'))
        {
            i += 1;
        }
        let cited: String = chars[start..i].iter().collect();
        out.push(cited.trim_end_matches(['.', '/']).to_string());
    }
    out
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Paragraph,
    List,
    Table,
    Heading,
}

struct Block {
    kind: Kind,
    /// (1-based line, text)
    lines: Vec<(usize, String)>,
}

/// The uncited measured figures of one Markdown text: (1-based line, figure).
pub fn scan(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    // Whether the last paragraph (the one introducing a list or table) cites its data.
    let mut lead = false;
    for block in blocks(text) {
        let joined: String = block
            .lines
            .iter()
            .map(|(_, l)| l.as_str())
            .collect::<Vec<_>>()
            .join("\n");
        let cited = joined.contains("results/") || joined.contains(NOT_MEASURED);
        let covered = match block.kind {
            Kind::Paragraph => {
                lead = cited;
                cited
            }
            Kind::Heading => {
                lead = false;
                true
            }
            Kind::List | Kind::Table => cited || lead,
        };
        if covered {
            continue;
        }
        for (number, line) in &block.lines {
            for figure in figures(line) {
                out.push((*number, figure));
            }
        }
    }
    out
}

/// Paragraphs, list items, tables and headings, outside fenced code and generated tables.
fn blocks(text: &str) -> Vec<Block> {
    let mut blocks: Vec<Block> = Vec::new();
    let mut open = false; // a block is being filled
    let mut fence = false;
    let mut generated = false;
    for (i, line) in text.lines().enumerate() {
        let number = i + 1;
        let trimmed = line.trim_start();
        if generated {
            if line.starts_with(crate::CLOSE) {
                generated = false;
            }
            open = false;
            continue;
        }
        if line.starts_with(crate::OPEN) {
            generated = true;
            open = false;
            continue;
        }
        if trimmed.starts_with("```") {
            fence = !fence;
            open = false;
            continue;
        }
        if fence {
            continue;
        }
        if trimmed.is_empty() {
            open = false;
            continue;
        }
        let kind = if trimmed.starts_with('#') {
            Kind::Heading
        } else if trimmed.starts_with('|') {
            Kind::Table
        } else if is_list_item(trimmed) {
            Kind::List
        } else {
            Kind::Paragraph
        };
        let continues = open
            && match (blocks.last().map(|b| b.kind), kind) {
                (Some(Kind::Table), Kind::Table) => true,
                (Some(Kind::Table), _) | (_, Kind::Table) => false,
                (Some(Kind::Heading), _) | (_, Kind::Heading) => false,
                (_, Kind::List) => false,
                _ => true,
            };
        if continues {
            blocks
                .last_mut()
                .expect("an open block")
                .lines
                .push((number, line.to_string()));
        } else {
            blocks.push(Block {
                kind,
                lines: vec![(number, line.to_string())],
            });
            open = true;
        }
    }
    blocks
}

fn is_list_item(trimmed: &str) -> bool {
    if trimmed.starts_with("- ") || trimmed.starts_with("* ") {
        return true;
    }
    let digits = trimmed.chars().take_while(char::is_ascii_digit).count();
    digits > 0 && trimmed[digits..].starts_with(". ")
}

/// The line without inline code spans and link targets (`](...)`), which hold flags, paths
/// and output formats rather than prose.
fn prose(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut code = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '`' {
            code = !code;
            out.push(' ');
            continue;
        }
        if code {
            continue;
        }
        if c == ']' && chars.peek() == Some(&'(') {
            // Skip the link target up to its closing parenthesis.
            for d in chars.by_ref() {
                if d == ')' {
                    break;
                }
            }
            out.push(' ');
            continue;
        }
        out.push(c);
    }
    out
}

/// A number as written: digits, an optional decimal part, an optional exponent.
#[derive(Debug)]
struct Number {
    start: usize,
    end: usize,
    decimal: bool,
    exponent: bool,
}

fn numbers(s: &[char]) -> Vec<Number> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < s.len() {
        let starts = s[i].is_ascii_digit()
            && (i == 0 || !(s[i - 1].is_alphanumeric() || matches!(s[i - 1], '_' | '.' | '^')));
        if !starts {
            i += 1;
            continue;
        }
        let start = i;
        while i < s.len() && s[i].is_ascii_digit() {
            i += 1;
        }
        let mut decimal = false;
        if i + 1 < s.len() && s[i] == '.' && s[i + 1].is_ascii_digit() {
            decimal = true;
            i += 1;
            while i < s.len() && s[i].is_ascii_digit() {
                i += 1;
            }
        }
        let mut exponent = false;
        if i + 1 < s.len() && s[i] == 'e' {
            let j = if s[i + 1] == '-' || s[i + 1] == '+' {
                i + 2
            } else {
                i + 1
            };
            if j < s.len() && s[j].is_ascii_digit() {
                exponent = true;
                i = j;
                while i < s.len() && s[i].is_ascii_digit() {
                    i += 1;
                }
            }
        }
        out.push(Number {
            start,
            end: i,
            decimal,
            exponent,
        });
    }
    out
}

/// The word that follows position `at` after at most one space.
fn word_after(s: &[char], at: usize) -> String {
    let mut i = at;
    if i < s.len() && s[i] == ' ' {
        i += 1;
    }
    let start = i;
    while i < s.len() && (s[i].is_alphanumeric() || s[i] == 'µ') {
        i += 1;
    }
    s[start..i].iter().collect()
}

/// The words that precede position `at`, trimmed (up to 12 characters).
fn before(s: &[char], at: usize) -> String {
    let from = at.saturating_sub(12);
    s[from..at]
        .iter()
        .collect::<String>()
        .trim_end()
        .to_string()
}

/// Whether the word before position `at` makes what follows a bound (`more than 10x`, `within
/// relMSE 0.04`, `<= 2 ms`): a test's or a target's limit, not a measurement.
fn bound_before(s: &[char], at: usize) -> bool {
    let from = at.saturating_sub(24);
    let text: String = s[from..at].iter().collect();
    let last = text
        .split_whitespace()
        .last()
        .unwrap_or("")
        .trim_matches(|c: char| c == '(' || c == ',');
    matches!(
        last.to_ascii_lowercase().as_str(),
        "than"
            | "least"
            | "most"
            | "within"
            | "below"
            | "above"
            | "under"
            | "bound"
            | "<"
            | ">"
            | "<="
            | ">="
    )
}

/// The measured figures written on one line.
fn figures(line: &str) -> Vec<String> {
    let s: Vec<char> = prose(line).chars().collect();
    let text = |a: usize, b: usize| s[a..b].iter().collect::<String>();
    let nums = numbers(&s);
    let mut out = Vec::new();
    for (k, n) in nums.iter().enumerate() {
        let figure = text(n.start, n.end);
        if bound_before(&s, n.start) {
            continue;
        }
        // Scientific notation with a decimal mantissa.
        if n.decimal && n.exponent {
            out.push(figure);
            continue;
        }
        // A ratio: `8.2x`, `37x` followed by no letter or digit.
        if n.end < s.len()
            && s[n.end] == 'x'
            && s.get(n.end + 1)
                .is_none_or(|c| !(c.is_alphanumeric() || *c == '^'))
        {
            out.push(format!("{figure}x"));
            continue;
        }
        let word = word_after(&s, n.end);
        let is_time_point = before(&s, n.start).ends_with('=');
        let unit = match word.as_str() {
            "ms" | "us" | "µs" | "ns" => true,
            "s" => n.decimal && !is_time_point,
            "MiB" | "GiB" | "KiB" | "MB" | "GB" | "KB" | "fps" => n.decimal,
            _ => false,
        };
        if unit {
            out.push(format!("{figure} {word}"));
            continue;
        }
        // An error value after its metric's name (`FLIP 0.060`; `within relMSE 0.04` is a
        // bound).
        let mut j = n.start;
        while j > 0 && s[j - 1] == ' ' {
            j -= 1;
        }
        let metric_end = j;
        while j > 0 && s[j - 1].is_alphabetic() {
            j -= 1;
        }
        let metric = text(j, metric_end);
        if n.decimal && (metric == "FLIP" || metric == "relMSE") && !bound_before(&s, j) {
            out.push(format!("{metric} {figure}"));
            continue;
        }
        // An error pair: decimal / decimal.
        if n.decimal {
            if let Some(m) = nums.get(k + 1) {
                let between = text(n.end, m.start);
                if between.trim() == "/" && (m.decimal || m.exponent) {
                    out.push(format!("{figure} / {}", text(m.start, m.end)));
                    continue;
                }
            }
        }
    }
    out
}
