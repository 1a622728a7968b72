//! The committed data behind the tables: `bench` JSON documents (one per scene) and the GPU
//! runs kept as JSON.
use anyhow::{bail, Context, Result};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::Path;

/// Where a set of figures comes from.
#[derive(Debug, Default)]
pub struct Provenance {
    /// The data's path from the document.
    pub data: String,
    /// Every distinct commit, date (day) and adapter of the files read.
    pub commits: BTreeSet<String>,
    pub days: BTreeSet<String>,
    pub adapters: BTreeSet<String>,
    /// Command lines, one per file, in file order (shown as the first one).
    pub command: Option<String>,
}

impl Provenance {
    fn add(&mut self, doc: &Value) {
        let p = &doc["provenance"];
        let commit = p["commit"].as_str().unwrap_or("unknown");
        self.commits.insert(short_commit(commit));
        if let Some(date) = p["date"].as_str() {
            self.days.insert(date.chars().take(10).collect());
        }
        if let Some(name) = doc["adapter"]["name"].as_str() {
            self.adapters.insert(name.to_string());
        }
        if self.command.is_none() {
            if let Some(args) = p["command_line"].as_array() {
                let words: Vec<&str> = args.iter().filter_map(Value::as_str).collect();
                self.command = Some(words.join(" "));
            }
        }
        // The re-runs merged into the document ([`apply_reruns`]).
        for rerun in doc[RERUNS_KEY].as_array().into_iter().flatten() {
            self.add(rerun);
        }
    }

    /// One sentence: the data, the commit(s), the date(s), the adapter(s).
    pub fn sentence(&self) -> String {
        let join = |set: &BTreeSet<String>| {
            set.iter()
                .map(|s| format!("`{s}`"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let plain = |set: &BTreeSet<String>| set.iter().cloned().collect::<Vec<_>>().join(", ");
        format!(
            "*Data: [`{data}`]({link}); measured with the build of commit {commits} on {days}, {adapters}.*",
            data = self.data.trim_start_matches("../"),
            link = self.data,
            commits = join(&self.commits),
            days = plain(&self.days),
            adapters = plain(&self.adapters),
        )
    }
}

/// A commit hash cut to 10 digits, `+dirty` kept.
fn short_commit(commit: &str) -> String {
    let (hash, dirty) = match commit.strip_suffix("+dirty") {
        Some(hash) => (hash, "+dirty"),
        None => (commit, ""),
    };
    format!("{}{dirty}", &hash[..hash.len().min(10)])
}

fn read_json(path: &Path) -> Result<Value> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))
}

