//! Mutation fuzzing of every loader: TOML scene files, OBJ + MTL, PLY (ASCII, binary and
//! gzipped), glTF and GLB, Mitsuba XML, and Radiance HDR, OpenEXR, PNG and TGA images.
//!
//! Each target first loads its corpus, `tests/fuzz_corpus/<target>/` (inputs that once failed,
//! kept so that every run tries them), then its seeds (the shipped files under `scenes/` and
//! small files made here with the library's own writers), then mutations of the seeds made by
//! a seeded generator. Cases run one at a time on a worker thread. Every case must end in a
//! value or an error within [`CASE_DEADLINE`] (a case still running then fails the test at
//! once): no panic (each case runs under `catch_unwind`, and a panic hook also catches panics
//! a loader catches itself, on any thread), at most [`MEMORY_CAP`] bytes allocated at once by
//! the whole process, and a loaded scene must survive what the renderers first compute from
//! it. A failing case is saved under the temporary folder and named in the failure with the
//! seed that repeats the run.
//!
//! The base seed changes from run to run and is printed at the start; `OCTOLUX_FUZZ_SEED=S`
//! repeats run S. The normal test run does [`DEFAULT_ITERATIONS`] cases per target. More on
//! demand: `OCTOLUX_FUZZ_ITERS=100000 cargo test --release -p octolux --test fuzz_loaders`.

mod counting_alloc;

use counting_alloc::{peak_since, reset_peak};
use octolux::image_io::HdrImage;
use octolux::scene::{EnvironmentMap, Scene, Texture};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
use std::sync::{mpsc, Mutex, MutexGuard, OnceLock, PoisonError};
use std::time::{Duration, Instant};
use tempfile::TempDir;

/// Cases per target in the normal test run (after its corpus).
const DEFAULT_ITERATIONS: usize = 3000;
/// Most bytes the process may hold at once during a case beyond what it held before.
const MEMORY_CAP: isize = 512 << 20;
/// Longest time one case may take; a case still running then fails the test at once.
const CASE_DEADLINE: Duration = Duration::from_secs(10);
/// The targets, each the name of its corpus folder under [`corpus_dir`].
const TARGETS: [&str; 12] = [
    "toml", "obj", "mtl", "ply", "ply-gz", "gltf", "glb", "xml", "hdr", "exr", "png", "tga",
];

// ---------------------------------------------------------------- one case at a time

/// Held by every test here while it runs: the memory counts and the panic flag are the whole
/// process's, so a case must run alone (the test harness runs tests on several threads).
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// A case that never finished: its thread is still running, so no later case could be
/// measured alone.
static STUCK: OnceLock<String> = OnceLock::new();

/// Waits for the other targets; fails when one of them left a case running.
fn alone() -> MutexGuard<'static, ()> {
    // A target that failed poisons the lock; that failure is already reported.
    let guard = ONE_AT_A_TIME.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some(stuck) = STUCK.get() {
        panic!("not run: a case of another target never finished:\n{stuck}");
    }
    guard
}

// ---------------------------------------------------------------- panics on any thread

/// Set by the panic hook: a panic on any thread, even one a loader catches itself.
static PANICKED: AtomicBool = AtomicBool::new(false);

/// Installs (once) a panic hook that sets [`PANICKED`], then reports as usual.
fn watch_panics() {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let report = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            PANICKED.store(true, Relaxed);
            report(info);
        }));
    });
}

// ---------------------------------------------------------------- mutation

/// Values that make parsers take unusual paths.
const TOKENS: &[&str] = &[
    "0",
    "-1",
    "1e30",
    "-1e30",
    "1e308",
    "3.4e38",
    "nan",
    "inf",
    "4294967295",
    "2147483648",
    "65536",
    "99999999999",
    "0.0",
    "1e-45",
    "\"\"",
    "[]",
    "{}",
    "<",
    ">",
    "\n",
    "=",
    ",",
    "\0",
    "&",
    "$",
    "..",
    "/",
    "%",
    "e",
    "-",
    "\u{feff}",
];

