//! Compare mode: the CPU reference path tracer refines in a background thread while the camera
//! rests, and the same thread measures the technique's image against it (FLIP and relMSE, and
//! the FLIP error map), so the window never waits for the CPU work. Moving the camera, the
//! scene time or the size cancels the reference; it starts again once the view has rested.

use glam::Vec3;
use octolux::image_io::HdrImage;
use octolux::metrics::{self, MetricOptions};
use octolux::reference::{self, ReferenceSettings};
use octolux::render::Output;
use octolux::scene::{Scene, SceneFrame};
use octolux::transport::Transport;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long the view must stay still before the reference starts.
const REST: Duration = Duration::from_millis(300);
/// Largest batch of samples per pixel between two updates.
const MAX_BATCH: u32 = 16;
/// A batch stops after the progressive pass during which this much time passed, which bounds
/// how long a cancelled reference keeps the CPU busy.
const BATCH_BUDGET: Duration = Duration::from_millis(250);

/// What the central view shows in compare mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shown {
    /// The technique's image.
    Technique,
    /// The reference as refined so far.
    Reference,
    /// The FLIP error map (magma colours, black = no error).
    ErrorMap,
}

impl Shown {
    /// Every choice, in menu order.
    pub const ALL: [Shown; 3] = [Shown::Technique, Shown::Reference, Shown::ErrorMap];

    /// Menu label.
    pub fn label(self) -> &'static str {
        match self {
            Shown::Technique => "technique",
            Shown::Reference => "reference",
            Shown::ErrorMap => "FLIP error map",
        }
    }
}

/// The image of the technique that the reference judges, with how to display both.
#[derive(Clone)]
pub struct TestImage {
    /// Linear image of the technique (the renderer's HDR output).
    pub image: HdrImage,
    /// Which part of the light it holds (the reference image compared is chosen to match).
    pub output: Output,
    /// Exposure in stops for display and the display-based metrics.
    pub exposure: f32,
}

/// What the worker has to show.
#[derive(Clone, Default)]
pub struct Progress {
    /// Samples per pixel in the reference so far.
    pub spp: u32,
    /// Target samples per pixel.
    pub target: u32,
    /// FLIP and relMSE of the technique against the reference so far.
    pub flip: Option<f64>,
    /// Relative MSE.
    pub rel_mse: Option<f64>,
    /// The reference, tone-mapped RGB8.
    pub reference_rgb: Option<Vec<u8>>,
    /// The FLIP error map, RGB8.
    pub error_rgb: Option<Vec<u8>>,
    /// Size of the images.
    pub size: (u32, u32),
    /// Bumped whenever the images change, so the window uploads them once.
    pub generation: u64,
    /// Why the reference stopped, if it failed.
    pub error: Option<String>,
}

/// What the reference depends on; a change restarts it.
#[derive(Clone, Debug, PartialEq)]
pub struct Key {
    /// Camera position and target.
    pub camera: [Vec3; 2],
    /// Scene time.
    pub time: f32,
    /// Image size.
    pub size: (u32, u32),
    /// Light transport.
    pub transport: Transport,
}

struct Shared {
    progress: Mutex<Progress>,
    test: Mutex<Option<TestImage>>,
    /// Set by the window when a new test image is waiting.
    test_changed: AtomicBool,
    cancel: AtomicBool,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

struct Job {
    key: Key,
    shared: Arc<Shared>,
    handle: JoinHandle<()>,
}

/// The compare mode's state.
pub struct Compare {
    /// Whether compare mode is on.
    pub enabled: bool,
    /// What the central view shows.
    pub shown: Shown,
    /// Samples per pixel to refine to.
    pub target_spp: u32,
    /// Judge against full transport instead of what the technique claims to compute.
    pub unlimited: bool,
    /// The scene the reference traces, copied when the first job starts (the window's scene
    /// never changes its geometry, so one copy serves every job; the camera comes with each
    /// frame).
    scene: Option<Arc<Scene>>,
    job: Option<Job>,
    /// Jobs cancelled but still finishing their last pass; a new one waits for them.
    retiring: Vec<JoinHandle<()>>,
    /// The key seen last frame and since when it has not changed.
    still: Option<(Key, Instant)>,
    shown_generation: u64,
}

impl Compare {
    /// Compare mode, off unless `enabled`.
    pub fn new(enabled: bool, target_spp: u32) -> Compare {
        Compare {
            enabled,
            shown: Shown::Technique,
            target_spp: target_spp.max(1),
            unlimited: false,
            scene: None,
            job: None,
            retiring: Vec::new(),
            still: None,
            shown_generation: 0,
        }
    }