/// The `bench` JSON files of a folder, in name order.
fn bench_files(dir: &Path) -> Result<Vec<(String, Value)>> {
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .with_context(|| format!("listing {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    // Numbers in names in numeric order (`640x360` before `1280x720`), the rest as text.
    paths.sort_by_key(|p| natural_key(&p.file_name().unwrap_or_default().to_string_lossy()));
    if paths.is_empty() {
        bail!("no .json files in {}", dir.display());
    }
    paths
        .into_iter()
        .map(|p| {
            let name = p.file_stem().unwrap().to_string_lossy().to_string();
            Ok((name, read_json(&p)?))
        })
        .collect::<Result<Vec<_>>>()
        .and_then(|mut files| {
            apply_reruns(&dir.join("reruns"), &mut files)?;
            Ok(files)
        })
}

/// Where a document keeps the provenance of the re-runs merged into it.
const RERUNS_KEY: &str = "merged_reruns";

/// Merges the re-runs in `dir` (`<scene>.json`, `bench` JSON of some techniques on a scene of
/// `files`, made with the same protocol), if the folder exists: each technique a re-run holds
/// replaces that technique's entry in its scene's document, whose provenance then lists the
/// re-run's too, so that a technique changed since the table was made can be measured again
/// without re-running every other technique. GI off (`none`) is the exception: a re-run may
/// hold it only to show that GI off is what it was (FLIP within 5e-4 and relMSE within 0.1 %),
/// since every technique is judged against it; a re-run whose GI off differs, whose protocol
/// (size, warm-up, settling, early frame, reference) differs, or whose scene has no document,
/// is an error.
fn apply_reruns(dir: &Path, files: &mut [(String, Value)]) -> Result<()> {
    if !dir.is_dir() {
        return Ok(());
    }
    // `<scene>.json`, or `<scene>.<label>.json` for a later re-run of other techniques of the
    // same scene; merged in name order, so a later file's cells replace an earlier one's.
    for (file, rerun) in bench_files(dir)? {
        let name = file.split('.').next().unwrap_or_default().to_string();
        let at = files
            .iter()
            .position(|(n, _)| *n == name)
            .with_context(|| format!("reruns/{file}.json: no {name}.json to merge it into"))?;
        let doc = &mut files[at].1;
        for key in ["width", "height", "warmup", "settle"] {
            if rerun[key] != doc[key] {
                bail!(
                    "reruns/{file}.json: '{key}' is {}, {name}.json's {}",
                    rerun[key],
                    doc[key]
                );
            }
        }
        let reference = |d: &Value| {
            let r = &d["scenes"][0]["references"][0];
            (r["spp"].clone(), r["bounces"].clone(), r["seed"].clone())
        };
        if reference(&rerun) != reference(doc) {
            bail!("reruns/{file}.json: another reference than {name}.json's");
        }
        let entries = rerun["scenes"][0]["techniques"]
            .as_array()
            .with_context(|| format!("reruns/{file}.json: no techniques"))?
            .clone();
        let list = doc["scenes"][0]["techniques"]
            .as_array_mut()
            .with_context(|| format!("{name}.json: no techniques"))?;
        for entry in entries {
            let technique = entry["technique"].as_str().unwrap_or("?").to_string();
            let slot = list
                .iter_mut()
                .find(|t| t["technique"] == technique.as_str())
                .with_context(|| {
                    format!("reruns/{file}.json: '{technique}' is not in {name}.json")
                })?;
            if entry["early"]["frame"] != slot["early"]["frame"] {
                bail!("reruns/{file}.json: '{technique}' has another early frame");
            }
            if technique == "none" {
                let m = |t: &Value, key: &str| t["metrics"][key].as_f64().unwrap_or(f64::NAN);
                let (flip, rel) = (m(&entry, "flip"), m(&entry, "rel_mse"));
                let (flip0, rel0) = (m(slot, "flip"), m(slot, "rel_mse"));
                if !((flip - flip0).abs() <= 5e-4 && (rel - rel0).abs() <= 1e-3 * rel0.abs()) {
                    bail!(
                        "reruns/{file}.json: GI off is {flip} / {rel}, {name}.json's {flip0} / \
                         {rel0}: the build changed what every technique is judged against; \
                         re-run the whole scene"
                    );
                }
                continue;
            }
            *slot = entry;
        }
        let provenance = serde_json::json!({
            "provenance": rerun["provenance"],
            "adapter": rerun["adapter"],
        });
        match doc[RERUNS_KEY].as_array_mut() {
            Some(list) => list.push(provenance),
            None => doc[RERUNS_KEY] = Value::Array(vec![provenance]),
        }
    }
    Ok(())
}

/// A sort key of `name` that orders its runs of digits by their value.
fn natural_key(name: &str) -> Vec<(String, u64)> {
    let mut key = Vec::new();
    let mut text = String::new();
    let mut chars = name.chars().peekable();
    while let Some(c) = chars.next() {
        if c.is_ascii_digit() {
            let mut n = c.to_digit(10).unwrap_or(0) as u64;
            while let Some(d) = chars.peek().and_then(|d| d.to_digit(10)) {
                n = n.saturating_mul(10).saturating_add(d as u64);
                chars.next();
            }
            key.push((std::mem::take(&mut text), n));
        } else {
            text.push(c);
        }
    }
    key.push((text, u64::MAX));
    key
}

/// Scene names, and per technique its cells per scene.
type PerTechnique<T> = (Vec<String>, Vec<(String, Vec<T>)>);

/// The scene names of bench `files` (in order) and, per technique of the first file (in its
/// order), `cell` of its entry in every file; the files' provenance is added.
fn per_technique<T>(
    files: &[(String, Value)],
    provenance: &mut Provenance,
    mut cell: impl FnMut(&Value, &str) -> Result<T>,
) -> Result<PerTechnique<T>> {
    let mut scenes = Vec::new();
    let mut techniques: Vec<(String, Vec<T>)> = Vec::new();
    for (i, (name, doc)) in files.iter().enumerate() {
        provenance.add(doc);
        let list = doc["scenes"][0]["techniques"]
            .as_array()
            .with_context(|| format!("{name}.json: no techniques"))?;
        if i == 0 {
            techniques = list
                .iter()
                .map(|t| (t["technique"].as_str().unwrap_or("?").to_string(), vec![]))
                .collect();
        }
        for (technique, cells) in &mut techniques {
            let t = list
                .iter()
                .find(|t| t["technique"] == technique.as_str())
                .with_context(|| format!("{name}.json: no technique '{technique}'"))?;
            cells.push(cell(t, name)?);
        }
        scenes.push(name.clone());
    }
    Ok((scenes, techniques))
}

/// FLIP and relMSE of one technique on one scene.
#[derive(Clone, Copy, Debug)]
pub struct Error {
    pub flip: f64,
    pub rel_mse: f64,
}

/// The error of every technique on every scene of one protocol.
#[derive(Debug)]
pub struct ErrorRun {
    pub provenance: Provenance,
    /// Scene names, in file order.
    pub scenes: Vec<String>,
    /// Per technique (in the first file's order), its error per scene.
    pub techniques: Vec<(String, Vec<Error>)>,
    pub width: u64,
    pub height: u64,
    pub warmup: u64,
    /// Whether each technique was warmed up to its settled picture (`bench --settle`), and
    /// then the techniques that took more frames than `warmup`, with their count.
    pub settle: bool,
    pub own_warmups: Vec<(String, u64)>,
    /// The frame judged when the table is of the early frames (`bench --early`).
    pub early_frame: Option<u64>,
    /// Reference samples per pixel per scene (in scene order), and the transport.
    pub spp: Vec<u64>,
    pub against: String,
    /// Per scene, the error between its reference and one of another seed, where the data
    /// has `<scene>-noise.txt` (`scripts/settled-table.sh`; `octolux diff`'s output).
    pub noise: Vec<Option<Error>>,
}

impl ErrorRun {
    /// The run in `dir`; with `early`, the error of each technique's early frame (`bench
    /// --early`) instead of the measured one's.
    pub fn load(dir: &Path, shown: &str, early: bool) -> Result<ErrorRun> {
        let files = bench_files(dir)?;
        let mut provenance = Provenance {
            data: shown.to_string(),
            ..Default::default()
        };
        let mut early_frame = None;
        let (scenes, techniques) = per_technique(&files, &mut provenance, |t, name| {
            let m = match early {
                true => {
                    let e = &t["early"];
                    let frame = e["frame"].as_u64().with_context(|| {
                        format!(
                            "{name}.json: '{}' has no early frame (bench --early)",
                            t["technique"]
                        )
                    })?;
                    if *early_frame.get_or_insert(frame) != frame {
                        bail!("{name}.json: early frame {frame}, others {early_frame:?}");
                    }
                    &e["metrics"]
                }
                false => &t["metrics"],
            };
            Ok(Error {
                flip: number(m, "flip", name)?,
                rel_mse: number(m, "rel_mse", name)?,
            })
        })?;
        let first = &files[0].1;
        let reference = &first["scenes"][0]["references"][0];
        let warmup = first["warmup"].as_u64().unwrap_or(0);
        let own_warmups = first["scenes"][0]["techniques"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|t| {
                let frames = t["warmup"].as_u64().filter(|&w| w != warmup)?;
                Some((t["technique"].as_str().unwrap_or("?").to_string(), frames))
            })
            .collect();
        Ok(ErrorRun {
            provenance,
            techniques,
            width: first["width"].as_u64().unwrap_or(0),
            height: first["height"].as_u64().unwrap_or(0),
            warmup,
            settle: first["settle"].as_bool().unwrap_or(false),
            own_warmups,
            early_frame,
            spp: files
                .iter()
                .flat_map(|(_, f)| f["scenes"].as_array().cloned().unwrap_or_default())
                .map(|scene| scene["references"][0]["spp"].as_u64().unwrap_or(0))
                .collect(),
            against: reference["bounces"].as_str().unwrap_or("?").to_string(),
            noise: scenes
                .iter()
                .map(|scene| read_noise(&dir.join(format!("{scene}-noise.txt"))))
                .collect::<Result<_>>()?,
            scenes,
        })
    }

    /// GI off's errors (the technique `none`).
    pub fn off(&self) -> Result<&[Error]> {
        self.of("none")
            .context("the data has no `none` (GI off) to compare with")
    }

    pub fn of(&self, technique: &str) -> Option<&[Error]> {
        self.techniques
            .iter()
            .find(|(t, _)| t == technique)
            .map(|(_, e)| e.as_slice())
    }
}

/// FLIP and relMSE from `octolux diff`'s table in `path` (None if there is no such file).
fn read_noise(path: &Path) -> Result<Option<Error>> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Ok(None);
    };
    let value = |metric: &str| -> Result<f64> {
        text.lines()
            .find_map(|l| {
                let mut words = l.split_whitespace();
                (words.next() == Some(metric)).then(|| words.next()?.parse().ok())?
            })
            .with_context(|| format!("{}: no '{metric}' line", path.display()))
    };
    Ok(Some(Error {
        flip: value("FLIP")?,
        rel_mse: value("relMSE")?,
    }))
}

