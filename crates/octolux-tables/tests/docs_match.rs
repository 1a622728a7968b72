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

    // Change the first figure of the first generated error table's first data row.
    let start = original.find(&format!("{OPEN}error ")).unwrap();
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

#[test]
fn every_measured_figure_in_the_prose_names_its_file_in_results() {
    let found = octolux_tables::figures::uncited(&repo()).expect("scan the docs");
    assert!(
        found.is_empty(),
        "measured figures whose paragraph names no file in results/ (cite the file and line, \
         or mark figures that are not this project's measurements with `{}`):\n{}",
        octolux_tables::figures::NOT_MEASURED,
        found
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
fn the_figure_check_reads_measurements_and_leaves_settings() {
    use octolux_tables::figures::scan;
    let figures = |line: &str| -> Vec<String> { scan(line).into_iter().map(|(_, f)| f).collect() };
    for (line, want) in [
        ("the pass took 12.5 ms on it", vec!["12.5 ms"]),
        (
            "40 us per step, 7 µs and 3 ns",
            vec!["40 us", "7 µs", "3 ns"],
        ),
        ("costs 8.2x per frame and 37x less", vec!["8.2x", "37x"]),
        ("held still 1.09e-6", vec!["1.09e-6"]),
        ("it scores 0.203 / 0.0461 here", vec!["0.203 / 0.0461"]),
        (
            "FLIP 0.060, relMSE 0.0052",
            vec!["FLIP 0.060", "relMSE 0.0052"],
        ),
        ("81.1 MiB against 43.8", vec!["81.1 MiB"]),
        (
            "0.97 s of rendering at 2.12 fps",
            vec!["0.97 s", "2.12 fps"],
        ),
    ] {
        assert_eq!(figures(line), want, "{line}");
    }
    for line in [
        "at 64x48 and 1920x1080, 4 x 4 blocks, 64 rays, 32 frames",
        "at most 128 MiB per binding, 2 GiB per file",
        "within 1e-4 of the twin, 3 x 2^-11, below 0.5 %",
        "the scene at t = 1.5 s, a 20 s loop",
        "`--vct-step 0.25` and `0.5 / 0.25` in code",
        "see [a](docs/a-1.5x.md) and f16, v1.2",
        "relMSE below 0.8 x GI off's, relMSE <= 0.03, within relMSE 0.04",
        "falls by more than 10x, at least 2.5 ms",
        "(0.25, 0.25, 0, 0.50) and 64 rays",
    ] {
        assert!(figures(line).is_empty(), "{line}: {:?}", figures(line));
    }
}

#[test]
fn a_citation_covers_its_paragraph_and_the_list_or_table_it_introduces() {
    let text = format!(
        "\
Intro citing [data](results/x.txt), line 3:

- a list item: 12.5 ms
- another: 0.33 / 0.17

| a | b |
| --- | --- |
| 1.5 ms | 2 |

Another paragraph, 7.5 ms, cites nothing.

- so its list is not covered: 9.5 ms

A paragraph of sizes, 31.5 MB by construction. {marker}

```
code 12.5 ms
```

{OPEN}error data=results/x -->
| 1.5 ms |
{CLOSE}
",
        marker = octolux_tables::figures::NOT_MEASURED
    );
    assert_eq!(
        octolux_tables::figures::scan(&text),
        [(10, "7.5 ms".to_string()), (12, "9.5 ms".to_string())]
    );
}

#[test]
fn every_file_the_docs_cite_in_results_exists() {
    let missing = octolux_tables::figures::missing_sources(&repo()).expect("scan the docs");
    assert!(
        missing.is_empty(),
        "the docs cite files in results/ that do not exist:\n{}",
        missing
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
fn a_cited_file_that_does_not_exist_is_found() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    std::fs::create_dir_all(root.join("docs")).unwrap();
    std::fs::create_dir_all(root.join("results/run")).unwrap();
    std::fs::write(root.join("results/run/a.txt"), "x\n").unwrap();
    std::fs::write(
        root.join("README.md"),
        "1.5 ms ([a](results/run/a.txt), line 1), 2.5 ms (results/run/b.txt, line 1).\n\
         The kit writes `results/bench.json` on the GPU machine.\n",
    )
    .unwrap();
    std::fs::write(
        root.join("docs/x.md"),
        "See [the run](../results/run/) and [gone](../results/gone.json).\n",
    )
    .unwrap();
    let missing: Vec<String> = octolux_tables::figures::missing_sources(root)
        .unwrap()
        .iter()
        .map(ToString::to_string)
        .collect();
    assert_eq!(
        missing,
        [
            "README.md:1: results/run/b.txt",
            "docs/x.md:1: results/gone.json"
        ]
    );
}