/// Little-endian 32-bit values worth writing over binary fields.
const WORDS: &[u32] = &[
    0,
    1,
    0xff,
    0xffff,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    0x0001_0000,
    0x7f80_0000, // +inf as f32
    0x7fc0_0000, // NaN as f32
];

/// One to four random edits of `data` (mostly one, so that cases get past the first check);
/// `others` are spliced from.
fn mutate(rng: &mut fastrand::Rng, data: &[u8], others: &[Vec<u8>]) -> Vec<u8> {
    let mut out = data.to_vec();
    let edits = [1, 1, 1, 1, 2, 2, 3, 4][rng.usize(0..8)];
    for _ in 0..edits {
        let len = out.len();
        let at = if len == 0 { 0 } else { rng.usize(0..len) };
        match rng.u8(0..10) {
            0 if len > 0 => out[at] ^= 1 << rng.u8(0..8),
            1 if len > 0 => out[at] = rng.u8(..),
            2 if len > 0 => {
                let n = rng.usize(1..=(len - at).min(64));
                out.drain(at..at + n);
            }
            3 if len > 0 => {
                let n = rng.usize(1..=(len - at).min(256));
                let copy = out[at..at + n].to_vec();
                let to = rng.usize(0..=len);
                out.splice(to..to, copy);
            }
            4 => out.truncate(at),
            5 | 6 => {
                let token = TOKENS[rng.usize(0..TOKENS.len())].as_bytes();
                // Replace a run of digits (or nothing) at `at` with the token.
                let mut end = at;
                while end < len && (out[end].is_ascii_digit() || out[end] == b'.') {
                    end += 1;
                }
                out.splice(at..end, token.iter().copied());
            }
            7 if len >= 4 => {
                let at = rng.usize(0..=len - 4);
                let word = WORDS[rng.usize(0..WORDS.len())];
                out[at..at + 4].copy_from_slice(&word.to_le_bytes());
            }
            8 if !others.is_empty() => {
                let other = &others[rng.usize(0..others.len())];
                if !other.is_empty() {
                    let from = rng.usize(0..other.len());
                    let n = rng.usize(1..=(other.len() - from).min(256));
                    out.splice(at..at, other[from..from + n].iter().copied());
                }
            }
            _ => {
                // Repeat a line (or a run of bytes) many times.
                let end = (at + rng.usize(1..=32)).min(len);
                let copy = out[at..end].to_vec();
                for _ in 0..rng.usize(1..=64) {
                    out.splice(at..at, copy.iter().copied());
                }
            }
        }
    }
    out
}

/// Recomputes the CRC of every PNG chunk, so that mutations reach the decoder proper.
fn fix_png_crcs(data: &mut [u8]) {
    let mut at = 8;
    while at + 12 <= data.len() {
        let len = u32::from_be_bytes([data[at], data[at + 1], data[at + 2], data[at + 3]]) as usize;
        let Some(end) = (at + 8).checked_add(len) else {
            return;
        };
        if end + 4 > data.len() {
            return;
        }
        let mut crc = flate2::Crc::new();
        crc.update(&data[at + 4..end]);
        data[end..end + 4].copy_from_slice(&crc.sum().to_be_bytes());
        at = end + 4;
    }
}

fn gzip(data: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(data).unwrap();
    enc.finish().unwrap()
}

// ---------------------------------------------------------------- seeds

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn shipped(relative: &str) -> Vec<u8> {
    std::fs::read(repo().join(relative)).unwrap_or_else(|e| panic!("{relative}: {e}"))
}

fn shipped_with_extension(dir: &str, ext: &str) -> Vec<Vec<u8>> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(repo().join(dir))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    paths.sort();
    paths.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

const MTL: &str =
    "newmtl white\nKd 0.8 0.8 0.8\nnewmtl glow\nKd 0.1 0.1 0.1\nKe 4 4 2\nmap_Kd tex.png\nd 0.9\n";

const OBJ_WITH_MTL: &str = "mtllib scene.mtl\no quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nusemtl white\nf 1/1/1 2/2/1 3/3/1\nusemtl glow\n\
f 1/1/1 3/3/1 4/4/1\n";

