//! The bench report: frame-time statistics, the JSON layout and the printed tables.

use octolux::gpu::roofline::{self, Peaks};
use octolux::gpu::{GpuContext, PassTiming};
use octolux::metrics::Metrics;
use serde::Serialize;
use std::io::{self, Write};

/// Version of the JSON layout; raised when a field changes meaning or disappears.
pub const JSON_VERSION: u32 = 3;

/// Passes the renderer records around every technique (`Renderer::render`): shadow maps,
/// G-buffer and direct light before the GI update, compose after it.
const FRAME_PASSES: &[&str] = &["shadow maps", "gbuffer", "direct light", "compose"];
/// The last frame pass recorded before the technique's passes.
const BEFORE_GI: &str = "direct light";
/// The first frame pass recorded after the technique's passes.
const AFTER_GI: &str = "compose";

/// Statistics of one time over the measured frames, in milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    /// Arithmetic mean.
    pub mean_ms: f64,
    /// Median (mean of the two middle values for an even count).
    pub median_ms: f64,
    /// Fastest frame.
    pub min_ms: f64,
    /// Slowest frame (the worst case).
    pub max_ms: f64,
}

impl Stats {
    /// Statistics of `samples` (all zero when empty).
    pub fn of(samples: &[f64]) -> Stats {
        if samples.is_empty() {
            return Stats::default();
        }
        let mut sorted = samples.to_vec();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let median = if n % 2 == 1 {
            sorted[n / 2]
        } else {
            0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
        };
        Stats {
            mean_ms: sorted.iter().sum::<f64>() / n as f64,
            median_ms: median,
            min_ms: sorted[0],
            max_ms: sorted[n - 1],
        }
    }
}

/// Statistics of one named pass.
#[derive(Clone, Debug, Serialize)]
pub struct PassStats {
    /// Pass name, as the renderer or technique records it.
    pub name: String,
    /// Whether the pass belongs to the technique (counted in the GI total).
    pub gi: bool,
    /// Its times over the measured frames it ran in.
    #[serde(flatten)]
    pub stats: Stats,
    /// What it did in the first measured frame, counted exactly (the same on every adapter):
    /// empty for a pass that counts nothing or with `--no-work-counts`.
    pub work: Vec<PassWork>,
    /// The bytes and operations its work counts stand for, and the share of the adapter's
    /// peaks its median time achieves (`octolux::gpu::roofline`); none for a pass without
    /// costed counts.
    pub roofline: Option<PassRoofline>,
}

/// A pass on the roofline: its estimated bytes and operations in one frame, and the share of
/// the adapter's measured peaks they make in the pass's median time (bytes as the shaders ask
/// for them, so caches can take it past 1).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PassRoofline {
    pub bytes: f64,
    pub ops: f64,
    pub bandwidth_share: Option<f64>,
    pub ops_share: Option<f64>,
}

/// Estimates every pass's bytes and operations from its work counts and sets them against
/// `peaks` (where measured).
pub fn attach_roofline(passes: &mut [PassStats], peaks: Option<&Peaks>) {
    for p in passes {
        let counts: Vec<(&str, u64)> = p
            .work
            .iter()
            .map(|w| (w.quantity.as_str(), w.count))
            .collect();
        let Some(estimate) = roofline::estimate(&p.name, &counts) else {
            continue;
        };
        let shares = peaks.map(|k| k.shares(estimate, p.stats.median_ms * 1e-3));
        p.roofline = Some(PassRoofline {
            bytes: estimate.bytes,
            ops: estimate.ops,
            bandwidth_share: shares.map(|s| s.0),
            ops_share: shares.map(|s| s.1),
        });
    }
}

/// One counted quantity of a pass ([`octolux::gpu::work`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct PassWork {
    /// What is counted (`"cone samples"`).
    pub quantity: String,
    /// How many in one frame.
    pub count: u64,
}