    /// Called every frame with the view's key and the scene. Cancels a reference whose view
    /// changed and starts one when the view has rested. Returns true when a new job started
    /// (the caller then hands it the technique's image with [`Compare::set_test`]).
    pub fn update(&mut self, key: Key, scene: &Scene, frame: impl FnOnce() -> SceneFrame) -> bool {
        self.retiring.retain(|h| !h.is_finished());
        if !self.enabled {
            self.stop();
            self.still = None;
            return false;
        }
        if self.job.as_ref().is_some_and(|j| j.key != key) {
            self.stop();
        }
        let now = Instant::now();
        match &self.still {
            Some((k, _)) if *k == key => {}
            _ => self.still = Some((key.clone(), now)),
        }
        let rested = self
            .still
            .as_ref()
            .is_some_and(|(_, since)| now - *since >= REST);
        if self.job.is_some() || !rested || !self.retiring.is_empty() {
            return false;
        }
        let shared = Arc::new(Shared {
            progress: Mutex::new(Progress {
                target: self.target_spp,
                size: key.size,
                ..Progress::default()
            }),
            test: Mutex::new(None),
            test_changed: AtomicBool::new(false),
            cancel: AtomicBool::new(false),
        });
        let traced = self
            .scene
            .get_or_insert_with(|| Arc::new(scene.clone()))
            .clone();
        let worker = Worker {
            scene: traced,
            frame: frame(),
            key: key.clone(),
            target: self.target_spp,
            shared: shared.clone(),
        };
        let handle = std::thread::spawn(move || worker.run());
        self.job = Some(Job {
            key,
            shared,
            handle,
        });
        true
    }

    /// Cancels the running reference (its thread ends after its current pass).
    pub fn stop(&mut self) {
        if let Some(job) = self.job.take() {
            job.shared.cancel.store(true, Ordering::Relaxed);
            self.retiring.push(job.handle);
        }
    }

    /// Whether a reference exists for the current view (running or finished).
    pub fn active(&self) -> bool {
        self.job.is_some()
    }

    /// Hands the worker the technique's image to judge (again after a technique, setting,
    /// output or exposure change).
    pub fn set_test(&self, test: TestImage) {
        if let Some(job) = &self.job {
            *lock(&job.shared.test) = Some(test);
            job.shared.test_changed.store(true, Ordering::Release);
        }
    }

    /// The worker's progress, and whether its images changed since the last call.
    pub fn progress(&mut self) -> Option<(Progress, bool)> {
        let job = self.job.as_ref()?;
        let progress = lock(&job.shared.progress).clone();
        let fresh = progress.generation != self.shown_generation;
        self.shown_generation = progress.generation;
        Some((progress, fresh))
    }
}

impl Drop for Compare {
    fn drop(&mut self) {
        self.stop();
    }
}

struct Worker {
    scene: Arc<Scene>,
    frame: SceneFrame,
    key: Key,
    target: u32,
    shared: Arc<Shared>,
}

/// Running spp-weighted means of the reference images.
struct Accumulated {
    total: HdrImage,
    direct: HdrImage,
    irradiance: HdrImage,
    spp: u32,
}

impl Accumulated {
    /// Adds a batch; `transport` says which irradiance the technique shows (and the GPU's
    /// direct pass lights with the lights and the sky only, so the emissive surfaces' direct
    /// light, albedo/pi x their irradiance with the pixel's mean albedo, moves out of `direct`).
    fn add(&mut self, images: &reference::ReferenceImages, transport: Transport) {
        let irradiance = images.gi_irradiance(transport.emissive);
        let mut direct = images.direct.clone();
        for ((d, e), a) in direct
            .pixels
            .iter_mut()
            .zip(&images.emitter_irradiance.pixels)
            .zip(&images.albedo.pixels)
        {
            *d -= *a * *e * std::f32::consts::FRAC_1_PI;
        }
        let n = images.spp_done as f32;
        let w = n / (self.spp as f32 + n);
        for (acc, new) in [
            (&mut self.total, &images.total),
            (&mut self.direct, &direct),
            (&mut self.irradiance, &irradiance),
        ] {
            for (a, b) in acc.pixels.iter_mut().zip(&new.pixels) {
                *a += (*b - *a) * w;
            }
        }
        self.spp += images.spp_done;
    }

    /// The reference image matching what `output` shows (the frame for outputs the
    /// reference does not compute: ambient occlusion, specular).
    fn matching(&self, output: Output) -> HdrImage {
        match output {
            Output::Final | Output::AmbientOcclusion | Output::Specular => self.total.clone(),
            Output::Direct => self.direct.clone(),
            Output::IndirectIrradiance => HdrImage {
                pixels: self
                    .irradiance
                    .pixels
                    .iter()
                    .map(|e| *e / std::f32::consts::PI)
                    .collect(),
                ..self.irradiance.clone()
            },
        }
    }
}

impl Worker {
    fn cancelled(&self) -> bool {
        self.shared.cancel.load(Ordering::Relaxed)
    }

    fn run(self) {
        if let Err(e) = self.refine() {
            let mut p = lock(&self.shared.progress);
            p.error = Some(format!("{e:#}"));
            p.generation += 1;
        }
    }