fn ascii_ply() -> Vec<u8> {
    b"ply\nformat ascii 1.0\ncomment two triangles\nelement vertex 4\nproperty float x\n\
property float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
property float u\nproperty float v\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
element face 2\nproperty list uchar int vertex_indices\nend_header\n\
0 0 0 0 0 1 0 0 255 0 0\n1 0 0 0 0 1 1 0 0 255 0\n1 1 0 0 0 1 1 1 0 0 255\n\
0 1 0 0 0 1 0 1 255 255 255\n3 0 1 2\n4 0 2 3 1\n"
        .to_vec()
}

fn binary_ply() -> Vec<u8> {
    let mut out = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n\
property float y\nproperty float z\nelement face 2\nproperty list uchar uint vertex_indices\n\
element extra 1\nproperty double weight\nend_header\n"
        .to_vec();
    for v in [0f32, 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for face in [[0u32, 1, 2], [0, 2, 3]] {
        out.push(3);
        for i in face {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out.extend_from_slice(&0.5f64.to_le_bytes());
    out
}

fn png_seed() -> Vec<u8> {
    let mut rgba = Vec::new();
    for i in 0..16u8 {
        rgba.extend_from_slice(&[i * 16, 255 - i * 16, i, 128 + i]);
    }
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbaImage::from_raw(4, 4, rgba)
        .unwrap()
        .write_to(&mut out, image::ImageFormat::Png)
        .unwrap();
    out.into_inner()
}

fn tga_seed() -> Vec<u8> {
    let rgb: Vec<u8> = (0..4 * 4 * 3).map(|i| (i * 5) as u8).collect();
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbImage::from_raw(4, 4, rgb)
        .unwrap()
        .write_to(&mut out, image::ImageFormat::Tga)
        .unwrap();
    out.into_inner()
}

fn exr_seed(dir: &Path) -> Vec<u8> {
    let mut image = HdrImage::new(8, 4);
    for (i, p) in image.pixels.iter_mut().enumerate() {
        *p = glam::Vec3::new(i as f32 * 0.25, 1.0, 0.5);
    }
    let path = dir.join("seed.exr");
    image.write_exr(&path).unwrap();
    std::fs::read(path).unwrap()
}

/// A glTF document with the triangle's buffer and a PNG texture as data URIs, a light and a
/// camera.
fn gltf_document(buffer_uri: Option<String>, image_uri: String) -> serde_json::Value {
    let mut buffer = serde_json::json!({"byteLength": 42});
    if let Some(uri) = buffer_uri {
        buffer["uri"] = serde_json::json!(uri);
    }
    serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "spot", "intensity": 683.0, "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}}
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"name": "tri", "mesh": 0, "scale": [2.0, 2.0, 2.0]},
            {"translation": [0.0, 3.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"translation": [0.0, 1.0, 10.0], "camera": 0}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 100.0}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 2}, "indices": 1, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "emissiveFactor": [0.1, 0.0, 0.0]}],
        "textures": [{"source": 0}],
        "images": [{"uri": image_uri}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC2", "byteOffset": 4}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 6}
        ],
        "buffers": [buffer]
    })
}

fn triangle_buffer() -> Vec<u8> {
    let positions: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let indices: [u16; 3] = [0, 1, 2];
    [
        bytemuck::cast_slice(&positions),
        bytemuck::cast_slice(&indices),
    ]
    .concat()
}

fn base64(bytes: &[u8]) -> String {
    base64::encode(bytes)
}

fn gltf_seed() -> Vec<u8> {
    gltf_document(
        Some(format!(
            "data:application/octet-stream;base64,{}",
            base64(&triangle_buffer())
        )),
        format!("data:image/png;base64,{}", base64(&png_seed())),
    )
    .to_string()
    .into_bytes()
}

