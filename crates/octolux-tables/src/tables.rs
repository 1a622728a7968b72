//! The Markdown of each kind of table.
use crate::data::{
    Error, ErrorRun, GpuRun, MovingCell, MovingRun, PassCell, Provenance, TemporalRun,
};
use anyhow::{Context, Result};
use std::fmt::Write;

/// Whether a technique beats GI off on a scene: lower FLIP and lower relMSE.
fn beats(e: Error, off: Error) -> bool {
    e.flip < off.flip && e.rel_mse < off.rel_mse
}

/// Whether GI off is not exact on a scene (its reference is not black there).
fn beatable(off: Error) -> bool {
    off.flip > 0.0 || off.rel_mse > 0.0
}

/// Geometric means over the beatable scenes of a technique's error as a fraction of GI off's:
/// (FLIP, relMSE, wins, beatable scenes).
pub fn fractions(errors: &[Error], off: &[Error]) -> (f64, f64, usize, usize) {
    let (mut log_flip, mut log_rel, mut wins, mut n) = (0.0, 0.0, 0, 0);
    for (&e, &o) in errors.iter().zip(off) {
        if !beatable(o) {
            continue;
        }
        // A technique exact where GI off is not would be a ratio of 0: floored so that one
        // such scene does not make the mean 0.
        log_flip += (e.flip / o.flip).max(1e-6).ln();
        log_rel += (e.rel_mse / o.rel_mse).max(1e-6).ln();
        wins += usize::from(beats(e, o));
        n += 1;
    }
    let n_f = n.max(1) as f64;
    ((log_flip / n_f).exp(), (log_rel / n_f).exp(), wins, n)
}

/// Every technique's FLIP / relMSE per scene, `*` where it beats GI off, then the geometric
/// means.
pub fn error(run: &ErrorRun) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{}", run.provenance.sentence());
    // One sample count, or each scene's where they differ.
    let spp = match run.spp.split_first() {
        Some((first, rest)) if rest.iter().all(|n| n == first) => format!("{first} spp"),
        _ => {
            let each: Vec<String> = run
                .scenes
                .iter()
                .zip(&run.spp)
                .map(|(scene, n)| format!("{n} ({scene})"))
                .collect();
            format!("{} spp", each.join(", "))
        }
    };
    let frames = match (run.early_frame, run.settle) {
        (Some(frame), _) => format!("frame {frame} (early: the techniques have not settled)"),
        (None, true) => {
            let own: Vec<String> = run
                .own_warmups
                .iter()
                .map(|(t, n)| format!("`{t}` {n}"))
                .collect();
            match own.is_empty() {
                true => format!("{} warm-up frames and 1 measured", run.warmup),
                false => format!(
                    "each technique settled ({} warm-up frames, {} for those converging over frames) and 1 measured",
                    run.warmup,
                    own.join(", ")
                ),
            }
        }
        (None, false) => format!("{} warm-up frames and 1 measured", run.warmup),
    };
    let _ = writeln!(
        s,
        "*{}x{}, {frames}, against the `{}` reference at {spp}. FLIP / relMSE; `*`: beats GI off (`none`) on both.*",
        run.width, run.height, run.against
    );
    s.push('\n');
    let _ = writeln!(
        s,
        "| technique | {} | beats GI off |",
        run.scenes.join(" | ")
    );
    let _ = writeln!(s, "| --- |{}", " --- |".repeat(run.scenes.len() + 1));
    let Ok(off) = run.off() else {
        return s;
    };
    for (technique, errors) in &run.techniques {
        let _ = write!(s, "| {technique} |");
        for (&e, &o) in errors.iter().zip(off) {
            let star = if technique != "none" && beats(e, o) {
                " *"
            } else {
                ""
            };
            let _ = write!(s, " {:.3} / {:.4}{star} |", e.flip, e.rel_mse);
        }
        let (_, _, wins, n) = fractions(errors, off);
        if technique == "none" {
            s.push_str(" - |\n");
        } else {
            let _ = writeln!(s, " {wins} / {n} |");
        }
    }
    if run.noise.iter().any(Option::is_some) {
        // Two references of different seeds against each other: each one's own noise is
        // about half of it (relMSE).
        let _ = write!(s, "| reference noise (seed 7 against 8) |");
        for noise in &run.noise {
            match noise {
                Some(e) => {
                    let _ = write!(s, " {:.3} / {:.4} |", e.flip, e.rel_mse);
                }
                None => s.push_str(" - |"),
            }
        }
        s.push_str(" - |\n");
    }
    let n_scenes = off.iter().filter(|&&o| beatable(o)).count();
    let _ = write!(
        s,
        "\nGeometric means over the {n_scenes} scenes whose reference is not black, as a fraction of GI off's error, FLIP / relMSE:"
    );
    let mut means: Vec<(String, f64, f64)> = run
        .techniques
        .iter()
        .filter(|(t, _)| t != "none")
        .map(|(t, e)| {
            let (f, r, _, _) = fractions(e, off);
            (t.clone(), f, r)
        })
        .collect();
    means.sort_by(|a, b| a.2.total_cmp(&b.2).then(a.1.total_cmp(&b.1)));
    let list: Vec<String> = means
        .iter()
        .map(|(t, f, r)| format!(" `{t}` {f:.2} / {r:.2}"))
        .collect();
    let _ = writeln!(s, "{}.", list.join(","));
    s
}

