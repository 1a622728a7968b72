//! Checks on the files a command writes, made before any work starts: the name ends in the
//! format written, the folder is writable, and the file is not one of the command's inputs.
//! (The writes themselves are atomic: `octolux::image_io::write_atomically`.)

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// The format a flag writes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Format {
    /// A PNG image.
    Png,
    /// An OpenEXR image.
    Exr,
    /// PNG or OpenEXR, chosen by the name.
    Image,
    /// A JSON document.
    Json,
}

impl Format {
    fn extensions(self) -> &'static [&'static str] {
        match self {
            Format::Png => &["png"],
            Format::Exr => &["exr"],
            Format::Image => &["png", "exr"],
            Format::Json => &["json"],
        }
    }
}

/// One file a command will write: the flag that names it, its path and its format.
pub struct Planned<'a> {
    /// The flag, e.g. `--out`.
    pub flag: &'a str,
    /// The file.
    pub path: &'a Path,
    /// What is written into it.
    pub format: Format,
}

/// [`check`] of outputs given as (flag, path, format).
pub fn check_paths(planned: &[(&str, PathBuf, Format)], inputs: &[PathBuf]) -> Result<()> {
    let planned: Vec<Planned> = planned
        .iter()
        .map(|(flag, path, format)| Planned {
            flag,
            path,
            format: *format,
        })
        .collect();
    check(&planned, inputs)
}

/// Checks every planned output against the others and against `inputs` (files the command
/// reads): its extension matches its format, it is not a folder, its folder exists or can be
/// made and is writable, it is not an input (the same file, whatever the path's spelling or
/// links), and no two flags write the same file.
pub fn check(planned: &[Planned], inputs: &[PathBuf]) -> Result<()> {
    for (i, out) in planned.iter().enumerate() {
        let shown = out.path.display();
        let ext = out
            .path
            .extension()
            .map(|e| e.to_string_lossy().to_lowercase())
            .unwrap_or_default();
        let allowed = out.format.extensions();
        if !allowed.contains(&ext.as_str()) {
            bail!(
                "{} {shown}: writes {}; the name must end in .{}",
                out.flag,
                match out.format {
                    Format::Png => "a PNG image",
                    Format::Exr => "an OpenEXR image",
                    Format::Image => "a PNG or OpenEXR image",
                    Format::Json => "JSON",
                },
                allowed.join(" or .")
            );
        }
        if out.path.is_dir() {
            bail!("{} {shown}: is a folder", out.flag);
        }
        if out.path.exists() {
            for input in inputs {
                if same_file::is_same_file(out.path, input).unwrap_or(false) {
                    bail!(
                        "{} {shown}: is the input {}; refusing to overwrite it",
                        out.flag,
                        input.display()
                    );
                }
            }
        }
        for other in &planned[..i] {
            if lexical(other.path) == lexical(out.path) {
                bail!("{} and {} both write {shown}", other.flag, out.flag);
            }
        }
        check_writable_folder(out.flag, out.path)?;
    }
    Ok(())
}

/// Checks that the folder of `path` exists (or can be made) and a file can be created in it.
pub fn check_writable_folder(flag: &str, path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    check_writable_dir(flag, path, dir)
}

/// Checks that `dir` exists and a file can be created in it, or that it can be made (its
/// nearest existing ancestor is a writable folder); errors name `flag` and `path`.
pub fn check_writable_dir(flag: &str, path: &Path, dir: &Path) -> Result<()> {
    // A folder that does not exist yet is made when the file is written: its nearest
    // existing ancestor must be a writable folder. Nothing is created here, so a run that
    // fails later leaves no empty folder behind.
    let existing = dir
        .ancestors()
        .find(|a| a.as_os_str().is_empty() || a.exists())
        .map(|a| {
            if a.as_os_str().is_empty() {
                Path::new(".")
            } else {
                a
            }
        })
        .unwrap_or(Path::new("."));
    if !existing.is_dir() {
        bail!(
            "{flag} {}: {} is not a folder",
            path.display(),
            existing.display()
        );
    }
    tempfile::Builder::new()
        .prefix(".octolux-check-")
        .tempfile_in(existing)
        .with_context(|| {
            format!(
                "{flag} {}: the folder {} is not writable",
                path.display(),
                existing.display()
            )
        })?;
    Ok(())
}

/// The path with `.` components removed, relative to the working folder when relative.
fn lexical(path: &Path) -> PathBuf {
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(path)
    };
    absolute
        .components()
        .filter(|c| !matches!(c, std::path::Component::CurDir))
        .collect()
}

/// Checks a frame rate: finite and within 0.001..=1e6 frames per second, so that frame times
/// stay finite and distinct.
pub fn check_fps(fps: f32) -> Result<()> {
    if !(fps.is_finite() && (1e-3..=1e6).contains(&fps)) {
        bail!("--fps {fps:?}: expected a number of frames per second within 0.001..=1000000");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_are_checked() {
        let tmp = tempfile::Builder::new()
            .prefix("octolux-outputs-")
            .tempdir()
            .unwrap();
        let dir = tmp.path();
        let input = dir.join("in.exr");
        std::fs::write(&input, b"x").unwrap();
        let plan = |path: &Path, format| Planned {
            flag: "--out",
            path: Box::leak(path.to_path_buf().into_boxed_path()),
            format,
        };
        let inputs = vec![input.clone()];
        let err = |p: Vec<Planned>| format!("{:#}", check(&p, &inputs).unwrap_err());
        assert!(err(vec![plan(&input, Format::Image)]).contains("is the input"));
        let dotted = dir.join(".").join("in.exr");
        assert!(err(vec![plan(&dotted, Format::Exr)]).contains("is the input"));
        assert!(err(vec![plan(&dir.join("a.png"), Format::Exr)]).contains(".exr"));
        assert!(err(vec![plan(&dir.join("a.exr"), Format::Png)]).contains(".png"));
        assert!(err(vec![plan(dir, Format::Image)]).contains("must end"));
        assert!(err(vec![
            plan(&dir.join("a.exr"), Format::Image),
            plan(&dir.join("./a.exr"), Format::Exr)
        ])
        .contains("both write"));
        check(&[plan(&dir.join("new/b.png"), Format::Png)], &inputs).unwrap();
        assert!(check_fps(1e-40).is_err() && check_fps(30.0).is_ok());
    }
}