fn glb_seed() -> Vec<u8> {
    let mut json = gltf_document(None, String::new());
    json["images"] = serde_json::json!([]);
    json["textures"] = serde_json::json!([]);
    json["materials"] = serde_json::json!([{}]);
    let mut json = json.to_string().into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = triangle_buffer();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

// ---------------------------------------------------------------- the harness

/// What a case loads.
#[derive(Clone, Copy)]
enum Loader {
    Scene,
    Sky,
    Texture,
}

struct Target {
    /// The file name the mutated bytes are written to (its extension picks the loader).
    file: &'static str,
    loader: Loader,
    /// The file loaded, when not `file` itself (an OBJ whose material library is mutated).
    load: Option<&'static str>,
    seeds: Vec<Vec<u8>>,
    /// Applied to the mutated bytes before they are written (gzip, PNG CRCs).
    finish: fn(Vec<u8>) -> Vec<u8>,
}

/// The number in environment variable `name`, or `default` when it is not set.
fn from_env<T: std::str::FromStr>(name: &str, default: impl FnOnce() -> T) -> T {
    match std::env::var(name) {
        Ok(v) => v
            .parse()
            .unwrap_or_else(|_| panic!("{name}={v} is not a number")),
        Err(_) => default(),
    }
}

fn iterations() -> usize {
    from_env("OCTOLUX_FUZZ_ITERS", || DEFAULT_ITERATIONS)
}

/// The run's base seed: `OCTOLUX_FUZZ_SEED`, or a new one each run so that runs try different
/// mutations. Printed once, past the test harness's capture, so that every log shows it.
fn base_seed() -> u64 {
    static SEED: OnceLock<u64> = OnceLock::new();
    *SEED.get_or_init(|| {
        let seed = from_env("OCTOLUX_FUZZ_SEED", || fastrand::u64(..));
        let line =
            format!("fuzz_loaders: base seed {seed} (OCTOLUX_FUZZ_SEED={seed} repeats the run)\n");
        let _ = std::io::stderr().write_all(line.as_bytes());
        seed
    })
}

/// Where a target's corpus lives: inputs that once failed, loaded first in every run.
fn corpus_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz_corpus")
        .join(name)
}

/// The files of a target's corpus (none when it has no folder), in name order.
fn corpus(name: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let Ok(entries) = std::fs::read_dir(corpus_dir(name)) else {
        return Vec::new();
    };
    let mut paths: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).collect();
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let data = std::fs::read(&p).unwrap();
            (p, data)
        })
        .collect()
}

/// A folder holding what the seeds refer to: a texture, a material library, the shipped
/// models and sky; removed when the returned guard drops.
fn workspace(name: &str) -> TempDir {
    let tmp = tempfile::Builder::new()
        .prefix(&format!("octolux-fuzz-{name}-"))
        .tempdir()
        .unwrap();
    let dir = tmp.path();
    std::fs::create_dir_all(dir.join("models")).unwrap();
    std::fs::create_dir_all(dir.join("skies")).unwrap();
    std::fs::write(dir.join("tex.png"), png_seed()).unwrap();
    std::fs::write(dir.join("scene.mtl"), MTL).unwrap();
    std::fs::write(dir.join("scene.obj"), OBJ_WITH_MTL).unwrap();
    for model in ["uv-sphere.obj", "two-rooms.obj"] {
        std::fs::write(
            dir.join("models").join(model),
            shipped(&format!("scenes/models/{model}")),
        )
        .unwrap();
    }
    std::fs::write(
        dir.join("skies/afternoon.hdr"),
        shipped("scenes/skies/afternoon.hdr"),
    )
    .unwrap();
    tmp
}

/// Replaces the file at `path` with `data`. Removed and written anew, not truncated: ext4
/// flushes a file that is truncated and written again when it is closed, which made writing a
/// case take longer than loading it.
fn replace(path: &Path, data: &[u8]) {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => panic!("{}: {e}", path.display()),
        _ => std::fs::write(path, data).unwrap(),
    }
}

/// The outcome of one case.
enum Outcome {
    Loaded,
    Rejected,
}