/// `x` with three significant digits, as C's `%.3g`.
pub fn sig3(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let exp = x.abs().log10().floor() as i32;
    if !(-4..3).contains(&exp) {
        let t = format!("{x:.2e}");
        // 1.20e-5 -> 1.2e-5, as %g drops trailing zeros.
        let (m, e) = t.split_once('e').unwrap();
        let m = m.trim_end_matches('0').trim_end_matches('.');
        return format!("{m}e{e}");
    }
    let decimals = (2 - exp).max(0) as usize;
    let t = format!("{x:.decimals$}");
    if t.contains('.') {
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        t
    }
}

/// Flicker held still, under a far moving light and a flying camera, and the lag after each
/// change, per technique.
pub fn temporal(run: &TemporalRun) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{}", run.provenance.sentence());
    s.push('\n');
    let _ = writeln!(s, "| technique | still flicker | far light | camera flight | lag: spot on | spot off | spot jumps | sphere jumps |");
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | --- | --- | --- | --- |");
    for r in &run.rows {
        let _ = write!(
            s,
            "| {} | {} | {} | {} |",
            r.technique,
            sci2(r.still_flicker),
            sci2(r.far_light),
            sci2(r.camera_flight)
        );
        for (_, frames, first, settled) in &r.lags {
            let _ = write!(s, " {frames} ({} -> {}) |", sig3(*first), sig3(*settled));
        }
        s.push('\n');
    }
    s
}

/// `x` with two decimals in scientific notation, `0` for zero.
fn sci2(x: f64) -> String {
    if x == 0.0 {
        "0".to_string()
    } else {
        format!("{x:.2e}")
    }
}

/// `x` with one decimal in scientific notation, `0` for zero.
fn sci1(x: f64) -> String {
    if x == 0.0 {
        "0".to_string()
    } else {
        format!("{x:.1e}")
    }
}

/// `lo-hi` of `values` with `decimals`, or one value when they round alike.
fn range(values: impl Iterator<Item = f64>, decimals: usize) -> String {
    let v: Vec<f64> = values.collect();
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (a, b) = (format!("{lo:.decimals$}"), format!("{hi:.decimals$}"));
    if a == b {
        a
    } else {
        format!("{a}-{b}")
    }
}