fn number(v: &Value, key: &str, file: &str) -> Result<f64> {
    v[key]
        .as_f64()
        .with_context(|| format!("{file}.json: no number '{key}' in {v}"))
}

/// One technique's temporal figures (`scripts/temporal.sh`).
#[derive(Debug)]
pub struct Temporal {
    pub technique: String,
    pub still_flicker: f64,
    pub far_light: f64,
    pub camera_flight: f64,
    /// Lag events: (name, frames, first relMSE after the change, settled relMSE).
    pub lags: Vec<(String, u64, f64, f64)>,
}

/// Flicker and lag of every technique.
#[derive(Debug)]
pub struct TemporalRun {
    pub provenance: Provenance,
    pub rows: Vec<Temporal>,
}

impl TemporalRun {
    pub fn load(dir: &Path, shown: &str) -> Result<TemporalRun> {
        let mut provenance = Provenance {
            data: shown.to_string(),
            ..Default::default()
        };
        let mut load = |name: &str| -> Result<Vec<Value>> {
            let doc = read_json(&dir.join(format!("{name}.json")))?;
            provenance.add(&doc);
            Ok(doc["scenes"][0]["techniques"]
                .as_array()
                .with_context(|| format!("{name}.json: no techniques"))?
                .clone())
        };
        let still = load("cornell-box")?;
        let animated = load("cornell-animated")?;
        let crossing = load("cornell-crossing")?;
        let far = load("two-rooms-far-light")?;
        let flight = load("sponza-flythrough")?;
        let find = |list: &[Value], name: &str| -> Result<Value> {
            list.iter()
                .find(|t| t["technique"] == name)
                .cloned()
                .with_context(|| format!("no technique '{name}' in every temporal file"))
        };
        let mut rows = Vec::new();
        for t in &still {
            let name = t["technique"].as_str().unwrap_or("?");
            let mut lags = Vec::new();
            for (label, source) in [
                ("spot on", t.clone()),
                ("spot off", t.clone()),
                ("spot jumps", find(&animated, name)?),
                ("sphere jumps", find(&crossing, name)?),
            ] {
                let index = if label == "spot off" { 1 } else { 0 };
                let lag = &source["lag"][index];
                lags.push((
                    label.to_string(),
                    lag["frames"].as_u64().context("a lag without frames")?,
                    lag["rel_mse"][0].as_f64().unwrap_or(f64::NAN),
                    lag["settled_rel_mse"].as_f64().unwrap_or(f64::NAN),
                ));
            }
            rows.push(Temporal {
                technique: name.to_string(),
                still_flicker: number(t, "flicker", "cornell-box")?,
                far_light: number(&find(&far, name)?, "motion_flicker", "two-rooms-far-light")?,
                camera_flight: number(
                    &find(&flight, name)?,
                    "motion_flicker",
                    "sponza-flythrough",
                )?,
                lags,
            });
        }
        Ok(TemporalRun { provenance, rows })
    }