fn load(loader: Loader, path: &Path) -> Result<Outcome, String> {
    match loader {
        // Loading validates the scene; what is left to try is what the renderers compute from
        // a scene validation let through (a panic there fails the case).
        Loader::Scene => match Scene::load(path) {
            Ok(scene) => {
                let frame = scene.frame(0.0, 0);
                std::hint::black_box(scene.world_triangles(&frame));
                std::hint::black_box(scene.gi_bounds_over_animation());
                Ok(Outcome::Loaded)
            }
            Err(_) => Ok(Outcome::Rejected),
        },
        // Loading checks the texels (negative or non-finite are errors).
        Loader::Sky => Ok(match EnvironmentMap::load(path) {
            Ok(_) => Outcome::Loaded,
            Err(_) => Outcome::Rejected,
        }),
        Loader::Texture => match Texture::load(path) {
            Ok(t) => {
                // The GPU upload takes the size and the texels as they are.
                if t.rgba.len() != t.width as usize * t.height as usize * 4 {
                    return Err("a loaded texture's size does not match its texels".into());
                }
                Ok(Outcome::Loaded)
            }
            Err(_) => Ok(Outcome::Rejected),
        },
    }
}

/// A thread that loads a target's file each time it is told to, so that the test can stop
/// waiting for a case that hangs (a thread cannot be stopped; a hung one is left behind).
struct Worker {
    go: mpsc::Sender<()>,
    done: mpsc::Receiver<Result<Outcome, String>>,
    thread: std::thread::JoinHandle<()>,
}

/// How a case went wrong.
enum Failure {
    /// The case ended, badly.
    Failed(String),
    /// The case is still running at its deadline.
    Stuck,
}

impl Worker {
    fn start(name: &str, loader: Loader, path: PathBuf) -> Worker {
        let (go, go_rx) = mpsc::channel();
        let (done_tx, done) = mpsc::channel();
        let thread = std::thread::Builder::new()
            .name(format!("fuzz-{name}"))
            .spawn(move || {
                for () in go_rx {
                    let result = std::panic::catch_unwind(|| load(loader, &path))
                        .unwrap_or_else(|_| Err("panicked".into()));
                    if done_tx.send(result).is_err() {
                        return;
                    }
                }
            })
            .unwrap();
        Worker { go, done, thread }
    }

    /// Loads the target's file once, adding the outcome, the time and the most memory held at
    /// once meanwhile to `stats`.
    fn run(&self, stats: &mut Stats) -> Result<(), Failure> {
        PANICKED.store(false, Relaxed);
        let base = reset_peak();
        let began = Instant::now();
        self.go.send(()).unwrap();
        let result = match self.done.recv_timeout(CASE_DEADLINE) {
            Ok(result) => result,
            Err(mpsc::RecvTimeoutError::Timeout) => return Err(Failure::Stuck),
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                unreachable!("the worker catches every panic")
            }
        };
        stats.slowest = stats.slowest.max(began.elapsed());
        let memory = peak_since(base);
        stats.most_memory = stats.most_memory.max(memory);
        match result {
            Ok(Outcome::Loaded) => stats.loaded += 1,
            Ok(Outcome::Rejected) => stats.rejected += 1,
            Err(why) => return Err(Failure::Failed(why)),
        }
        if PANICKED.load(Relaxed) {
            return Err(Failure::Failed(
                "panicked (caught inside the loader)".into(),
            ));
        }
        if memory > MEMORY_CAP {
            return Err(Failure::Failed(format!(
                "allocated {} MiB at once",
                memory >> 20
            )));
        }
        Ok(())
    }

    fn stop(self) {
        drop(self.go);
        self.thread.join().unwrap();
    }
}

/// What a target's cases did.
#[derive(Default)]
struct Stats {
    loaded: usize,
    rejected: usize,
    slowest: Duration,
    most_memory: isize,
}