/// GI time per technique and scene on a GPU.
pub fn gpu_gi(run: &GpuRun) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{}", run.provenance.sentence());
    if !run.note.is_empty() {
        let _ = writeln!(s, "*{}*", run.note);
    }
    if !run.command.is_empty() {
        let _ = writeln!(s, "*Command: `{}`.*", run.command);
    }
    s.push('\n');
    let earlier = run
        .earlier
        .as_ref()
        .map_or(String::new(), |(what, _)| format!(" {what} |"));
    let _ = writeln!(
        s,
        "| technique | {} | dominant passes | build |{earlier}",
        run.scenes.join(" | ")
    );
    let _ = writeln!(
        s,
        "| --- |{} --- | --- |{}",
        " ---: |".repeat(run.scenes.len()),
        if earlier.is_empty() { "" } else { " --- |" }
    );
    for (i, (technique, ms, dominant, commit)) in run.rows.iter().enumerate() {
        let cells: Vec<String> = ms.iter().map(|m| format!("{m:.2}")).collect();
        let old = run
            .earlier
            .as_ref()
            .map_or(String::new(), |(_, cells)| format!(" {} |", cells[i]));
        let _ = writeln!(
            s,
            "| {technique} | {} | {dominant} | `{commit}` |{old}",
            cells.join(" | ")
        );
    }
    s
}

/// The moving protocol: each technique's GI time on every scene, the worst of them, and per
/// pair of a still scene and its everything-moves counterpart the time ratio and the work that
/// grows the most (work counts are exact on every adapter; times are the adapter's).
pub fn moving(run: &MovingRun, pairs: &[(String, String)]) -> Result<String> {
    let pairs = pair_indices(run, pairs)?;
    let mut s = String::new();
    let _ = writeln!(s, "{}", run.provenance.sentence());
    s.push('\n');
    let mut header = String::from("| technique |");
    let mut rule = String::from("| --- |");
    for scene in &run.scenes {
        header.push_str(&format!(" {scene} ms |"));
        rule.push_str(" ---: |");
    }
    header.push_str(" worst |");
    rule.push_str(" --- |");
    for &(still, moving) in &pairs {
        header.push_str(&format!(
            " {} / {} | work that grows most |",
            run.scenes[moving], run.scenes[still]
        ));
        rule.push_str(" ---: | --- |");
    }
    let _ = writeln!(s, "{header}");
    let _ = writeln!(s, "{rule}");
    for (technique, cells) in &run.techniques {
        let mut row = format!("| `{technique}` |");
        for cell in cells {
            let ms = if cell.gi_ms >= 100.0 {
                format!("{:.0}", cell.gi_ms)
            } else {
                sig3(cell.gi_ms)
            };
            row.push_str(&format!(" {ms} |"));
        }
        let (worst, most) = cells
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.gi_ms.total_cmp(&b.1.gi_ms))
            .context("no scenes")?;
        let worst = if most.gi_ms > 0.0 {
            run.scenes[worst].as_str()
        } else {
            "-"
        };
        row.push_str(&format!(" {worst} |"));
        for &(still, moving) in &pairs {
            let ratio = if cells[still].gi_ms > 0.0 {
                format!("{:.2}", cells[moving].gi_ms / cells[still].gi_ms)
            } else {
                "-".into()
            };
            row.push_str(&format!(
                " {ratio} | {} |",
                growth(&cells[still], &cells[moving])
            ));
        }
        let _ = writeln!(s, "{row}");
    }
    Ok(s)
}