    pub fn of(&self, technique: &str) -> Option<&Temporal> {
        self.rows.iter().find(|r| r.technique == technique)
    }
}

/// GI times of a GPU run, per technique and scene (`results/<gpu>/*.json`).
#[derive(Debug)]
pub struct GpuRun {
    pub provenance: Provenance,
    /// How the figures were kept (raw bench output, or transcribed).
    pub note: String,
    pub command: String,
    pub scenes: Vec<String>,
    /// Per technique: GI ms per scene, the dominant passes, the commit of the build.
    pub rows: Vec<(String, Vec<f64>, String, String)>,
    /// Per technique, the figures of an earlier run (`earlier` names it), where kept.
    pub earlier: Option<(String, Vec<String>)>,
}

impl GpuRun {
    pub fn load(path: &Path, shown: &str) -> Result<GpuRun> {
        let doc = read_json(path)?;
        let scenes: Vec<String> = doc["scenes"]
            .as_array()
            .context("no 'scenes'")?
            .iter()
            .filter_map(|s| s.as_str().map(str::to_string))
            .collect();
        let mut provenance = Provenance {
            data: shown.to_string(),
            ..Default::default()
        };
        provenance
            .adapters
            .insert(doc["adapter"].as_str().context("no 'adapter'")?.to_string());
        if let Some(day) = doc["date"].as_str() {
            provenance.days.insert(day.to_string());
        }
        let mut rows = Vec::new();
        for row in doc["gi_ms"].as_array().context("no 'gi_ms'")? {
            let technique = row["technique"]
                .as_str()
                .context("a row without technique")?;
            let ms: Vec<f64> = row["ms"]
                .as_array()
                .with_context(|| format!("{technique}: no 'ms'"))?
                .iter()
                .filter_map(Value::as_f64)
                .collect();
            if ms.len() != scenes.len() {
                bail!(
                    "{technique}: {} times for {} scenes",
                    ms.len(),
                    scenes.len()
                );
            }
            let commit = short_commit(row["commit"].as_str().unwrap_or("unknown"));
            provenance.commits.insert(commit.clone());
            rows.push((
                technique.to_string(),
                ms,
                row["dominant"].as_str().unwrap_or("").to_string(),
                commit,
            ));
        }
        let earlier = doc["earlier"].as_str().map(|what| {
            let cells = doc["gi_ms"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|r| r["earlier"].as_str().unwrap_or("-").to_string())
                .collect();
            (what.to_string(), cells)
        });
        Ok(GpuRun {
            earlier,
            provenance,
            note: doc["note"].as_str().unwrap_or("").to_string(),
            command: doc["command_line"].as_str().unwrap_or("").to_string(),
            scenes,
            rows,
        })
    }