/// Runs the target's corpus and cases; panics listing the failing inputs (saved to files), or
/// at once naming a case that runs past [`CASE_DEADLINE`].
fn fuzz(name: &'static str, target: impl FnOnce() -> Target) {
    assert!(TARGETS.contains(&name), "{name} is not in TARGETS");
    let _alone = alone();
    watch_panics();
    let seed = base_seed();
    let target = target();
    let tmp = workspace(name);
    let path = tmp.path().join(target.file);
    let worker = Worker::start(
        name,
        target.loader,
        tmp.path().join(target.load.unwrap_or(target.file)),
    );
    let heading = format!("{name} (base seed {seed}; OCTOLUX_FUZZ_SEED={seed} repeats the run)");
    // A failed case is listed at the end; a stuck one fails the test at once, since its thread
    // cannot be stopped.
    let mut failures = Vec::new();
    let mut report = |failure: Failure, case: String, input: String| match failure {
        Failure::Failed(why) => failures.push(format!("{case}: {why}{input}")),
        Failure::Stuck => {
            let message = format!(
                "{heading}:\n{case}: did not finish within {} s{input}",
                CASE_DEADLINE.as_secs()
            );
            // Past the harness's capture too, in case the process never gets to print it.
            let _ = std::io::stderr().write_all(format!("{message}\n").as_bytes());
            STUCK.set(message.clone()).unwrap();
            panic!("{message}");
        }
    };
    let mut stats = Stats::default();
    let start = Instant::now();
    let corpus = corpus(name);
    for (file, data) in &corpus {
        replace(&path, data);
        if let Err(failure) = worker.run(&mut stats) {
            report(
                failure,
                format!("corpus file {}", file.display()),
                String::new(),
            );
        }
    }
    let iterations = iterations();
    let mut rng = fastrand::Rng::with_seed(seed ^ fxhash(name));
    for case in 0..iterations {
        let original = &target.seeds[case % target.seeds.len()];
        // The first cases are the seeds themselves.
        let data = if case < target.seeds.len() {
            original.clone()
        } else {
            mutate(&mut rng, original, &target.seeds)
        };
        let data = (target.finish)(data);
        replace(&path, &data);
        if let Err(failure) = worker.run(&mut stats) {
            let saved = std::env::temp_dir()
                .join(format!("octolux-fuzz-{name}-{seed}-{case}-{}", target.file));
            std::fs::write(&saved, &data).unwrap();
            let input = format!(
                "; input saved to {} (to try it in every run, copy it into {}/)",
                saved.display(),
                corpus_dir(name).display()
            );
            report(failure, format!("case {case}"), input);
        }
    }
    worker.stop();
    println!(
        "{name}: {iterations} cases after {} from the corpus (base seed {seed}) in {:.1} s: {} \
         loaded, {} rejected, slowest {:.0} ms, most memory {:.1} MiB",
        corpus.len(),
        start.elapsed().as_secs_f64(),
        stats.loaded,
        stats.rejected,
        stats.slowest.as_secs_f64() * 1e3,
        stats.most_memory as f64 / (1 << 20) as f64
    );
    assert!(failures.is_empty(), "{heading}:\n{}", failures.join("\n"));
    // The seeds themselves load, so the cases explore past the first check.
    assert!(stats.loaded > 0, "{name}: nothing loaded");
}

/// A stable hash of a name, so that each target mutates differently.
fn fxhash(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    })
}

fn keep(data: Vec<u8>) -> Vec<u8> {
    data
}

fn png_crcs(mut data: Vec<u8>) -> Vec<u8> {
    fix_png_crcs(&mut data);
    data
}

fn gzipped(data: Vec<u8>) -> Vec<u8> {
    gzip(&data)
}

#[test]
fn fuzz_scene_files() {
    fuzz("toml", || {
        let mut seeds = shipped_with_extension("scenes", "toml");
        // The shipped scenes that need the shared scenes folder fail at once without it:
        // keep the self-contained ones first, so most cases start from a scene that loads.
        seeds.sort_by_key(|s| String::from_utf8_lossy(s).contains("scenes:"));
        seeds.truncate(5);
        Target {
            file: "scene.toml",
            load: None,
            loader: Loader::Scene,
            seeds,
            finish: keep,
        }
    });
}