/// Puts each work count with the pass it belongs to (counted under the name the technique
/// gives it, timed under that name scoped by the technique, or under its plain name for the
/// frame's own passes); counts of a pass the frames did not time are dropped.
pub fn attach_work(passes: &mut [PassStats], technique: &str, work: Vec<octolux::gpu::WorkCount>) {
    for w in work {
        let name = octolux::gpu::scoped_name(Some(technique), &w.pass);
        // The frame's own passes (shadow maps, G-buffer) are timed under their plain names.
        let found = match passes.iter().position(|p| p.name == name) {
            Some(i) => Some(i),
            None => passes.iter().position(|p| p.name == w.pass),
        };
        if let Some(p) = found.map(|i| &mut passes[i]) {
            p.work.push(PassWork {
                quantity: w.quantity,
                count: w.count,
            });
        }
    }
}

/// `n` in at most 4 significant digits with k, M, G, T (exact below 10000).
pub fn short_count(n: u64) -> String {
    if n < 10_000 {
        return n.to_string();
    }
    let mut v = n as f64;
    let mut unit = 0;
    while v >= 999.95 && unit < 4 {
        v /= 1000.0;
        unit += 1;
    }
    let digits = if v >= 100.0 {
        1
    } else if v >= 10.0 {
        2
    } else {
        3
    };
    format!("{v:.digits$}{}", ["", "k", "M", "G", "T"][unit])
}

/// GPU memory of one ledger owner.
#[derive(Clone, Debug, Serialize)]
pub struct OwnerMemory {
    /// Ledger owner (a technique name, `gbuffer`, `shadow-maps`, `scene`, ...).
    pub owner: String,
    /// MiB.
    pub mib: f64,
}

/// One GPU resource of the memory ledger.
#[derive(Clone, Debug, Serialize)]
pub struct MemoryEntry {
    /// Ledger owner.
    pub owner: String,
    /// The resource's name under its owner.
    pub name: String,
    /// MiB.
    pub mib: f64,
}

/// One technique's results on one scene.
#[derive(Clone, Debug, Serialize)]
pub struct TechniqueReport {
    /// Scene name.
    pub scene: String,
    /// Technique name.
    pub technique: String,
    /// The reference transport it was judged against; `null` with `--no-reference`.
    pub reference: Option<String>,
    /// Per-pass statistics in recording order.
    pub passes: Vec<PassStats>,
    /// Sum of the technique's own passes per frame.
    pub gi_total: Stats,
    /// Sum of all passes per frame.
    pub frame_total: Stats,
    /// CPU wall time of a whole frame (record, submit, wait, read the timers back).
    pub frame_wall: Stats,
    /// GPU memory the technique itself owns, MiB.
    pub technique_mib: f64,
    /// All GPU memory of the frame (scene, G-buffer, shadows, technique...), MiB.
    pub total_mib: f64,
    /// GPU memory per ledger owner.
    pub memory: Vec<OwnerMemory>,
    /// Every resource of the ledger (all owners), after the last measured frame.
    pub memory_entries: Vec<MemoryEntry>,
    /// wgpu's count of live objects after the warm-up frames and after the measured ones
    /// (equal unless something leaks per frame); `null` where wgpu keeps no count.
    pub objects: Option<[octolux::gpu::ResourceCounts; 2]>,
    /// Frames rendered before the measured ones: `--warmup`, or with `--settle` at least the
    /// technique's own settling frames.
    pub warmup: u32,
    /// Error of the last measured frame against the reference; `null` with `--no-reference`.
    pub metrics: Option<Metrics>,
    /// Error of the early frame (`--early`) against the reference of its time; `null`
    /// without it.
    pub early: Option<EarlyReport>,
    /// Flicker with nothing moving: the mean relative change of the indirect irradiance from
    /// one frame to the next with the scene held still after the measured frames
    /// (`bench/temporal.rs`); `null` with `--no-flicker`.
    pub flicker: Option<f64>,
    /// Flicker while the scene's own animation goes on (4 frames after the measured ones), at
    /// the same surface points (reprojected when the camera moves); `null` for a still scene
    /// or with `--no-flicker`. Meaningful where what moves does not light what is seen (a
    /// camera flying through a still scene, a light in another room).
    pub motion_flicker: Option<f64>,
    /// Lag after each `--lag` event, in their order.
    pub lag: Vec<LagReport>,
}