    pub fn of(&self, technique: &str) -> Option<&[f64]> {
        self.rows
            .iter()
            .find(|r| r.0 == technique)
            .map(|r| r.1.as_slice())
    }
}

/// One technique on one scene of the moving protocol: its GI time and the work of the passes
/// that redo work when things move.
#[derive(Clone, Debug)]
pub struct MovingCell {
    /// GI total, mean over the measured frames (ms).
    pub gi_ms: f64,
    /// The work counts of the first measured frame, summed per quantity over the technique's
    /// passes (`"triangles drawn"` → n).
    pub work: Vec<(String, u64)>,
    /// The technique's own passes, in the bench's order.
    pub passes: Vec<PassCell>,
}

/// One of a technique's own passes: its median time and, where its work has a cost per unit
/// (`octolux::gpu::roofline`), its estimated bytes and its shares of the adapter's peaks.
#[derive(Clone, Debug, PartialEq)]
pub struct PassCell {
    pub name: String,
    pub median_ms: f64,
    /// Bytes asked per frame, share of the peak bandwidth, share of the peak operations.
    pub roofline: Option<(f64, f64, f64)>,
}

/// The moving protocol: every technique on still scenes and on their everything-moves
/// counterparts (`scripts/moving-table.sh`).
#[derive(Debug)]
pub struct MovingRun {
    pub provenance: Provenance,
    /// Scene names, in file order.
    pub scenes: Vec<String>,
    /// Per technique (in the first file's order), its cell per scene.
    pub techniques: Vec<(String, Vec<MovingCell>)>,
}

