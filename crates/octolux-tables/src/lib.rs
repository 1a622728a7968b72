//! The measured tables of README.md and docs/*.md, made from the committed data in `results/`.
//!
//! A generated table sits between two markers in the Markdown, each at the start of a line:
//!
//! ```text
//! <!-- table: error data=results/lavapipe/error-160x90 -->
//! ... (rewritten by `tables`) ...
//! <!-- end table -->
//! ```
//!
//! The first word names the kind of table, the `key=value` pairs its inputs (paths relative to
//! the repository). Every table starts with a line that says where its figures come from: the
//! data folder, the commit the binary that measured them was built from, the date and the
//! adapter. A table typed by hand between markers is overwritten; `--check` finds it.
//!
//! A measured figure in the prose around the tables names the file under `results/` it comes
//! from ([`figures`]; `tables figures` lists those that do not).

mod data;
pub mod figures;
mod sheet;
mod tables;

pub use sheet::{sheet, unsheet, SHEET_ORDER};

use anyhow::{bail, Context, Result};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The opening marker's prefix.
pub const OPEN: &str = "<!-- table: ";
/// The closing marker.
pub const CLOSE: &str = "<!-- end table -->";

/// What a run did.
#[derive(Debug, Default)]
pub struct Report {
    /// One line per table: its file, kind and whether it changed.
    pub lines: Vec<String>,
    /// The tables whose text differs from what the data gives (`file: kind`).
    pub stale: Vec<String>,
}

/// Regenerates every table in `root`'s README.md and docs/*.md; with `check`, writes nothing.
pub fn run(root: &Path, check: bool) -> Result<Report> {
    let mut report = Report::default();
    for path in documents(root)? {
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("reading {}", path.display()))?;
        let shown = path
            .strip_prefix(root)
            .unwrap_or(&path)
            .display()
            .to_string();
        // Links in a table are relative to its document.
        let prefix = if path.parent() == Some(root) {
            ""
        } else {
            "../"
        };
        let (new_text, kinds) =
            regenerate(&text, root, prefix).with_context(|| format!("in {shown}"))?;
        for (kind, changed) in kinds {
            let what = format!("{shown}: {kind}");
            report.lines.push(format!(
                "{what}: {}",
                match (changed, check) {
                    (false, _) => "up to date",
                    (true, true) => "DIFFERS from results/",
                    (true, false) => "rewritten",
                }
            ));
            if changed {
                report.stale.push(what);
            }
        }
        if !check && new_text != text {
            std::fs::write(&path, new_text)
                .with_context(|| format!("writing {}", path.display()))?;
        }
    }
    Ok(report)
}

