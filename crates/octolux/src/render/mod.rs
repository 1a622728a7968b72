//! The GPU frame: shadow maps -> G-buffer -> direct light -> GI technique -> compose + tone map.
//!
//! [`Renderer`] owns every stage. A frame evaluates the scene at a time, uploads transforms,
//! lights and matrices, records each stage as a named pass (timed by [`crate::gpu::PassTimer`]) and leaves
//! the linear HDR image and the tone-mapped display image ready to read back.

mod compose;
mod direct;

use crate::embed::{GiConfig, GiEngine};
use crate::frame::{GBuffer, ShadowMaps};
use crate::gi::{self, GiTechnique};
use crate::gpu::{read_half_image, read_texture, GpuContext, PassTiming};
use crate::image_io::{check_image_size, HdrImage};
use crate::scene::{CameraView, Scene};
use crate::{Error, Result};
use glam::Vec3;

/// Frame settings.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Output width in pixels.
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// Side of each shadow-map layer in texels.
    pub shadow_map_size: u32,
    /// Which scene camera to use.
    pub camera: usize,
    /// GI technique name (see [`gi::TECHNIQUES`]).
    pub gi: String,
    /// Settings of the GI techniques.
    pub gi_settings: gi::GiSettings,
    /// Soft shadows for the sky's directional lights (percentage-closer soft shadows with
    /// each light's angular size; `lights.wgsl`), else the filter of every directional
    /// light, which sums the sky lights' sharp shadows into steps. On by default: smoother and
    /// closer to the reference's direct light (docs/scene-format.md).
    pub soft_sky_shadows: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 360,
            shadow_map_size: 2048,
            camera: 0,
            gi: "none".into(),
            gi_settings: gi::GiSettings::default(),
            soft_sky_shadows: true,
        }
    }
}

/// What the HDR and display images of a frame hold (the G-buffer, direct light and GI passes
/// run the same whatever is chosen).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Output {
    /// The frame: direct light plus albedo/pi x indirect irradiance.
    #[default]
    Final = 0,
    /// Direct light (and emission) only.
    Direct = 1,
    /// The technique's indirect irradiance E, shown as E/pi: the radiance a white Lambertian
    /// surface would reflect, so it reads on the same exposure as the frame.
    IndirectIrradiance = 2,
    /// The technique's ambient occlusion (the indirect image's alpha: 1 = open, 0 =
    /// occluded), shown without exposure; only the cone-tracing techniques compute one.
    AmbientOcclusion = 3,
    /// The technique's specular image ([`crate::gi::GiTechnique::specular_view`]), black for
    /// techniques without one.
    Specular = 4,
}

impl Output {
    /// Every output, in menu order.
    pub const ALL: [Output; 5] = [
        Output::Final,
        Output::Direct,
        Output::IndirectIrradiance,
        Output::AmbientOcclusion,
        Output::Specular,
    ];

    /// Short name for menus and file names.
    pub fn name(self) -> &'static str {
        match self {
            Output::Final => "final",
            Output::Direct => "direct",
            Output::IndirectIrradiance => "indirect irradiance",
            Output::AmbientOcclusion => "ambient occlusion",
            Output::Specular => "specular",
        }
    }

    /// Whether the reference path tracer computes this output too (the frame, direct light
    /// and indirect irradiance; not ambient occlusion or specular), so the two can be compared.
    pub fn has_reference(self) -> bool {
        matches!(
            self,
            Output::Final | Output::Direct | Output::IndirectIrradiance
        )
    }
}

/// G-buffer contents read back to the CPU (for tests and debugging).
#[derive(Clone, Debug)]
pub struct GBufferImages {
    /// Linear albedo per pixel (zero on background).
    pub albedo: Vec<Vec3>,
    /// World normal per pixel (zero on background).
    pub normal: Vec<Vec3>,
    /// Emission per pixel.
    pub emission: Vec<Vec3>,
    /// Depth-buffer value per pixel (1 on background).
    pub depth: Vec<f32>,
}