/// Per technique and scene, its `top` most expensive passes (median time) with the bytes its
/// work asks for and its shares of the adapter's peak bandwidth and operations (`-` for a
/// pass without an estimate: rasterised, or without counts): the `roofline` table.
pub fn roofline(run: &MovingRun, top: usize) -> Result<String> {
    let mut s = String::new();
    let _ = writeln!(s, "{}", run.provenance.sentence());
    s.push('\n');
    let _ = writeln!(
        s,
        "| technique | scene | pass | median ms | bytes asked per frame | bandwidth | operations |"
    );
    let _ = writeln!(s, "| --- | --- | --- | ---: | ---: | ---: | ---: |");
    for (technique, cells) in &run.techniques {
        let mut first = true;
        for (scene, cell) in run.scenes.iter().zip(cells) {
            let mut passes: Vec<&PassCell> = cell.passes.iter().collect();
            passes.sort_by(|a, b| b.median_ms.total_cmp(&a.median_ms));
            for pass in passes.into_iter().take(top) {
                let name = pass
                    .name
                    .strip_prefix(technique.as_str())
                    .unwrap_or(&pass.name)
                    .trim();
                let (bytes, bw, ops) = match pass.roofline {
                    Some((bytes, bw, ops)) => (
                        if bytes >= 1e9 {
                            format!("{} GB", sig3(bytes / 1e9))
                        } else {
                            format!("{} MB", sig3(bytes / 1e6))
                        },
                        format!("{:.1} %", 100.0 * bw),
                        format!("{:.1} %", 100.0 * ops),
                    ),
                    None => ("-".into(), "-".into(), "-".into()),
                };
                let shown = if first {
                    format!("`{technique}`")
                } else {
                    String::new()
                };
                first = false;
                let _ = writeln!(
                    s,
                    "| {shown} | {scene} | {name} | {} | {bytes} | {bw} | {ops} |",
                    sig3(pass.median_ms)
                );
            }
        }
    }
    Ok(s)
}

/// The adapter of the data's first file without its details ("NVIDIA H200", "llvmpipe"), or
/// `none` where it names none.
fn short_adapter<'a>(provenance: &'a Provenance, none: &'a str) -> &'a str {
    let adapter = provenance
        .adapters
        .iter()
        .next()
        .map_or(none, |a| a.as_str());
    adapter.split(" (").next().unwrap_or(adapter)
}

/// The scene indices of each (still, moving) pair of names.
fn pair_indices(run: &MovingRun, pairs: &[(String, String)]) -> Result<Vec<(usize, usize)>> {
    let index = |name: &str| {
        run.scenes
            .iter()
            .position(|s| s == name)
            .with_context(|| format!("no scene '{name}' in the moving data"))
    };
    pairs
        .iter()
        .map(|(still, moving)| Ok((index(still)?, index(moving)?)))
        .collect()
}