/// README.md and every docs/*.md, in name order.
fn documents(root: &Path) -> Result<Vec<PathBuf>> {
    let mut paths = vec![root.join("README.md")];
    let docs = root.join("docs");
    let mut entries: Vec<PathBuf> = std::fs::read_dir(&docs)
        .with_context(|| format!("listing {}", docs.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    entries.sort();
    paths.extend(entries);
    Ok(paths)
}

/// `text` with every table between markers remade from the data under `root` (links to it
/// prefixed with `prefix`, the way from the document to `root`), and per table its kind and
/// whether its text changed.
pub fn regenerate(text: &str, root: &Path, prefix: &str) -> Result<(String, Vec<(String, bool)>)> {
    let mut out = String::with_capacity(text.len());
    let mut kinds = Vec::new();
    let mut rest = text;
    // Markers stand at the start of a line (a marker quoted in prose is not one).
    let next_marker = |text: &str| {
        if text.starts_with(OPEN) {
            Some(0)
        } else {
            text.find(&format!("\n{OPEN}")).map(|i| i + 1)
        }
    };
    while let Some(start) = next_marker(rest) {
        let line_end = rest[start..]
            .find('\n')
            .map(|i| start + i + 1)
            .context("a table marker at the end of the file")?;
        let marker = rest[start + OPEN.len()..line_end]
            .trim_end()
            .strip_suffix("-->")
            .with_context(|| format!("marker not closed with '-->': {}", &rest[start..line_end]))?
            .trim();
        let end = if rest[line_end..].starts_with(CLOSE) {
            Some(line_end)
        } else {
            rest[line_end..]
                .find(&format!("\n{CLOSE}"))
                .map(|i| line_end + i + 1)
        }
        .with_context(|| format!("no '{CLOSE}' at the start of a line after '{marker}'"))?;
        let old = &rest[line_end..end];
        let new = render(marker, root, prefix).with_context(|| format!("table '{marker}'"))?;
        out.push_str(&rest[..line_end]);
        out.push_str(&new);
        kinds.push((
            marker.split_whitespace().next().unwrap_or("").to_string(),
            old != new,
        ));
        rest = &rest[end..];
        out.push_str(&rest[..CLOSE.len()]);
        rest = &rest[CLOSE.len()..];
    }
    out.push_str(rest);
    Ok((out, kinds))
}

/// The marker's `pairs=STILL:MOVING,...`: scenes of the moving protocol, each still one with
/// its everything-moves counterpart.
fn pairs(args: &BTreeMap<&str, &str>, kind: &str) -> Result<Vec<(String, String)>> {
    args.get("pairs")
        .with_context(|| format!("'{kind}' needs pairs=STILL:MOVING,..."))?
        .split(',')
        .map(|pair| {
            pair.split_once(':')
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .with_context(|| format!("pair '{pair}' is not STILL:MOVING"))
        })
        .collect()
}

/// The Markdown of one marker's table, ending in a newline.
fn render(marker: &str, root: &Path, prefix: &str) -> Result<String> {
    let mut words = marker.split_whitespace();
    let kind = words.next().context("an empty marker")?;
    let mut args = BTreeMap::new();
    for word in words {
        let (key, value) = word
            .split_once('=')
            .with_context(|| format!("'{word}' is not key=value"))?;
        args.insert(key, value);
    }
    let path = |key: &str| -> Result<PathBuf> {
        Ok(root.join(
            args.get(key)
                .with_context(|| format!("'{kind}' needs {key}=PATH"))?,
        ))
    };
    let shown = |key: &str| format!("{prefix}{}", args.get(key).copied().unwrap_or_default());
    match kind {
        "error" => {
            let early = match args.get("frame").copied() {
                None | Some("measured") => false,
                Some("early") => true,
                Some(other) => bail!("'error': frame={other}: expected 'measured' or 'early'"),
            };
            let run = data::ErrorRun::load(&path("data")?, &shown("data"), early)?;
            Ok(tables::error(&run))
        }
        "temporal" => {
            let run = data::TemporalRun::load(&path("data")?, &shown("data"))?;
            Ok(tables::temporal(&run))
        }
        "gpu-gi" => {
            let run = data::GpuRun::load(&path("data")?, &shown("data"))?;
            Ok(tables::gpu_gi(&run))
        }
        "gi-choice" => {
            let error = data::ErrorRun::load(&path("error")?, &shown("error"), false)?;
            let temporal = data::TemporalRun::load(&path("temporal")?, &shown("temporal"))?;
            let gpu = data::GpuRun::load(&path("gpu")?, &shown("gpu"))?;
            let default = args
                .get("default")
                .context("'gi-choice' needs default=NAME")?;
            // The moving protocol's column, where the marker names its data.
            let moving = match args.get("moving") {
                Some(_) => Some((
                    data::MovingRun::load(&path("moving")?, &shown("moving"))?,
                    pairs(&args, kind)?,
                )),
                None => None,
            };
            let moving = moving.as_ref().map(|(run, p)| (run, p.as_slice()));
            tables::gi_choice(&error, &temporal, &gpu, moving, default)
        }
        "moving" => {
            let run = data::MovingRun::load(&path("data")?, &shown("data"))?;
            tables::moving(&run, &pairs(&args, kind)?)
        }
        "roofline" => {
            let run = data::MovingRun::load(&path("data")?, &shown("data"))?;
            let top = match args.get("top") {
                Some(n) => n
                    .parse()
                    .with_context(|| format!("'roofline': top={n} is not a count"))?,
                None => 2,
            };
            tables::roofline(&run, top)
        }
        other => bail!(
            "unknown table kind '{other}' (error, temporal, gpu-gi, gi-choice, moving, roofline)"
        ),
    }
}