#[test]
fn fuzz_obj() {
    fuzz("obj", || Target {
        file: "fuzz.obj",
        load: None,
        loader: Loader::Scene,
        seeds: vec![
            OBJ_WITH_MTL.as_bytes().to_vec(),
            shipped("scenes/models/two-rooms.obj"),
        ],
        finish: keep,
    });
}

#[test]
fn fuzz_mtl() {
    // The mutated file is the material library of a fixed OBJ.
    fuzz("mtl", || Target {
        file: "scene.mtl",
        load: Some("scene.obj"),
        loader: Loader::Scene,
        seeds: vec![MTL.as_bytes().to_vec()],
        finish: keep,
    });
}

#[test]
fn fuzz_ply() {
    fuzz("ply", || Target {
        file: "fuzz.ply",
        load: None,
        loader: Loader::Scene,
        seeds: vec![ascii_ply(), binary_ply()],
        finish: keep,
    });
}

#[test]
fn fuzz_ply_gz() {
    fuzz("ply-gz", || Target {
        file: "fuzz.ply.gz",
        load: None,
        loader: Loader::Scene,
        seeds: vec![binary_ply(), ascii_ply()],
        finish: gzipped,
    });
}

#[test]
fn fuzz_gltf() {
    fuzz("gltf", || Target {
        file: "fuzz.gltf",
        load: None,
        loader: Loader::Scene,
        seeds: vec![gltf_seed()],
        finish: keep,
    });
}

#[test]
fn fuzz_glb() {
    fuzz("glb", || Target {
        file: "fuzz.glb",
        load: None,
        loader: Loader::Scene,
        seeds: vec![glb_seed()],
        finish: keep,
    });
}

#[test]
fn fuzz_mitsuba() {
    fuzz("xml", || Target {
        file: "fuzz.xml",
        load: None,
        loader: Loader::Scene,
        seeds: vec![shipped("scenes/mitsuba-example.xml")],
        finish: keep,
    });
}

#[test]
fn fuzz_hdr() {
    fuzz("hdr", || Target {
        file: "fuzz.hdr",
        load: None,
        loader: Loader::Sky,
        seeds: vec![shipped("scenes/skies/afternoon.hdr")],
        finish: keep,
    });
}

#[test]
fn fuzz_exr() {
    fuzz("exr", || Target {
        file: "fuzz.exr",
        load: None,
        loader: Loader::Sky,
        seeds: vec![exr_seed(workspace("exr-seed").path())],
        finish: keep,
    });
}

#[test]
fn fuzz_png() {
    fuzz("png", || Target {
        file: "fuzz.png",
        load: None,
        loader: Loader::Texture,
        seeds: vec![png_seed()],
        finish: png_crcs,
    });
}

#[test]
fn fuzz_tga() {
    fuzz("tga", || Target {
        file: "fuzz.tga",
        load: None,
        loader: Loader::Texture,
        seeds: vec![tga_seed()],
        finish: keep,
    });
}

#[test]
fn the_allocation_counter_sees_every_thread() {
    let _alone = alone();
    let base = reset_peak();
    std::thread::spawn(|| drop(std::hint::black_box(vec![1u8; 8 << 20])))
        .join()
        .unwrap();
    // Not quite 8 MiB: what other threads free meanwhile counts too.
    let peak = peak_since(base);
    assert!(peak > 7 << 20, "{peak}");
    // A mutation never panics, whatever the data.
    let mut rng = fastrand::Rng::with_seed(1);
    for len in [0, 1, 3, 4, 100] {
        for _ in 0..200 {
            mutate(&mut rng, &vec![7u8; len], &[vec![], vec![1, 2, 3]]);
        }
    }
}

#[test]
fn every_corpus_folder_is_a_target() {
    let _alone = alone();
    for entry in std::fs::read_dir(corpus_dir("")).unwrap() {
        let name = entry.unwrap().file_name();
        let name = name.to_string_lossy();
        assert!(
            TARGETS.contains(&name.as_ref()),
            "tests/fuzz_corpus/{name} names no target; the targets are {TARGETS:?}"
        );
    }
}
