//! `tables`: rewrites every generated table in README.md and docs/*.md from results/, or with
//! `--check` reports the tables that differ from what the data gives and exits non-zero;
//! `tables figures` lists the measured figures in the prose that name no file in results/.
//!
//! ```sh
//! cargo run -p octolux-tables              # rewrite
//! cargo run -p octolux-tables -- --check   # compare only
//! cargo run -p octolux-tables -- figures   # uncited measured figures
//! ```
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let argv: Vec<String> = std::env::args().collect();
    if argv.get(1).map(String::as_str) == Some("sheet") {
        return sheet(&argv[2..]);
    }
    if argv.get(1).map(String::as_str) == Some("unsheet") {
        return unsheet(&argv[2..]);
    }
    if argv.get(1).map(String::as_str) == Some("figures") {
        return figures(&argv[2..]);
    }
    let mut check = false;
    let mut root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--check" => check = true,
            "--root" => match args.next() {
                Some(dir) => root = PathBuf::from(dir),
                None => return usage("--root needs a folder"),
            },
            "-h" | "--help" => {
                println!(
                    "tables [--check] [--root DIR]\n\
                     tables sheet IMAGES_DIR OUT.png|OUT.jpg [COLUMNS]\n\
                     tables unsheet SHEET IMAGES_DIR [COLUMNS]\n\
                     tables figures [--root DIR]\n\n\
                     Regenerates the tables between `<!-- table: ... -->` and `<!-- end table -->` in\n\
                     DIR/README.md and DIR/docs/*.md from the data in DIR/results/ (DIR: the\n\
                     repository). --check: change nothing, list the tables that differ, exit 1 if any.\n\
                     sheet: one scene's images side by side. unsheet: a sheet of all ten images back\n\
                     into IMAGES_DIR as PNGs, keeping the images already there (to remake a sheet\n\
                     after re-running some techniques alone).\n\
                     figures: list the measured figures in the prose (times, sizes, ratios, errors)\n\
                     whose paragraph names no file in results/, and the cited files in results/\n\
                     that do not exist; exit 1 if any."
                );
                return ExitCode::SUCCESS;
            }
            other => return usage(&format!("unknown argument '{other}'")),
        }
    }
    match octolux_tables::run(&root, check) {
        Ok(report) => {
            for line in &report.lines {
                println!("{line}");
            }
            if check && !report.stale.is_empty() {
                eprintln!(
                    "error: {} table(s) differ from results/: run `cargo run -p octolux-tables`",
                    report.stale.len()
                );
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            }
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// `tables sheet DIR OUT.png|OUT.jpg [COLUMNS]`: one scene's images side by side.
fn sheet(args: &[String]) -> ExitCode {
    sheet_command(
        args,
        "sheet needs IMAGES_DIR and OUT.png (or OUT.jpg)",
        |dir, out, columns| octolux_tables::sheet(dir.as_ref(), out.as_ref(), columns),
    )
}

/// `tables unsheet SHEET DIR [COLUMNS]`: a sheet's tiles back into images.
fn unsheet(args: &[String]) -> ExitCode {
    sheet_command(
        args,
        "unsheet needs SHEET and IMAGES_DIR",
        |sheet, dir, columns| octolux_tables::unsheet(sheet.as_ref(), dir.as_ref(), columns),
    )
}

/// The two sheet commands' arguments (two paths, then COLUMNS, 5 by default) and report: the
/// names placed or written, printed after the second path.
fn sheet_command(
    args: &[String],
    missing: &str,
    run: impl FnOnce(&str, &str, u32) -> anyhow::Result<Vec<String>>,
) -> ExitCode {
    let (Some(first), Some(second)) = (args.first(), args.get(1)) else {
        return usage(missing);
    };
    let columns = match args.get(2).map(|c| c.parse::<u32>()) {
        None => 5,
        Some(Ok(c)) if c > 0 => c,
        Some(_) => return usage("COLUMNS: a whole number above 0"),
    };
    match run(first, second, columns) {
        Ok(names) => {
            println!("{second}: {}", names.join(", "));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// `tables figures [--root DIR]`: the measured figures that name no file in results/.
fn figures(args: &[String]) -> ExitCode {
    let root = match args {
        [] => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../.."),
        [flag, dir] if flag == "--root" => PathBuf::from(dir),
        _ => return usage("figures takes only --root DIR"),
    };
    let found = octolux_tables::figures::uncited(&root)
        .and_then(|uncited| Ok((uncited, octolux_tables::figures::missing_sources(&root)?)));
    match found {
        Ok((uncited, missing)) if uncited.is_empty() && missing.is_empty() => {
            println!(
                "every measured figure names its file in results/, and every file cited exists"
            );
            ExitCode::SUCCESS
        }
        Ok((uncited, missing)) => {
            for f in &uncited {
                println!("{f}");
            }
            for f in &missing {
                println!("{f} (no such file)");
            }
            eprintln!(
                "error: {} measured figure(s) name no file in results/ (cite the file and line, \
                 or mark figures that are not measurements with `{}`), {} cited file(s) missing",
                uncited.len(),
                octolux_tables::figures::NOT_MEASURED,
                missing.len()
            );
            ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn usage(problem: &str) -> ExitCode {
    eprintln!(
        "error: {problem}\nusage: tables [--check] [--root DIR] | tables sheet IMAGES_DIR OUT.png|OUT.jpg [COLUMNS] | tables unsheet SHEET IMAGES_DIR [COLUMNS] | tables figures [--root DIR]"
    );
    ExitCode::FAILURE
}