/// A technique's largest GI time ratio of an everything-moves scene over its still one, and
/// that moving scene's name; None where it has no GI time on every still scene.
fn worst_moving_ratio(
    run: &MovingRun,
    pairs: &[(usize, usize)],
    technique: &str,
) -> Option<(f64, String)> {
    let (_, cells) = run.techniques.iter().find(|(t, _)| t == technique)?;
    pairs
        .iter()
        .filter(|&&(still, _)| cells[still].gi_ms > 0.0)
        .map(|&(still, moving)| {
            (
                cells[moving].gi_ms / cells[still].gi_ms,
                run.scenes[moving].clone(),
            )
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
}

/// The (at most two) work quantities that grow the most from `still` to `moving`, as
/// "quantity: a → b"; "-" when none grows.
fn growth(still: &MovingCell, moving: &MovingCell) -> String {
    let mut grown: Vec<(f64, String)> = moving
        .work
        .iter()
        .filter_map(|(quantity, after)| {
            let before = still
                .work
                .iter()
                .find(|(q, _)| q == quantity)
                .map_or(0, |w| w.1);
            (*after > before).then(|| {
                let ratio = *after as f64 / before.max(1) as f64;
                (
                    ratio,
                    format!("{quantity}: {} → {}", count(before), count(*after)),
                )
            })
        })
        .collect();
    grown.sort_by(|a, b| b.0.total_cmp(&a.0));
    if grown.is_empty() {
        return "-".into();
    }
    grown
        .into_iter()
        .take(2)
        .map(|(_, text)| text)
        .collect::<Vec<_>>()
        .join("; ")
}

/// A count in 4 significant digits with k, M, G (as the bench prints them).
fn count(n: u64) -> String {
    let x = n as f64;
    match n {
        0..=9_999 => n.to_string(),
        10_000..=999_999 => format!("{}k", sig4(x / 1e3)),
        1_000_000..=999_999_999 => format!("{}M", sig4(x / 1e6)),
        _ => format!("{}G", sig4(x / 1e9)),
    }
}

fn sig4(x: f64) -> String {
    let decimals = (3 - x.abs().log10().floor() as i32).clamp(0, 3) as usize;
    format!("{x:.decimals$}")
}

/// The table the default technique is chosen from: error against GI off's, wins, GPU time,
/// lag and flicker per technique; the default first, the others by relMSE.
pub fn gi_choice(
    error: &ErrorRun,
    temporal: &TemporalRun,
    gpu: &GpuRun,
    moving: Option<(&MovingRun, &[(String, String)])>,
    default: &str,
) -> Result<String> {
    let off = error.off()?;
    let moving = match moving {
        Some((run, pairs)) => Some((run, pair_indices(run, pairs)?)),
        None => None,
    };
    let mut rows = Vec::new();
    for (technique, errors) in error.techniques.iter().filter(|(t, _)| t != "none") {
        let (flip, rel, wins, n) = fractions(errors, off);
        let t = temporal
            .of(technique)
            .with_context(|| format!("no temporal data for '{technique}'"))?;
        let ms = gpu
            .of(technique)
            .map_or("-".to_string(), |ms| range(ms.iter().copied(), 2));
        let lag = range(t.lags.iter().map(|l| l.1 as f64), 0);
        let beats = if wins == n {
            "every scene it can".to_string()
        } else {
            format!("{wins} of {n}")
        };
        let name = if technique == default {
            format!("`{technique}` (default)")
        } else {
            format!("`{technique}`")
        };
        let mut row = format!("| {name} | {flip:.2} / {rel:.2} | {beats} | {ms} |");
        if let Some((run, pairs)) = &moving {
            let worst = worst_moving_ratio(run, pairs, technique)
                .map_or("-".to_string(), |(r, scene)| format!("{r:.2} ({scene})"));
            row.push_str(&format!(" {worst} |"));
        }
        row.push_str(&format!(
            " {lag} | {} / {} / {} |",
            sci1(t.still_flicker),
            sci1(t.far_light),
            sci1(t.camera_flight)
        ));
        rows.push((technique == default, rel, row));
    }
    rows.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.total_cmp(&b.1)));
    let mut s = String::new();
    let _ = writeln!(s, "{}", error.provenance.sentence());
    let _ = writeln!(s, "{}", temporal.provenance.sentence());
    let _ = writeln!(s, "{}", gpu.provenance.sentence());
    if let Some((run, _)) = &moving {
        let _ = writeln!(s, "{}", run.provenance.sentence());
    }
    s.push('\n');
    let short = short_adapter(&gpu.provenance, "GPU");
    let (moving_header, moving_rule) = match &moving {
        Some((run, _)) => (
            format!(
                " everything moving: GI time / still's, worst ({}) |",
                short_adapter(&run.provenance, "")
            ),
            " --- |",
        ),
        None => (String::new(), ""),
    };
    let _ = writeln!(s, "| technique | error, fraction of GI off's (FLIP / relMSE) | beats GI off | GI ms, {short}, 1920x1080 |{moving_header} lag (frames) | flicker: still / far light / camera flight |");
    let _ = writeln!(s, "| --- | --- | --- | --- |{moving_rule} --- | --- |");
    for (_, _, row) in rows {
        let _ = writeln!(s, "{row}");
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_worst_moving_ratio_is_the_largest_over_the_pairs() {
        let cell = |gi_ms| MovingCell {
            gi_ms,
            work: Vec::new(),
            passes: Vec::new(),
        };
        let run = MovingRun {
            provenance: Default::default(),
            scenes: ["box", "box-moves", "hall", "hall-moves"]
                .map(String::from)
                .to_vec(),
            techniques: vec![
                (
                    "a".into(),
                    vec![cell(2.0), cell(3.0), cell(4.0), cell(10.0)],
                ),
                ("b".into(), vec![cell(2.0), cell(6.0), cell(4.0), cell(4.0)]),
                ("none".into(), vec![cell(0.0); 4]),
            ],
        };
        let pairs = pair_indices(
            &run,
            &[("box", "box-moves"), ("hall", "hall-moves")].map(|(a, b)| (a.into(), b.into())),
        )
        .unwrap();
        assert_eq!(pairs, [(0, 1), (2, 3)]);
        assert_eq!(
            worst_moving_ratio(&run, &pairs, "a"),
            Some((2.5, "hall-moves".into()))
        );
        assert_eq!(
            worst_moving_ratio(&run, &pairs, "b"),
            Some((3.0, "box-moves".into()))
        );
        assert_eq!(worst_moving_ratio(&run, &pairs, "none"), None);
        assert_eq!(worst_moving_ratio(&run, &pairs, "c"), None);
        assert!(pair_indices(&run, &[("box".into(), "nowhere".into())]).is_err());
    }

    #[test]
    fn the_roofline_table_lists_each_techniques_most_expensive_passes() {
        let pass = |name: &str, median_ms, roofline| PassCell {
            name: name.into(),
            median_ms,
            roofline,
        };
        let cell = |passes| MovingCell {
            gi_ms: 1.0,
            work: Vec::new(),
            passes,
        };
        let run = MovingRun {
            provenance: Default::default(),
            scenes: vec!["box".into()],
            techniques: vec![(
                "vpl".into(),
                vec![cell(vec![
                    pass("vpl rsm", 0.6, None),
                    pass("vpl merge", 0.02, Some((1e5, 0.5, 0.1))),
                    pass("vpl shade", 1.07, Some((2.5e8, 0.04, 0.006))),
                ])],
            )],
        };
        let table = roofline(&run, 2).unwrap();
        let rows: Vec<&str> = table
            .lines()
            .filter(|l| l.starts_with("| `") || l.starts_with("|  |"))
            .collect();
        assert_eq!(
            rows,
            [
                "| `vpl` | box | shade | 1.07 | 250 MB | 4.0 % | 0.6 % |",
                "|  | box | rsm | 0.6 | - | - | - |",
            ]
        );
    }

    #[test]
    fn three_significant_digits_as_c_does() {
        assert_eq!(sig3(0.0762), "0.0762");
        assert_eq!(sig3(0.08), "0.08");
        assert_eq!(sig3(1.33), "1.33");
        assert_eq!(sig3(0.0), "0");
        assert_eq!(sig3(1.25e-7), "1.25e-7");
        assert_eq!(sig3(3.91e-17), "3.91e-17");
        assert_eq!(sig3(0.92), "0.92");
        assert_eq!(sig3(1.2e-5), "1.2e-5");
    }

    #[test]
    fn geometric_means_skip_scenes_gi_off_gets_exact() {
        let e = |flip, rel_mse| Error { flip, rel_mse };
        let off = [e(0.4, 0.2), e(0.0, 0.0), e(0.1, 0.05)];
        let t = [e(0.1, 0.1), e(0.3, 0.1), e(0.1, 0.025)];
        let (flip, rel, wins, n) = fractions(&t, &off);
        assert_eq!((wins, n), (1, 2));
        assert!((flip - 0.5).abs() < 1e-12, "{flip}");
        assert!((rel - 0.5).abs() < 1e-12, "{rel}");
    }

    #[test]
    fn ranges_collapse_when_equal() {
        assert_eq!(range([2.0, 14.0, 6.0].into_iter(), 0), "2-14");
        assert_eq!(range([0.0, 0.0].into_iter(), 0), "0");
        assert_eq!(range([0.201, 0.249].into_iter(), 2), "0.20-0.25");
    }
}
