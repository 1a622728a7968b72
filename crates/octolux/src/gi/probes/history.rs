//! What both probe techniques decide on the CPU each frame for their probes' histories
//! (docs/probes.md, "Rays that turn every frame"): what changed since the last frame (objects
//! that moved, lights that changed, how much of last frame's bounced light the lights still
//! make: [`FrameChanges`]) and the frame's rays ([`RayPlan`]: a new surfel set along the
//! lattice turned anew while the light changed in the last `history` frames, else none).

use super::engine::{moved_boxes, ProbeEngine};
use super::lattice::frame_rotation;
use crate::gi::GiFrame;
use crate::scene::{Light, LightKind};
use glam::{Mat3, Mat4, Vec3};

/// Samples the depth maps average over: they see only geometry, which a new sample changes
/// far less than the light, so they stop after these until an object moves (each costs
/// n x 64 kernel terms per probe, the dearest pass of a sample).
pub(crate) const MOMENT_SAMPLES: u32 = 8;

/// What of a light changes what the surfels receive.
type LightState = (LightKind, Vec3, f32, Vec3, Vec3);

/// The power `light` sends into a box of `extent` (luminance-weighted W; for a directional
/// light, its irradiance times the box's area across the light). Last frame's bounces, which
/// the surfels receive with multiple bounces, scale with it.
fn light_power(light: &Light, extent: Vec3) -> f32 {
    use std::f32::consts::PI;
    let luminance = light.color.dot(Vec3::new(0.2126, 0.7152, 0.0722)) * light.intensity.max(0.0);
    match light.kind {
        LightKind::Point => 4.0 * PI * luminance,
        LightKind::Spot {
            inner_angle,
            outer_angle,
        } => 2.0 * PI * (1.0 - (0.5 * (inner_angle + outer_angle)).cos()) * luminance,
        LightKind::Directional => {
            let d = light.direction.abs();
            let e = extent;
            luminance * (d.x * e.y * e.z + d.y * e.x * e.z + d.z * e.x * e.y)
        }
    }
}

/// How much of last frame's bounced light this frame's lights still make: their power over
/// last frame's, at most 1 (exact when every light dims alike or all switch off; where one of
/// several changes, the bounces catch up over the next frames as before).
fn bounce_scale(before: f32, now: f32) -> f32 {
    if before > 0.0 {
        (now / before).min(1.0)
    } else {
        1.0
    }
}

/// What changed in a frame, as [`FrameChanges::observe`] finds it.
pub(crate) struct Changes {
    /// Old and new bounds of the objects that moved since the last frame.
    pub moved: Vec<(Vec3, Vec3)>,
    /// Whether an object moved or a light changed.
    pub changed: bool,
    /// The lights' power now over last frame's, at most 1 ([`bounce_scale`]).
    pub bounce_scale: f32,
}

/// The objects' transforms and the lights of the last frame, to tell what changed.
#[derive(Default)]
pub(crate) struct FrameChanges {
    transforms: Option<Vec<Mat4>>,
    lights: Option<Vec<LightState>>,
    power: Option<f32>,
}

impl FrameChanges {
    /// What changed since the last frame observed; `extent` is the probes' box (for the
    /// power of directional lights).
    pub fn observe(&mut self, frame: &GiFrame, extent: Vec3) -> Changes {
        let now = &frame.instant.object_transforms;
        let moved = match &self.transforms {
            Some(before) => moved_boxes(frame.scene, before, now),
            None => Vec::new(),
        };
        self.transforms = Some(now.clone());
        let lights: Vec<LightState> = frame
            .instant
            .lights
            .iter()
            .map(|l| (l.kind, l.color, l.intensity, l.position, l.direction))
            .collect();
        let changed = !moved.is_empty() || self.lights.as_ref() != Some(&lights);
        self.lights = Some(lights);
        let power: f32 = frame
            .instant
            .lights
            .iter()
            .map(|l| light_power(l, extent))
            .sum();
        let scale = self.power.map_or(1.0, |before| bounce_scale(before, power));
        self.power = Some(power);
        Changes {
            moved,
            changed,
            bounce_scale: scale,
        }
    }
}

/// The rays of each frame for probes with a history: two surfel sets per probe, the newer
/// placed along the lattice turned by a new rotation (CPU-made: identity first, then
/// Shoemake's uniform rotation of a Halton point) while the light changed in the last
/// `history` frames.
#[derive(Default)]
pub(crate) struct RayPlan {
    /// Frames since the lights or an object last changed.
    quiet: u32,
    /// Samples placed so far (the index of the next lattice rotation).
    samples: u32,
    /// The surfel set placed most recently, and each set's rotation.
    pub latest: u32,
    pub rotations: [Mat3; 2],
    /// Whether the last frame placed a new sample.
    pub sampled: bool,
    /// Samples in the depth maps' history since an object last moved.
    pub moment_samples: u32,
}

impl RayPlan {
    /// Plans this frame (`changed`: a light or an object changed; `moved`: an object moved)
    /// and hands the rays to `engine`; nothing without a history.
    pub fn plan(&mut self, engine: &mut ProbeEngine, changed: bool, moved: bool) {
        let history = engine.settings.history;
        if history == 0 {
            return;
        }
        self.quiet = if changed {
            0
        } else {
            self.quiet.saturating_add(1)
        };
        // After a change, every probe's history fills up again before the rays stop.
        self.sampled = self.quiet <= history;
        let mut keep = 0.0;
        if self.sampled {
            self.latest = if self.samples == 0 {
                0
            } else {
                1 - self.latest
            };
            self.rotations[self.latest as usize] = frame_rotation(self.samples);
            self.samples = self.samples.wrapping_add(1);
            self.moment_samples = if moved { 1 } else { self.moment_samples + 1 };
            let kept = (self.moment_samples - 1) as f32;
            // Past MOMENT_SAMPLES the maps keep their value (probes-grid skips the pass then).
            keep = if self.moments_due() {
                kept / (kept + 1.0)
            } else {
                1.0
            };
        }
        engine.set_rays(
            self.sampled.then_some(self.latest),
            self.latest,
            self.rotations,
            keep,
        );
    }

    /// Whether this frame's sample still adds to the depth maps ([`MOMENT_SAMPLES`]).
    pub fn moments_due(&self) -> bool {
        self.moment_samples <= MOMENT_SAMPLES
    }
}
