//! Octolux's dynamic diffuse global illumination for Bevy 0.20: add [`OctoluxGiPlugin`] to the
//! app and [`OctoluxGi`] to a 3D camera.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use octolux_bevy::{OctoluxGi, OctoluxGiPlugin};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, OctoluxGiPlugin))
//!     .add_systems(Startup, |mut commands: Commands| {
//!         commands.spawn((Camera3d::default(), OctoluxGi::new("probes-grid")));
//!     })
//!     .run();
//! ```
//!
//! How it works (docs/bevy.md is the guide):
//! - Every frame the main world's meshes with a `StandardMaterial`, their transforms and the
//!   point, spot and directional lights are mirrored into octolux's scene (`mirror`), in
//!   octolux's radiometric units ([`units`]).
//! - The camera renders with Bevy's deferred G-buffer ([`OctoluxGi`] requires the depth,
//!   normal and deferred prepasses and HDR). After the prepass, octolux's passes read its
//!   depth and normals and compute the indirect irradiance
//!   ([`octolux::embed::GiEngine::record`], into Bevy's command encoder).
//! - After Bevy's deferred lighting, one full-screen pass adds `diffuse / pi * E` (the deferred
//!   G-buffer's base colour x (1 - metallic), its occlusion, the camera's exposure) to the
//!   view's HDR target: Bevy's direct light plus octolux's indirect light, in the same units.
//! - Ambient light is Bevy's stand-in for indirect light: it is turned off on GI cameras
//!   ([`GiAmbient`]) so that it does not count twice.

mod diagnostics;
mod mirror;
mod render;
pub mod units;

pub use diagnostics::GiDiagnostics;
pub use mirror::{GiExclude, GiMotion};
pub use octolux::gi::{GiSettings, TECHNIQUES};
pub use render::GiViews;

use bevy::app::{App, Plugin, PostUpdate};
use bevy::camera::visibility::VisibilitySystems;
use bevy::camera::Hdr;
use bevy::core_pipeline::prepass::{DeferredPrepass, DepthPrepass, NormalPrepass};
use bevy::ecs::prelude::*;
use bevy::light::{AmbientLight, GlobalAmbientLight};
use bevy::pbr::DefaultOpaqueRendererMethod;
use bevy::transform::TransformSystems;
use std::sync::{Arc, Mutex};

/// Octolux's GI for the Bevy app: mirrors the scene, checks the device, records octolux's passes
/// for every camera with [`OctoluxGi`] and adds their indirect light.
///
/// It makes deferred rendering the default for opaque materials
/// ([`DefaultOpaqueRendererMethod`]): the indirect light is composed from the deferred
/// G-buffer's base colour. Materials set to forward rendering get no indirect light.
#[derive(Default)]
pub struct OctoluxGiPlugin;

impl Plugin for OctoluxGiPlugin {
    fn build(&self, app: &mut App) {
        let status = OctoluxGiStatus::default();
        app.insert_resource(DefaultOpaqueRendererMethod::deferred())
            .insert_resource(status.clone())
            .init_resource::<mirror::MirrorState>()
            .init_resource::<mirror::GiScene>()
            .add_systems(
                PostUpdate,
                (
                    mirror::mirror_scene
                        .after(TransformSystems::Propagate)
                        .after(VisibilitySystems::VisibilityPropagate),
                    manage_ambient,
                    diagnostics::publish_timings,
                ),
            );
        render::build(app, status);
    }
}

/// Octolux's indirect light on a 3D camera: the technique and its settings, switchable at run
/// time (the next frame builds the new one).
///
/// It requires HDR and Bevy's depth, normal and deferred prepasses (MSAA is turned off with
/// them: deferred rendering does not take it).
#[derive(Component, Clone, Debug)]
#[require(Hdr, DepthPrepass, NormalPrepass, DeferredPrepass)]
pub struct OctoluxGi {
    /// Whether the indirect light is computed and added. While off, octolux's state is kept
    /// (switching back on is immediate); remove the component to release it.
    pub enabled: bool,
    /// The technique, one of [`TECHNIQUES`] (`none` adds nothing).
    pub technique: String,
    /// Settings of every technique, with octolux's documented defaults.
    pub settings: GiSettings,
    /// Side of octolux's own shadow maps of each light (the techniques light their structures
    /// with them), in texels.
    pub shadow_map_size: u32,
    /// What becomes of Bevy's ambient light on this camera.
    pub ambient: GiAmbient,
}

impl OctoluxGi {
    /// `technique` (one of [`TECHNIQUES`]) with default settings.
    pub fn new(technique: &str) -> OctoluxGi {
        OctoluxGi {
            technique: technique.to_string(),
            ..OctoluxGi::default()
        }
    }

    /// Switches to the technique after the current one in [`TECHNIQUES`] (`none` included).
    pub fn next_technique(&mut self) {
        let i = TECHNIQUES
            .iter()
            .position(|t| *t == self.technique)
            .map_or(0, |i| (i + 1) % TECHNIQUES.len());
        self.technique = TECHNIQUES[i].to_string();
    }
}

