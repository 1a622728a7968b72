//! The tables in README.md and docs/*.md are what `tables` makes of the committed data in
//! results/: a figure changed by hand, or data changed without regenerating, fails here.
use octolux_tables::{run, CLOSE, OPEN};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn committed_tables_match_the_committed_data() {
    let report = run(&repo(), true).expect("regenerate the tables");
    assert!(
        report.stale.is_empty(),
        "tables that differ from results/ (regenerate with `cargo run -p octolux-tables`):\n{}",
        report.stale.join("\n")
    );
    // The tables the README's choice of default and the docs' error and temporal sections
    // rest on are generated, not typed.
    for kind in [
        "README.md: gi-choice",
        "docs/performance.md: error",
        "docs/performance.md: temporal",
        "docs/performance.md: gpu-gi",
    ] {
        assert!(
            report.lines.iter().any(|l| l.starts_with(kind)),
            "no generated '{kind}' table: {:#?}",
            report.lines
        );
    }
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let target = to.join(path.file_name().unwrap());
        if path.is_dir() {
            copy_dir(&path, &target);
        } else {
            std::fs::copy(&path, &target).unwrap();
        }
    }
}

#[test]
fn a_figure_changed_by_hand_fails_the_check_and_regenerating_restores_it() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    std::fs::copy(repo().join("README.md"), root.join("README.md")).unwrap();
    copy_dir(&repo().join("docs"), &root.join("docs"));
    copy_dir(&repo().join("results"), &root.join("results"));
    let doc = root.join("docs/performance.md");
    let original = std::fs::read_to_string(&doc).unwrap();

    // Change the first figure of the first generated table's first data row.
    let start = original.find(OPEN).unwrap();
    let end = start + original[start..].find(CLOSE).unwrap();
    let row = start
        + original[start..end]
            .find("| none |")
            .expect("a row of GI off");
    let digit = row + original[row..].find(|c: char| c.is_ascii_digit()).unwrap();
    let mut edited = original.clone();
    let old = edited.as_bytes()[digit];
    let new = if old == b'9' { "8" } else { "9" };
    edited.replace_range(digit..digit + 1, new);
    std::fs::write(&doc, &edited).unwrap();

    let report = run(root, true).unwrap();
    assert_eq!(
        report.stale,
        ["docs/performance.md: error"],
        "{:#?}",
        report.lines
    );
    run(root, false).unwrap();
    assert_eq!(std::fs::read_to_string(&doc).unwrap(), original);
    assert!(run(root, true).unwrap().stale.is_empty());
}

#[test]
fn missing_data_is_a_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    std::fs::create_dir_all(root.join("docs")).unwrap();
    std::fs::write(
        root.join("README.md"),
        format!("intro\n{OPEN}error data=results/none-here -->\nold\n{CLOSE}\n"),
    )
    .unwrap();
    let e = format!("{:#}", run(root, true).unwrap_err());
    assert!(
        e.contains("README.md") && e.contains("results/none-here"),
        "{e}"
    );
    std::fs::write(
        root.join("README.md"),
        format!("{OPEN}error data=x -->\nno end\n"),
    )
    .unwrap();
    let e = format!("{:#}", run(root, true).unwrap_err());
    assert!(e.contains(CLOSE), "{e}");
    // A marker quoted in prose is not one.
    std::fs::write(
        root.join("README.md"),
        format!("write `{OPEN}KIND -->` and `{CLOSE}` around a table\n"),
    )
    .unwrap();
    assert!(run(root, true).unwrap().lines.is_empty());
}