/// The error of an early frame (`--early N`), beside the measured one's.
#[derive(Clone, Debug, Serialize)]
pub struct EarlyReport {
    /// The frame judged, counted from 1 (the technique's first frame).
    pub frame: u32,
    /// Its error against the reference of its scene time.
    pub metrics: Metrics,
}

/// A technique's response to one `--lag` event.
#[derive(Clone, Debug, Serialize)]
pub struct LagReport {
    /// The event as given (`jump:A..B`, `on:LIGHT`, `off:LIGHT`).
    pub event: String,
    /// Frames after the event until relMSE stays within 10 % of the settled one (0: the first
    /// frame after the event already is).
    pub frames: u32,
    /// relMSE of the last frame rendered after the event (the settled error).
    pub settled_rel_mse: f64,
    /// relMSE against the after-state's reference, one per frame after the event.
    pub rel_mse: Vec<f64>,
}

/// One reference render.
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceReport {
    /// Light transport.
    pub bounces: String,
    /// Samples per pixel done.
    pub spp: u32,
    /// CPU wall time in seconds.
    pub seconds: f64,
}

/// One scene's results.
#[derive(Clone, Debug, Serialize)]
pub struct SceneReport {
    /// Scene name (from the scene file, or the model's file name).
    pub scene: String,
    /// The file given on the command line; `null` for the built-in Cornell box.
    pub file: Option<String>,
    /// Triangles over all object instances.
    pub triangles: usize,
    /// Whether anything in the scene moves (then time advances by `1/fps` per frame).
    pub animated: bool,
    /// Scene time of the first warm-up frame, s.
    pub first_time: f32,
    /// Scene time of the last measured frame, s (the frame compared with the reference).
    pub last_time: f32,
    /// Per technique, in `--gi` order.
    pub techniques: Vec<TechniqueReport>,
    /// Per reference rendered (empty with `--no-reference`).
    pub references: Vec<ReferenceReport>,
}

/// The GPU adapter and how passes were timed.
#[derive(Clone, Debug, Serialize)]
pub struct AdapterReport {
    /// Adapter name.
    pub name: String,
    /// Graphics API (`Vulkan`, `Metal`, `Dx12`, ...).
    pub backend: String,
    /// `DiscreteGpu`, `IntegratedGpu`, `VirtualGpu`, `Cpu` or `Other`.
    pub device_type: String,
    /// PCI vendor id.
    pub vendor: u32,
    /// PCI device id.
    pub device: u32,
    /// Driver name (`AdapterInfo::driver`).
    pub driver: String,
    /// Driver version and details (`AdapterInfo::driver_info`).
    pub driver_info: String,
    /// `GPU timestamps` or `CPU submit+wait`.
    pub timing_source: String,
}

impl AdapterReport {
    /// The adapter of `ctx`.
    pub fn of(ctx: &GpuContext) -> AdapterReport {
        let info = &ctx.info;
        AdapterReport {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend),
            device_type: format!("{:?}", info.device_type),
            vendor: info.vendor,
            device: info.device,
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
            timing_source: if ctx.timestamps {
                "GPU timestamps"
            } else {
                "CPU submit+wait"
            }
            .to_string(),
        }
    }

    /// One line: name, backend, type, driver, timing source.
    pub fn line(&self) -> String {
        let driver = match (self.driver.is_empty(), self.driver_info.is_empty()) {
            (true, true) => "unknown".to_string(),
            (false, true) => self.driver.clone(),
            (true, false) => self.driver_info.clone(),
            (false, false) => format!("{}, {}", self.driver, self.driver_info),
        };
        format!(
            "{} ({}, {}; driver: {}); pass times from {}",
            self.name, self.backend, self.device_type, driver, self.timing_source
        )
    }
}

/// What a reader needs to reproduce a run: the commit the binary was built from, when it ran
/// and how it was called.
#[derive(Clone, Debug, Serialize)]
pub struct Provenance {
    /// The git commit of the build (`+dirty`: tracked files differed from it; `unknown`:
    /// built outside a git checkout).
    pub commit: String,
    /// The package version.
    pub version: String,
    /// When the run started, UTC (RFC 3339, seconds).
    pub date: String,
    /// The command line, as given.
    pub command_line: Vec<String>,
}