impl Default for OctoluxGi {
    /// `probes-grid` (all bounces, converging over frames) with default settings.
    fn default() -> Self {
        OctoluxGi {
            enabled: true,
            technique: "probes-grid".into(),
            settings: GiSettings::default(),
            shadow_map_size: 2048,
            ambient: GiAmbient::Replace,
        }
    }
}

/// What becomes of Bevy's ambient light (the camera's `AmbientLight`, else the
/// `GlobalAmbientLight`) on a camera with octolux's GI.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GiAmbient {
    /// Turned off while the GI runs: ambient light is a constant guess at indirect light,
    /// which octolux computes instead. Restored when the GI is off.
    #[default]
    Replace,
    /// Kept, and given to octolux as a uniform sky of the same radiance: Bevy's ambient term
    /// is then the sky's direct light (unshadowed, as Bevy draws it) and octolux adds the
    /// sky's bounces. Costs octolux's sky shadow maps (one layer per sky direction).
    Sky,
}

/// Whether octolux's GI runs, shared by the main and render worlds: the device check at start,
/// and per camera its technique, its last error and its GPU memory.
#[derive(Resource, Clone, Default)]
pub struct OctoluxGiStatus(Arc<Mutex<StatusInner>>);

#[derive(Default)]
struct StatusInner {
    device: DeviceStatus,
    cameras: std::collections::HashMap<Entity, CameraGiStatus>,
}

/// The device check's outcome.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum DeviceStatus {
    /// The render device has not been checked yet (before the renderer starts).
    #[default]
    Unchecked,
    /// The device runs octolux.
    Ready,
    /// The device cannot run octolux (the reason): the app runs without GI.
    Unavailable(String),
}

/// One camera's GI, as the render world last saw it.
#[derive(Clone, Debug, Default)]
pub struct CameraGiStatus {
    /// The technique running.
    pub technique: String,
    /// Whether the last frame added indirect light.
    pub active: bool,
    /// The last error (building the scene or a frame); the camera renders without GI then.
    pub error: Option<String>,
    /// Octolux's GPU memory for this camera, bytes.
    pub memory_bytes: u64,
    /// The per-pass GPU times of the latest frame whose timestamps came back (empty on devices
    /// without timestamp queries), milliseconds.
    pub timings: Vec<(String, f64)>,
    /// Counts the times new timings arrived.
    pub timings_serial: u64,
}

impl OctoluxGiStatus {
    fn lock(&self) -> std::sync::MutexGuard<'_, StatusInner> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The device check's outcome.
    pub fn device(&self) -> DeviceStatus {
        self.lock().device.clone()
    }

    /// The status of the GI of `camera` (a main-world camera entity with [`OctoluxGi`]).
    pub fn camera(&self, camera: Entity) -> Option<CameraGiStatus> {
        self.lock().cameras.get(&camera).cloned()
    }

    fn set_device(&self, device: DeviceStatus) {
        self.lock().device = device;
    }

    fn update_camera(&self, camera: Entity, f: impl FnOnce(&mut CameraGiStatus)) {
        f(self.lock().cameras.entry(camera).or_default());
    }

    fn retain_cameras(&self, keep: impl Fn(&Entity) -> bool) {
        self.lock().cameras.retain(|e, _| keep(e));
    }
}

/// The camera's own ambient light before the GI turned it off (None: it had none and used the
/// global one).
#[derive(Component)]
struct SavedAmbient(Option<AmbientLight>);

/// Turns Bevy's ambient light off on cameras whose GI replaces it and back on when it stops.
#[allow(clippy::type_complexity)]
fn manage_ambient(
    mut commands: Commands,
    status: Res<OctoluxGiStatus>,
    global: Option<Res<GlobalAmbientLight>>,
    cameras: Query<(
        Entity,
        Option<&OctoluxGi>,
        Option<&AmbientLight>,
        Option<&SavedAmbient>,
    )>,
) {
    let available = !matches!(status.device(), DeviceStatus::Unavailable(_));
    for (entity, gi, ambient, saved) in &cameras {
        let replace =
            gi.is_some_and(|gi| gi.enabled && gi.ambient == GiAmbient::Replace) && available;
        match (replace, saved) {
            (true, None) => {
                let off = AmbientLight {
                    brightness: 0.0,
                    color: ambient
                        .map(|a| a.color)
                        .or(global.as_ref().map(|g| g.color))
                        .unwrap_or(bevy::color::Color::WHITE),
                    affects_lightmapped_meshes: true,
                };
                commands
                    .entity(entity)
                    .insert((SavedAmbient(ambient.cloned()), off));
            }
            (false, Some(saved)) => {
                let mut e = commands.entity(entity);
                e.remove::<SavedAmbient>();
                match &saved.0 {
                    Some(a) => e.insert(a.clone()),
                    None => e.remove::<AmbientLight>(),
                };
            }
            _ => {}
        }
    }
}