/// The GPU renderer for one scene and output size: octolux's own G-buffer, direct light and
/// compose around a [`GiEngine`], the same GI an embedding renderer uses.
pub struct Renderer {
    ctx: GpuContext,
    settings: RenderSettings,
    engine: GiEngine,
    gbuffer: GBuffer,
    direct: direct::DirectLight,
    compose: compose::Compose,
    output: Output,
}

impl Renderer {
    /// Uploads `scene` and builds every stage for images of the configured size.
    pub fn new(ctx: &GpuContext, scene: &Scene, settings: RenderSettings) -> Result<Renderer> {
        check_image_size(settings.width, settings.height)?;
        scene.check_camera(settings.camera)?;
        let (w, h) = (settings.width, settings.height);
        let config = GiConfig {
            width: w,
            height: h,
            technique: settings.gi.clone(),
            settings: settings.gi_settings.clone(),
            shadow_map_size: settings.shadow_map_size,
        };
        let mut engine = GiEngine::with_context(ctx, scene.clone(), config)?;
        engine.build_now()?;
        let lit = engine.lit_mut().ok_or_else(not_built)?;
        lit.soft_sky_shadows = settings.soft_sky_shadows;
        let lit = engine.lit().ok_or_else(not_built)?;
        let gbuffer = GBuffer::new(ctx, &lit.scene_gpu, w, h);
        let direct = direct::DirectLight::new(ctx, engine.camera_uniform(), &gbuffer, lit, w, h);
        let technique = engine.technique().ok_or_else(not_built)?;
        let mut compose = compose::Compose::new(ctx, w, h);
        compose.bind(
            ctx,
            engine.camera_uniform(),
            &direct.output_view,
            &gbuffer,
            technique.indirect_view(),
            technique.specular_view(),
        );
        ctx.check_errors()?;
        Ok(Renderer {
            ctx: ctx.clone(),
            settings,
            engine,
            gbuffer,
            direct,
            compose,
            output: Output::Final,
        })
    }

    /// Replaces the GI technique with `name` built from `gi_settings`, keeping everything else
    /// (scene upload, shadow maps, G-buffer, direct light): what a run-time technique switch or
    /// a settings change needs. On error the current technique stays. The old technique's
    /// entries leave the memory ledger.
    pub fn set_technique(
        &mut self,
        _scene: &Scene,
        name: &str,
        gi_settings: &gi::GiSettings,
    ) -> Result<()> {
        let old = (self.settings.gi.clone(), self.settings.gi_settings.clone());
        self.engine.set_technique(name, gi_settings)?;
        if let Err(e) = self.engine.build_now() {
            // Back to the technique that worked.
            self.engine.set_technique(&old.0, &old.1)?;
            self.engine.build_now()?;
            self.bind_compose()?;
            return Err(e);
        }
        self.settings.gi = name.to_string();
        self.settings.gi_settings = gi_settings.clone();
        self.bind_compose()?;
        self.ctx.check_errors()
    }

    fn bind_compose(&mut self) -> Result<()> {
        let technique = self.engine.technique().ok_or_else(not_built)?;
        self.compose.bind(
            &self.ctx,
            self.engine.camera_uniform(),
            &self.direct.output_view,
            &self.gbuffer,
            technique.indirect_view(),
            technique.specular_view(),
        );
        Ok(())
    }

    /// Chooses what the next frames' images hold (default [`Output::Final`]).
    pub fn set_output(&mut self, output: Output) {
        self.output = output;
    }

    /// What the frames' images hold.
    pub fn output(&self) -> Output {
        self.output
    }

    /// The tone-mapped display image of the last frame on the GPU: `Rgba8Unorm` holding
    /// sRGB-encoded values, usable as a copy source (e.g. into an `Rgba8UnormSrgb` texture that
    /// a window samples).
    pub fn display_texture(&self) -> &wgpu::Texture {
        &self.compose.ldr
    }

    /// The settings in use.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The active GI technique.
    pub fn technique(&self) -> &dyn GiTechnique {
        match self.engine.technique() {
            Some(t) => t,
            // Built in `new` and after every switch; only a failed rebuild leaves none.
            None => unreachable_technique(),
        }
    }

    /// The GI engine the renderer drives (scene, lights, shadow maps, technique).
    pub fn engine(&self) -> &GiEngine {
        &self.engine
    }