impl Provenance {
    /// This process: its build's commit, the time now and its arguments.
    pub fn now() -> Provenance {
        Provenance {
            commit: env!("OCTOLUX_COMMIT").to_string(),
            version: env!("CARGO_PKG_VERSION").to_string(),
            date: utc_rfc3339(std::time::SystemTime::now()),
            command_line: std::env::args().collect(),
        }
    }
}

/// `time` as `YYYY-MM-DDTHH:MM:SSZ` (the proleptic Gregorian calendar from days since 1970).
pub fn utc_rfc3339(time: std::time::SystemTime) -> String {
    let secs = time
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Howard Hinnant's civil_from_days, on eras of 400 years.
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// The whole run: one document for every scene.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// Version of this layout.
    pub version: u32,
    /// Where the figures come from: the code, the time and the command line.
    pub provenance: Provenance,
    /// The adapter every technique ran on.
    pub adapter: AdapterReport,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Frames rendered before measuring (`--warmup`; each technique's own in its report).
    pub warmup: u32,
    /// Whether each technique was warmed up to its settled picture (`--settle`).
    pub settle: bool,
    /// Frames measured.
    pub frames: u32,
    /// Frames per second of scene time (animated scenes).
    pub fps: f32,
    /// Scene time of the first frame, s.
    pub time: f32,
    /// Scene camera as given (`--camera`: an index or a name).
    pub camera: String,
    /// Whether the reference was rendered and error measured.
    pub reference: bool,
    /// The adapter's memory bandwidth and arithmetic throughput, measured by a copy and an
    /// FMA kernel (with the work counts; none with `--no-work-counts`).
    pub peaks: Option<Peaks>,
    /// Per scene, in command-line order.
    pub scenes: Vec<SceneReport>,
}

/// Which passes of a frame belong to the technique: those recorded between direct light and
/// compose. If a frame lacks those markers, every pass the renderer does not record itself.
pub fn gi_passes(frame: &[PassTiming]) -> Vec<bool> {
    let before = frame.iter().position(|p| p.name == BEFORE_GI);
    let after = frame.iter().rposition(|p| p.name == AFTER_GI);
    match (before, after) {
        (Some(b), Some(a)) if b < a => (0..frame.len()).map(|i| b < i && i < a).collect(),
        _ => frame
            .iter()
            .map(|p| !FRAME_PASSES.contains(&p.name.as_str()))
            .collect(),
    }
}

/// Per-pass, GI-total and frame-total statistics of the measured frames (`wall_ms`: CPU wall
/// time per frame).
pub fn frame_stats(
    frames: &[Vec<PassTiming>],
    wall_ms: &[f64],
) -> (Vec<PassStats>, Stats, Stats, Stats) {
    let mut names: Vec<(String, bool, Vec<f64>)> = Vec::new();
    let mut gi_totals = Vec::with_capacity(frames.len());
    let mut frame_totals = Vec::with_capacity(frames.len());
    for frame in frames {
        let gi = gi_passes(frame);
        let mut gi_total = 0.0;
        for (pass, &is_gi) in frame.iter().zip(&gi) {
            if is_gi {
                gi_total += pass.ms;
            }
            match names.iter_mut().find(|(n, _, _)| *n == pass.name) {
                Some((_, _, samples)) => samples.push(pass.ms),
                None => names.push((pass.name.clone(), is_gi, vec![pass.ms])),
            }
        }
        gi_totals.push(gi_total);
        frame_totals.push(frame.iter().map(|p| p.ms).sum());
    }
    let passes = names
        .into_iter()
        .map(|(name, gi, samples)| PassStats {
            name,
            gi,
            stats: Stats::of(&samples),
            work: Vec::new(),
            roofline: None,
        })
        .collect();
    (
        passes,
        Stats::of(&gi_totals),
        Stats::of(&frame_totals),
        Stats::of(wall_ms),
    )
}

/// Prints one scene's table.
pub fn print_scene(out: &mut dyn Write, run: &BenchReport, scene: &SceneReport) -> io::Result<()> {
    let motion = if scene.animated {
        format!(
            "animated, t = {:.3}..{:.3} s at {} fps",
            scene.first_time, scene.last_time, run.fps
        )
    } else {
        format!("static, t = {} s", scene.first_time)
    };
    writeln!(
        out,
        "bench: '{}' ({}, {} triangles, {motion}) at {}x{}; {} warm-up + {} measured frames",
        scene.scene,
        scene.file.as_deref().unwrap_or("built-in"),
        scene.triangles,
        run.width,
        run.height,
        run.warmup,
        run.frames
    )?;
    writeln!(out, "adapter: {}", run.adapter.line())?;
    if let Some(peaks) = &run.peaks {
        writeln!(
            out,
            "peaks: {:.1} GB/s, {:.1} GFLOP/s ({}); [bw %, ops %] after a pass's work: its \
             estimated bytes and operations over its median time, as shares of them",
            peaks.bytes_per_s * 1e-9,
            peaks.ops_per_s * 1e-9,
            peaks.source
        )?;
    }
    let groups = format!(
        "  {:<12} {:^26}  {:^26}  {:^19}  {:^21}  {:^19}",
        "", "GI total ms", "frame ms", "GPU memory MiB", "error vs reference", "flicker"
    );
    writeln!(out, "{}", groups.trim_end())?;
    writeln!(
        out,
        "  {:<12} {:>8} {:>8} {:>8}  {:>8} {:>8} {:>8}  {:>9} {:>9}  {:>9} {:>11}  {:>9} {:>9}  reference",
        "technique",
        "mean",
        "median",
        "max",
        "mean",
        "median",
        "max",
        "technique",
        "frame",
        "FLIP",
        "relMSE",
        "still",
        "motion"
    )?;
    for t in &scene.techniques {
        let (flip, rel_mse) = match &t.metrics {
            Some(m) => (format!("{:.4}", m.flip), format!("{:.4e}", m.rel_mse)),
            None => ("-".to_string(), "-".to_string()),
        };
        writeln!(
            out,
            "  {:<12} {:>8.3} {:>8.3} {:>8.3}  {:>8.3} {:>8.3} {:>8.3}  {:>9.3} {:>9.3}  {:>9} {:>11}  {:>9} {:>9}  {}",
            t.technique,
            t.gi_total.mean_ms,
            t.gi_total.median_ms,
            t.gi_total.max_ms,
            t.frame_total.mean_ms,
            t.frame_total.median_ms,
            t.frame_total.max_ms,
            t.technique_mib,
            t.total_mib,
            flip,
            rel_mse,
            t.flicker.map_or("-".to_string(), |f| format!("{f:.2e}")),
            t.motion_flicker.map_or("-".to_string(), |f| format!("{f:.2e}")),
            t.reference.as_deref().unwrap_or("-")
        )?;
    }
    if run.settle {
        let own: Vec<String> = scene
            .techniques
            .iter()
            .filter(|t| t.warmup != run.warmup)
            .map(|t| format!("{} {}", t.technique, t.warmup))
            .collect();
        if !own.is_empty() {
            writeln!(
                out,
                "  warmed up to their settled picture: {} frames (the others {})",
                own.join(", "),
                run.warmup
            )?;
        }
    }
    for t in &scene.techniques {
        if let Some(early) = &t.early {
            writeln!(
                out,
                "  early frame {} of {:<12} FLIP {:.4}  relMSE {:.4e}",
                early.frame, t.technique, early.metrics.flip, early.metrics.rel_mse
            )?;
        }
    }
    let events = scene.techniques.first().map_or(0, |t| t.lag.len());
    for i in 0..events {
        let event = &scene.techniques[0].lag[i].event;
        writeln!(
            out,
            "  lag after {event} (frames until relMSE stays within 10% of its settled value):"
        )?;
        for t in &scene.techniques {
            if let Some(lag) = t.lag.get(i) {
                writeln!(
                    out,
                    "    {:<12} {:>3} frames  (relMSE {:.3e} on the first frame, {:.3e} settled)",
                    t.technique,
                    lag.frames,
                    lag.rel_mse.first().copied().unwrap_or(0.0),
                    lag.settled_rel_mse
                )?;
            }
        }
    }
    for r in &scene.references {
        writeln!(
            out,
            "  reference ({}): {} spp in {:.2} s (CPU), t = {:.3} s",
            r.bounces, r.spp, r.seconds, scene.last_time
        )?;
    }
    writeln!(
        out,
        "per-pass ms ({} frames; * = the technique's own passes, summed in GI total):",
        run.frames
    )?;
    writeln!(
        out,
        "  {:<26} {:>9} {:>9} {:>9} {:>9}  work in the first measured frame",
        "", "mean", "median", "min", "max"
    )?;
    for t in &scene.techniques {
        writeln!(out, "  {}", t.technique)?;
        for p in &t.passes {
            let label = format!("{} {}", if p.gi { "*" } else { " " }, p.name);
            let mut work: Vec<String> = p
                .work
                .iter()
                .map(|w| format!("{} {}", short_count(w.count), w.quantity))
                .collect();
            if let Some(PassRoofline {
                bandwidth_share: Some(bw),
                ops_share: Some(ops),
                ..
            }) = &p.roofline
            {
                let last = work.pop().unwrap_or_default();
                work.push(format!(
                    "{last} [{:.1} % bw, {:.1} % ops]",
                    bw * 100.0,
                    ops * 100.0
                ));
            }
            let line = format!(
                "    {:<24} {:>9.3} {:>9.3} {:>9.3} {:>9.3}  {}",
                label,
                p.stats.mean_ms,
                p.stats.median_ms,
                p.stats.min_ms,
                p.stats.max_ms,
                work.join(", ")
            );
            writeln!(out, "{}", line.trim_end())?;
        }
    }
    writeln!(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use octolux::gpu::TimingSource;

    fn pass(name: &str, ms: f64) -> PassTiming {
        PassTiming {
            name: name.to_string(),
            ms,
            source: TimingSource::CpuSubmitWait,
        }
    }

    #[test]
    fn dates_in_utc() {
        use std::time::{Duration, UNIX_EPOCH};
        let at = |secs| utc_rfc3339(UNIX_EPOCH + Duration::from_secs(secs));
        assert_eq!(at(0), "1970-01-01T00:00:00Z");
        // A leap day and the turn of a century year that is a leap year.
        assert_eq!(at(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(at(1_798_761_599), "2026-12-31T23:59:59Z");
        assert_eq!(at(4_107_542_400), "2100-03-01T00:00:00Z");
    }

    #[test]
    fn stats_of_odd_and_even_counts() {
        let s = Stats::of(&[3.0, 1.0, 2.0]);
        assert_eq!(
            (s.mean_ms, s.median_ms, s.min_ms, s.max_ms),
            (2.0, 2.0, 1.0, 3.0)
        );
        let s = Stats::of(&[4.0, 1.0, 2.0, 9.0]);
        assert_eq!(
            (s.mean_ms, s.median_ms, s.min_ms, s.max_ms),
            (4.0, 3.0, 1.0, 9.0)
        );
        assert_eq!(Stats::of(&[]), Stats::default());
    }

    #[test]
    fn short_counts() {
        let cases = [
            (0, "0"),
            (9999, "9999"),
            (10_000, "10.00k"),
            (123_456, "123.5k"),
            (999_949, "999.9k"),
            (999_950, "1.000M"),
            (2_073_600, "2.074M"),
            (530_841_600, "530.8M"),
            (u64::MAX, "18446744.1T"),
        ];
        for (n, text) in cases {
            assert_eq!(short_count(n), text, "{n}");
        }
    }

    #[test]
    fn gi_passes_lie_between_direct_light_and_compose() {
        let frame = [
            pass("shadow maps", 1.0),
            pass("gbuffer", 1.0),
            pass("direct light", 1.0),
            pass("olpv rsm", 2.0),
            pass("olpv downsample", 3.0),
            pass("compose", 1.0),
        ];
        assert_eq!(gi_passes(&frame), [false, false, false, true, true, false]);
        // Without the markers, everything the renderer does not record itself.
        assert_eq!(gi_passes(&frame[3..]), [true, true, false]);
        let (passes, gi, total, _) = frame_stats(&[frame.to_vec(), frame.to_vec()], &[9.0, 9.0]);
        assert_eq!(passes.len(), 6);
        assert_eq!(gi.mean_ms, 5.0);
        assert_eq!(total.max_ms, 9.0);
    }
}
