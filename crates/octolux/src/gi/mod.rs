//! Global-illumination techniques, all behind [`GiTechnique`].
//!
//! The boundary (docs/architecture.md, "The GI boundary"): a technique reads the G-buffer, the lights, the shadow maps and
//! the scene geometry, and writes an HDR *indirect irradiance* image (W/m^2, `Rgba16Float`,
//! aligned with the G-buffer). Compose turns it into outgoing radiance as albedo/pi x E.

pub mod bounds;
pub mod lpv;
mod none;
pub mod probes;
mod registry;
pub mod vct;
pub mod vpl;

pub use bounds::Bounds;
pub use lpv::{ClpvSettings, LpvGi, LpvSettings, OlpvSettings};
pub use none::NoGi;
pub use registry::{technique, Family, Technique, DEFAULT_TECHNIQUE, REGISTRY, TECHNIQUES};

use crate::frame::{GiSurfaces, LayerView, SceneGpu, ShadowMaps};
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::{CameraView, Scene, SceneFrame};
use crate::{Error, Result};

/// Everything a technique may read in one frame.
pub struct GiFrame<'a> {
    /// The scene (static data).
    pub scene: &'a Scene,
    /// The scene at this frame's instant: object transforms, lights and camera evaluated at
    /// its time.
    pub instant: &'a SceneFrame,
    /// The camera matrices for the output size.
    pub view: &'a CameraView,
    /// What the techniques read of this frame's G-buffer: depth and world normal.
    pub gbuffer: GiSurfaces<'a>,
    /// The camera uniform (`Camera` in `frame/common.wgsl`).
    pub camera_uniform: &'a wgpu::Buffer,
    /// The scene on the GPU: techniques rasterise it with their own pipelines (RSMs,
    /// voxelisation) through `SceneGpu::draw`; view uniform `1 + i` holds shadow layer `i`.
    pub scene_gpu: &'a SceneGpu,
    /// Shadow maps of this frame (already rendered).
    pub shadows: &'a ShadowMaps,
    /// Per shadow layer: view-projection and texel footprint, in layer order.
    pub shadow_layers: &'a [LayerView],
    /// The lights as `render/direct.wgsl` reads them (`array<Light>`), one per light of
    /// `instant.lights`.
    pub lights: &'a wgpu::Buffer,
    /// How many of `instant.lights`, at its end, are the directional lights that stand in for
    /// the sky ([`crate::frame::sky_lights`]).
    pub sky_lights: usize,
}

/// A GI technique: owns its GPU state, updates it each frame and outputs indirect irradiance.
/// `Send`, so that a [`crate::embed::GiEngine`] can live on a renderer's own thread (Bevy's
/// render world runs beside its main world).
pub trait GiTechnique: Send {
    /// Short name, as on the command line.
    fn name(&self) -> &str;
    /// Records the passes that bring the technique up to date with `frame` and write the
    /// indirect irradiance image. Every pass goes through `timer` under a name.
    fn update(&mut self, ctx: &GpuContext, frame: &GiFrame, timer: &mut PassTimer) -> Result<()>;
    /// The indirect irradiance image (valid after `update`). Techniques that compute ambient
    /// occlusion (the cone tracers) put it in alpha (1 = open, 0 = occluded).
    fn indirect_view(&self) -> &wgpu::TextureView;
    /// An optional image of specular radiance, W/(m^2 sr), along each pixel's mirror
    /// direction (the cone tracers' `specular` setting); None by default.
    fn specular_view(&self) -> Option<&wgpu::TextureView> {
        None
    }
    /// Memory-ledger owners of this technique's resources besides its name (a shared voxel
    /// structure it builds, under the structure's own owner), released with it.
    fn other_ledger_owners(&self) -> &[&'static str] {
        &[]
    }
    /// The light transport this technique claims to compute, so that it is judged against the
    /// matching reference: its bounces (LPV and VPL methods compute one), and how its light
    /// from emissive surfaces is counted.
    fn reference_transport(&self) -> crate::transport::Transport;
    /// The concrete technique, for tests and tools that inspect its state (None by default).
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        None
    }
    /// Frames a still view takes to reach the picture this technique converges to (0 by
    /// default: every frame is computed afresh). `octolux render` runs this many frames
    /// before the one it writes.
    fn settle_frames(&self) -> u32 {
        0
    }
}

/// Settings of every technique, one field per technique family, each with documented defaults.
/// Filled from the command line (`octolux render --gi lpv --lpv-size 32 ...`) and from a scene
/// file's `[settings]` table.
#[derive(Clone, Debug, Default, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GiSettings {
    /// Uniform LPV, and the RSM/injection/lookup settings shared by `clpv` and `olpv`
    /// (`[settings.lpv]`).
    pub lpv: LpvSettings,
    /// Cascaded LPV (`[settings.clpv]`).
    pub clpv: ClpvSettings,
    /// Octree LPV (`[settings.olpv]`).
    pub olpv: OlpvSettings,
    /// Voxel cone tracing (`[settings.vct]`).
    pub vct: vct::VctSettings,
    /// Many-lights VPL GI (`[settings.vpl]`).
    pub vpl: vpl::VplSettings,
    /// Probes and surfels (`[settings.probes]`).
    pub probes: probes::ProbeSettings,
}

impl GiSettings {
    /// Reads settings from a scene file's `[settings]` table; unknown keys are errors.
    pub fn from_table(table: &toml::Table, origin: &std::path::Path) -> Result<GiSettings> {
        toml::Value::Table(table.clone())
            .try_into()
            .map_err(|e: toml::de::Error| {
                Error::parse(origin, format!("[settings]: {}", e.message()))
            })
    }
}

/// Allocates a technique's indirect-irradiance image: `Rgba16Float`, G-buffer sized, written
/// by a compute pass, read by compose and copyable for tests. Recorded under `owner`.
pub(crate) fn indirect_target(
    ctx: &GpuContext,
    owner: &str,
    width: u32,
    height: u32,
) -> (wgpu::Texture, wgpu::TextureView) {
    crate::gpu::alloc::image_target(
        ctx,
        owner,
        "indirect irradiance",
        width,
        height,
        wgpu::TextureFormat::Rgba16Float,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
    )
}

/// Creates the technique called `name` (one of [`TECHNIQUES`]) for images of `width` x
/// `height`.
pub fn create(
    name: &str,
    ctx: &GpuContext,
    scene: &Scene,
    settings: &GiSettings,
    width: u32,
    height: u32,
) -> Result<Box<dyn GiTechnique>> {
    technique(name)?.create(ctx, scene, settings, width, height)
}