impl MovingRun {
    pub fn load(dir: &Path, shown: &str) -> Result<MovingRun> {
        let files = bench_files(dir)?;
        let mut provenance = Provenance {
            data: shown.to_string(),
            ..Default::default()
        };
        let (scenes, techniques) = per_technique(&files, &mut provenance, |t, name| {
            let gi_ms = number(&t["gi_total"], "mean_ms", name)?;
            let mut work: Vec<(String, u64)> = Vec::new();
            let passes = t["passes"].as_array().into_iter().flatten();
            let mut own = Vec::new();
            for pass in passes.filter(|p| p["gi"].as_bool() == Some(true)) {
                let r = &pass["roofline"];
                own.push(PassCell {
                    name: pass["name"].as_str().unwrap_or("?").to_string(),
                    median_ms: number(pass, "median_ms", name)?,
                    roofline: r["bytes"].as_f64().map(|bytes| {
                        let share = |key: &str| r[key].as_f64().unwrap_or(0.0);
                        (bytes, share("bandwidth_share"), share("ops_share"))
                    }),
                });
                for w in pass["work"].as_array().into_iter().flatten() {
                    let quantity = w["quantity"].as_str().unwrap_or("?").to_string();
                    let count = w["count"].as_u64().unwrap_or(0);
                    match work.iter_mut().find(|(q, _)| *q == quantity) {
                        Some((_, n)) => *n += count,
                        None => work.push((quantity, count)),
                    }
                }
            }
            Ok(MovingCell {
                gi_ms,
                work,
                passes: own,
            })
        })?;
        Ok(MovingRun {
            provenance,
            scenes,
            techniques,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::{natural_key, ErrorRun};
    use serde_json::{json, Value};

    /// A bench document of one scene: `techniques` as (name, FLIP, relMSE), made by `commit`.
    fn doc(commit: &str, width: u32, techniques: &[(&str, f64, f64)]) -> Value {
        let entries: Vec<Value> = techniques
            .iter()
            .map(|&(t, flip, rel)| {
                json!({"technique": t, "metrics": {"flip": flip, "rel_mse": rel},
                       "early": {"frame": 4, "metrics": {"flip": flip, "rel_mse": rel}}})
            })
            .collect();
        json!({
            "provenance": {"commit": commit, "date": "2026-11-30T00:00:00Z"},
            "adapter": {"name": "test adapter"},
            "width": width, "height": 4, "warmup": 3, "settle": true,
            "scenes": [{"techniques": entries,
                        "references": [{"spp": 512, "bounces": "unlimited", "seed": 7}]}],
        })
    }

    fn write(dir: &std::path::Path, name: &str, v: &Value) {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::write(dir.join(format!("{name}.json")), v.to_string()).unwrap();
    }

    #[test]
    fn a_rerun_replaces_its_techniques_and_adds_its_build() {
        let dir = tempfile::tempdir().unwrap();
        let main = [("none", 0.5, 0.2), ("a", 0.3, 0.1), ("b", 0.2, 0.05)];
        write(dir.path(), "room", &doc("1111111111aa", 8, &main));
        write(dir.path(), "box", &doc("1111111111aa", 8, &main));
        let reruns = dir.path().join("reruns");
        // GI off as it was (within rounding), `a` measured again.
        let rerun = [("none", 0.5002, 0.2001), ("a", 0.25, 0.08)];
        write(&reruns, "room", &doc("2222222222bb", 8, &rerun));
        let run = ErrorRun::load(dir.path(), "data", false).unwrap();
        let a = run.of("a").unwrap();
        assert_eq!(run.scenes, ["box", "room"]);
        assert_eq!((a[0].flip, a[1].flip), (0.3, 0.25));
        assert_eq!(run.of("b").unwrap()[1].flip, 0.2);
        assert_eq!(
            run.off().unwrap()[1].flip,
            0.5,
            "GI off is the scene file's"
        );
        let commits: Vec<&String> = run.provenance.commits.iter().collect();
        assert_eq!(commits, ["1111111111", "2222222222"]);
        // A later re-run of another technique, labelled, merges after it.
        let later = [("none", 0.4998, 0.2), ("b", 0.15, 0.04)];
        write(&reruns, "room.b-again", &doc("4444444444dd", 8, &later));
        let run = ErrorRun::load(dir.path(), "data", false).unwrap();
        assert_eq!(run.of("a").unwrap()[1].flip, 0.25);
        assert_eq!(run.of("b").unwrap()[1].flip, 0.15);
        assert_eq!(run.provenance.commits.len(), 3);
        std::fs::remove_file(reruns.join("room.b-again.json")).unwrap();

        // What a re-run may not change: GI off, the protocol, a scene with no document.
        for (name, bad, what) in [
            ("room", doc("3", 8, &[("none", 0.51, 0.2)]), "GI off"),
            ("room", doc("3", 16, &[("a", 0.1, 0.1)]), "'width'"),
            ("room", doc("3", 8, &[("c", 0.1, 0.1)]), "'c' is not in"),
            ("hall", doc("3", 8, &[("a", 0.1, 0.1)]), "no hall.json"),
        ] {
            std::fs::remove_dir_all(&reruns).unwrap();
            write(&reruns, name, &bad);
            let e = format!(
                "{:#}",
                ErrorRun::load(dir.path(), "data", false).unwrap_err()
            );
            assert!(e.contains(what), "{e}");
        }
    }

    #[test]
    fn numbers_sort_by_value_and_names_as_text() {
        let mut names = vec![
            "1280x720",
            "320x180",
            "640x360",
            "cornell-box",
            "cornell-animated",
        ];
        names.sort_by_key(|n| natural_key(n));
        assert_eq!(
            names,
            [
                "320x180",
                "640x360",
                "1280x720",
                "cornell-animated",
                "cornell-box"
            ]
        );
    }
}