    fn refine(&self) -> anyhow::Result<()> {
        let (w, h) = self.key.size;
        let mut acc = Accumulated {
            total: HdrImage::new(w, h),
            direct: HdrImage::new(w, h),
            irradiance: HdrImage::new(w, h),
            spp: 0,
        };
        let mut batch = 1;
        let mut seed = 1;
        loop {
            if self.cancelled() {
                return Ok(());
            }
            let refining = acc.spp < self.target;
            if refining {
                let settings = ReferenceSettings {
                    spp: batch.min(self.target - acc.spp),
                    time_budget: Some(BATCH_BUDGET),
                    seed,
                    ..ReferenceSettings::default()
                }
                .with_transport(self.key.transport);
                let images =
                    reference::render(&self.scene, &self.frame, w, h, &settings, &|_, _| {})?;
                acc.add(&images, self.key.transport);
                seed += 1;
                batch = (batch * 2).min(MAX_BATCH);
            }
            let changed = self.shared.test_changed.swap(false, Ordering::Acquire);
            if refining || changed {
                let test = lock(&self.shared.test).clone();
                self.publish(&acc, test.as_ref())?;
            } else {
                // Done refining: wait for a new technique image, or to be cancelled.
                std::thread::sleep(Duration::from_millis(50));
            }
        }
    }

    fn publish(&self, acc: &Accumulated, test: Option<&TestImage>) -> anyhow::Result<()> {
        let output = test.map_or(Output::Final, |t| t.output);
        let exposure = test.map_or(0.0, |t| t.exposure);
        let reference = acc.matching(output);
        let reference_rgb = display_rgb8(&reference, exposure);
        let mut measured = None;
        if let Some(test) =
            test.filter(|t| t.image.width == reference.width && t.output.has_reference())
        {
            let options = MetricOptions {
                exposure,
                ..MetricOptions::default()
            };
            let map = metrics::flip_map(&test.image, &reference, &options)?;
            let flip = map.values.iter().map(|&v| v as f64).sum::<f64>() / map.values.len() as f64;
            let rel_mse = metrics::rel_mse(&test.image, &reference, None)?;
            measured = Some((flip, rel_mse, map.to_magma_rgb8(None)));
        }
        let mut p = lock(&self.shared.progress);
        p.spp = acc.spp;
        p.reference_rgb = Some(reference_rgb);
        if let Some((flip, rel_mse, rgb)) = measured {
            p.flip = Some(flip);
            p.rel_mse = Some(rel_mse);
            p.error_rgb = Some(rgb);
        }
        p.generation += 1;
        Ok(())
    }
}

/// Tone-mapped RGB8 of a linear image, as the renderer's display image.
fn display_rgb8(image: &HdrImage, exposure: f32) -> Vec<u8> {
    let scale = exposure.exp2();
    image
        .pixels
        .iter()
        .flat_map(|p| octolux::image_io::tone_map_to_srgb8(*p * scale))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use octolux::scene::cornell;

    fn key(size: (u32, u32)) -> Key {
        Key {
            camera: [Vec3::ZERO, Vec3::Z],
            time: 0.0,
            size,
            transport: Transport::uniform(octolux::transport::Bounces::Indirect(1)),
        }
    }

    #[test]
    fn refines_after_the_view_rests_and_measures_the_test_image() {
        let scene = cornell::scene();
        let frame = scene.frame(0.0, 0);
        let mut compare = Compare::new(true, 4);
        let size = (24, 16);
        // The first call only notes the view; nothing starts before it has rested.
        assert!(!compare.update(key(size), &scene, || frame.clone()));
        assert!(!compare.active());
        std::thread::sleep(REST);
        assert!(compare.update(key(size), &scene, || frame.clone()));
        // Judge a black image: every lit pixel is wrong, so FLIP is well above zero.
        compare.set_test(TestImage {
            image: HdrImage::new(size.0, size.1),
            output: Output::Final,
            exposure: 0.0,
        });
        let deadline = Instant::now() + Duration::from_secs(60);
        let progress = loop {
            let (p, _) = compare.progress().unwrap();
            assert!(p.error.is_none(), "{:?}", p.error);
            if p.spp >= 4 && p.flip.is_some() {
                break p;
            }
            assert!(Instant::now() < deadline, "reference did not finish");
            std::thread::sleep(Duration::from_millis(20));
        };
        assert_eq!(progress.spp, 4);
        assert!(progress.flip.unwrap() > 0.1, "{:?}", progress.flip);
        assert_eq!(
            progress.reference_rgb.as_ref().unwrap().len(),
            (size.0 * size.1 * 3) as usize
        );
        // A new view cancels it.
        assert!(!compare.update(key((8, 8)), &scene, || frame.clone()));
        assert!(!compare.active());
    }
}