    /// The G-buffer (for GI techniques and debugging).
    pub fn gbuffer(&self) -> &GBuffer {
        &self.gbuffer
    }

    /// The shadow maps.
    pub fn shadow_maps(&self) -> &ShadowMaps {
        match self.engine.lit() {
            Some(lit) => &lit.shadows,
            None => unreachable_technique(),
        }
    }

    /// Renders `scene` (the one given to [`Renderer::new`], whose lights and moving objects may
    /// have changed since) at time `t` seconds, waits for the GPU, and returns the per-pass
    /// times of this frame.
    pub fn render(&mut self, scene: &Scene, t: f32) -> Result<Vec<PassTiming>> {
        self.record(scene, t)?;
        self.engine.timer().finish_frame()
    }

    /// Like [`Renderer::render`] but without waiting for the GPU (for real-time loops): returns
    /// the pass times of the most recent earlier frame whose GPU timestamps have come back, or
    /// None while none has. Reading an image back still waits for its frame.
    pub fn render_pipelined(&mut self, scene: &Scene, t: f32) -> Result<Option<Vec<PassTiming>>> {
        self.record(scene, t)?;
        self.engine.timer().finish_frame_pipelined()
    }

    /// Records every pass of one frame into the engine's timer: shadow maps, G-buffer, direct
    /// light, the technique, compose.
    fn record(&mut self, scene: &Scene, t: f32) -> Result<()> {
        let (w, h) = (self.settings.width, self.settings.height);
        let view = scene.camera_at(t, self.settings.camera).view(w, h);
        self.engine.display = crate::embed::Display {
            exposure: scene.exposure.exp2(),
            output: self.output as u32,
        };
        self.engine.follow(scene);
        self.engine.prepare(t, view)?;
        let (gbuffer, direct) = (&self.gbuffer, &self.direct);
        self.engine.with_lit(|timer, lit| -> Result<()> {
            lit.render_shadows(timer)?;
            gbuffer.render(timer, &lit.scene_gpu)?;
            direct.render(timer, w, h);
            Ok(())
        })??;
        self.engine.update_gi(self.gbuffer.surfaces())?;
        self.compose.render(self.engine.timer(), w, h);
        Ok(())
    }

    /// The camera matrices of the last frame rendered.
    pub fn last_view(&self) -> Option<&CameraView> {
        self.engine.last_view()
    }

    /// Reads the linear HDR output of the last frame.
    pub fn read_hdr(&self) -> Result<HdrImage> {
        let bytes = read_texture(&self.ctx, &self.compose.hdr, 0)?;
        let floats: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        Ok(HdrImage {
            width: self.settings.width,
            height: self.settings.height,
            pixels: floats
                .chunks_exact(4)
                .map(|p| Vec3::new(p[0], p[1], p[2]))
                .collect(),
        })
    }

    /// Reads the tone-mapped sRGB display image of the last frame as RGB8.
    pub fn read_display(&self) -> Result<Vec<u8>> {
        let bytes = read_texture(&self.ctx, &self.compose.ldr, 0)?;
        Ok(bytes
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect())
    }

    /// Reads the direct-light radiance of the last frame.
    pub fn read_direct(&self) -> Result<HdrImage> {
        read_half_image(&self.ctx, &self.direct.output)
    }

    /// Reads the G-buffer of the last frame.
    pub fn read_gbuffer(&self) -> Result<GBufferImages> {
        let depth_bytes = read_texture(&self.ctx, &self.gbuffer.depth, 0)?;
        Ok(GBufferImages {
            albedo: read_half_image(&self.ctx, &self.gbuffer.albedo)?.pixels,
            normal: read_half_image(&self.ctx, &self.gbuffer.normal)?.pixels,
            emission: read_half_image(&self.ctx, &self.gbuffer.emission)?.pixels,
            depth: depth_bytes
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect(),
        })
    }
}

fn not_built() -> Error {
    Error::Gpu("internal: the GI engine has no technique or GPU scene".into())
}

fn unreachable_technique() -> ! {
    unreachable!("the renderer builds its technique and GPU scene in new and on every switch")
}
