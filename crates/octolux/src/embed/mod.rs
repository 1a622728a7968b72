//! Dynamic GI inside a caller's wgpu renderer: [`GiEngine`].
//!
//! An engine keeps its device, its G-buffer, its direct lighting and its frame. It gives
//! octolux the scene through code (meshes, materials, instances, lights, sky; changed between
//! frames), and per frame the camera and its G-buffer's depth and normal as texture views.
//! [`GiEngine::record`] records octolux's passes (its shadow maps, the G-buffer input pass,
//! the technique's passes) into the caller's command encoder, and
//! [`GiEngine::indirect_view`] is the indirect irradiance E (W/m^2, `Rgba16Float`, aligned with
//! the caller's G-buffer) to compose as `albedo / pi * E`. docs/embedding.md is the guide.
//!
//! ```no_run
//! # fn frame(device: &wgpu::Device, queue: &wgpu::Queue, depth: &wgpu::TextureView,
//! #          normal: &wgpu::TextureView, mesh: octolux::scene::Mesh) -> octolux::Result<()> {
//! use octolux::embed::*;
//! use octolux::scene::{Light, Material};
//! use glam::{Mat4, Vec3};
//! let mut gi = GiEngine::new(device, queue, GiConfig::new(1280, 720, "probes-grid"))?;
//! let white = gi.add_material(Material::default());
//! let room = gi.add_mesh(mesh, white)?;
//! gi.add_instance(room, Mat4::IDENTITY, Motion::Static)?;
//! gi.add_light(Light::point(Vec3::new(0.0, 1.8, 0.0), Vec3::ONE, 5.0))?;
//! // Every frame, after the engine's G-buffer pass:
//! let mut encoder = device.create_command_encoder(&Default::default());
//! let camera = CameraInput::new(Mat4::IDENTITY, Mat4::perspective_rh(1.0, 16.0 / 9.0, 0.1, 100.0));
//! let gbuffer = GBufferInput::new(depth, DepthConvention::Standard, normal, NormalEncoding::WORLD);
//! gi.record(&mut encoder, &FrameInput { camera, gbuffer, time: 0.0 })?;
//! queue.submit([encoder.finish()]);
//! let indirect = gi.indirect_view(); // sample it in the engine's lighting pass
//! # Ok(()) }
//! ```

mod edit;
mod input;
mod lit;

pub use crate::gpu::requirements::{check_device, required_features, required_limits};
pub use edit::{InstanceId, LightId, MaterialId, MeshId, Motion, TextureId};
pub use input::{
    CameraInput, DepthConvention, GBufferInput, NormalEncoding, NormalPacking, NormalSpace,
};
pub(crate) use lit::LitScene;

use crate::frame::{CameraUniform, GiSurfaces};
use crate::gi::{self, GiFrame, GiSettings, GiTechnique};
use crate::gpu::{GpuContext, MemoryLedger, PassTimer, PassTiming};
use crate::image_io::HdrImage;
use crate::scene::{Camera, CameraView, Scene};
use crate::{Error, Result};
use bytemuck::Zeroable;
use glam::Vec3;

/// What a [`GiEngine`] computes and at which size.
#[derive(Clone, Debug)]
pub struct GiConfig {
    /// Width of the caller's G-buffer and of the indirect irradiance image, in pixels.
    pub width: u32,
    /// Height, in pixels.
    pub height: u32,
    /// The technique ([`crate::gi::TECHNIQUES`]).
    pub technique: String,
    /// Settings of every technique (defaults as documented per technique).
    pub settings: GiSettings,
    /// Side of each of octolux's own shadow-map layers (the techniques read them to light
    /// their structures), in texels.
    pub shadow_map_size: u32,
}

impl GiConfig {
    /// `technique` at `width` x `height` with default settings and 2048-texel shadow maps.
    pub fn new(width: u32, height: u32, technique: &str) -> GiConfig {
        GiConfig {
            width,
            height,
            technique: technique.to_string(),
            settings: GiSettings::default(),
            shadow_map_size: 2048,
        }
    }
}

/// One frame's input from the caller.
#[derive(Clone, Copy, Debug)]
pub struct FrameInput<'a> {
    /// The camera the G-buffer was drawn with.
    pub camera: CameraInput,
    /// The caller's G-buffer (depth and normal) for this frame.
    pub gbuffer: GBufferInput<'a>,
    /// Time in seconds (the scene's keyframed tracks, where it has any, are evaluated at it).
    pub time: f32,
}

/// Octolux's GI for a caller's renderer: the scene (edited through code), octolux's shadow
/// maps of its lights, the selected technique, and the input pass that reads the caller's
/// G-buffer. See the [module docs](self).
pub struct GiEngine {
    ctx: GpuContext,
    scene: Scene,
    ids: edit::Ids,
    config: GiConfig,
    /// The scene on the GPU, its lights and shadow maps; None until the first frame after a
    /// structural change (built then).
    lit: Option<LitScene>,
    technique: Option<Box<dyn GiTechnique>>,
    input: Option<input::InputPass>,
    camera_uniform: wgpu::Buffer,
    /// Exposure scale and output mode for octolux's own compose.
    pub(crate) display: Display,
    timer: PassTimer,
    last_view: Option<CameraView>,
}

impl GiEngine {
    /// An engine on the caller's device with an empty scene; fails with the device's missing
    /// limits and features ([`check_device`]) or on a bad configuration.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, config: GiConfig) -> Result<GiEngine> {
        let ctx = GpuContext::from_device(device, queue)?;
        GiEngine::with_context(&ctx, Scene::default(), config)
    }

    /// An engine on an octolux context holding `scene` (for example one loaded from a file);
    /// the scene can be edited further through the engine.
    /// The scene is validated first ([`crate::scene::validate`]): malformed data is an error
    /// naming what is wrong, never a panic later.
    pub fn with_context(ctx: &GpuContext, mut scene: Scene, config: GiConfig) -> Result<GiEngine> {
        if !scene.objects.is_empty() || !scene.meshes.is_empty() {
            crate::scene::validate(&mut scene)?;
        }
        crate::image_io::check_image_size(config.width, config.height)?;
        let max_dim = ctx.device.limits().max_texture_dimension_2d;
        if config.width > max_dim || config.height > max_dim {
            return Err(Error::InvalidArgument(format!(
                "image size {}x{} exceeds the adapter's limit of {max_dim} per side",
                config.width, config.height
            )));
        }
        if config.shadow_map_size < 16 || config.shadow_map_size > max_dim {
            return Err(Error::InvalidArgument(format!(
                "shadow map size {} must be within 16..={max_dim}",
                config.shadow_map_size
            )));
        }
        check_technique(&config.technique)?;
        let camera_uniform = ctx.create_buffer_init(
            "frame",
            "camera",
            bytemuck::bytes_of(&CameraUniform::zeroed()),
            wgpu::BufferUsages::UNIFORM,
        );
        let ids = edit::Ids::for_scene(&scene);
        Ok(GiEngine {
            ctx: ctx.clone(),
            scene,
            ids,
            config,
            lit: None,
            technique: None,
            input: None,
            camera_uniform,
            display: Display::default(),
            timer: PassTimer::new(ctx),
            last_view: None,
        })
    }

    /// The scene as it stands (with every edit so far).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The configuration in use.
    pub fn config(&self) -> &GiConfig {
        &self.config
    }

    /// The octolux context the engine works on (device, queue, ledger).
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// GPU memory of octolux's resources by owner: the same ledger the bench reports.
    pub fn memory(&self) -> &MemoryLedger {
        &self.ctx.ledger
    }

    /// Replaces the technique and its settings; the next frame builds it. Fails on an unknown
    /// name (the current technique stays).
    pub fn set_technique(&mut self, name: &str, settings: &GiSettings) -> Result<()> {
        check_technique(name)?;
        self.config.technique = name.to_string();
        self.config.settings = settings.clone();
        self.drop_technique()?;
        Ok(())
    }

    /// Changes the G-buffer size; the technique and the input pass are built again at the
    /// next frame.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<()> {
        crate::image_io::check_image_size(width, height)?;
        self.config.width = width;
        self.config.height = height;
        self.input = None;
        self.drop_technique()
    }

    /// The technique in use (None before the first frame after a change).
    pub fn technique(&self) -> Option<&dyn GiTechnique> {
        self.technique.as_deref()
    }

    /// The indirect irradiance of the last frame recorded, W/m^2 in rgb (`Rgba16Float`, the
    /// G-buffer's size; the cone tracers put ambient occlusion in alpha). Compose it as
    /// `albedo / pi * E`. None before the first frame and after a change of technique or size
    /// until the next frame.
    pub fn indirect_view(&self) -> Option<&wgpu::TextureView> {
        self.technique.as_ref().map(|t| t.indirect_view())
    }

    /// The technique's specular radiance image where it has one (the cone tracers with their
    /// `specular` setting).
    pub fn specular_view(&self) -> Option<&wgpu::TextureView> {
        self.technique.as_ref().and_then(|t| t.specular_view())
    }

    /// Reads the indirect irradiance of the last frame back to the CPU (rgb, W/m^2; waits for
    /// the GPU): for tests and tools, not for a frame loop.
    pub fn read_indirect(&self) -> Result<HdrImage> {
        let view = self.indirect_view().ok_or_else(not_prepared)?;
        crate::gpu::read_half_image(&self.ctx, view.texture())
    }

    /// The camera matrices octolux used for the last frame (its own standard-depth projection
    /// of the caller's camera).
    pub fn last_view(&self) -> Option<&CameraView> {
        self.last_view.as_ref()
    }

    /// Per-pass GPU times of the most recent frame whose timestamps have come back (a frame or
    /// two after it was submitted); None while none has, and always on a device without
    /// `TIMESTAMP_QUERY`. Does not block.
    pub fn take_timings(&mut self) -> Result<Option<Vec<PassTiming>>> {
        self.timer.take_timings()
    }

    /// Records one frame of GI into the caller's `encoder`: octolux's shadow maps, the pass
    /// that reads the caller's G-buffer, and the technique's passes. Rebuilds first what an
    /// edit since the last frame invalidated. Afterwards [`GiEngine::indirect_view`] holds the
    /// result once the caller has submitted `encoder`. Errors (a G-buffer of the wrong size or
    /// format, GPU validation errors) leave the encoder's earlier contents alone.
    pub fn record(&mut self, encoder: &mut wgpu::CommandEncoder, input: &FrameInput) -> Result<()> {
        let ctx = self.ctx.clone();
        ctx.capture_errors(|| {
            input.gbuffer.check(self.config.width, self.config.height)?;
            let view = input
                .camera
                .octolux_view(self.config.width, self.config.height)?;
            self.prepare(input.time, view)?;
            if self.input.is_none() {
                self.input = Some(input::InputPass::new(
                    &self.ctx,
                    self.config.width,
                    self.config.height,
                ));
            }
            self.timer.begin_external(encoder);
            let result = self.record_frame(&input.gbuffer, &input.camera);
            self.timer.end_external(encoder);
            result
        })
    }

    /// The passes of [`GiEngine::record`] after `prepare`, into the timer's current encoder.
    fn record_frame(&mut self, gbuffer: &GBufferInput, camera: &CameraInput) -> Result<()> {
        let (Some(lit), Some(input_pass)) = (self.lit.as_mut(), self.input.take()) else {
            return Err(not_prepared());
        };
        let view = self.last_view.as_ref().ok_or_else(not_prepared)?;
        if let Err(e) = lit.render_shadows(&mut self.timer) {
            self.input = Some(input_pass);
            return Err(e);
        }
        input_pass.record(&self.ctx, &mut self.timer, gbuffer, camera, view);
        let result = self.update_gi(input_pass.surfaces());
        self.input = Some(input_pass);
        result
    }

    /// Brings the GPU scene, the technique and this frame's uniforms up to date for time `t`
    /// seen through `view` (what both [`GiEngine::record`] and octolux's own renderer do first).
    pub(crate) fn prepare(&mut self, t: f32, view: CameraView) -> Result<()> {
        if self.lit.is_none() {
            self.rebuild()?;
        }
        if self.technique.is_none() {
            let (w, h) = (self.config.width, self.config.height);
            let technique = gi::create(
                &self.config.technique,
                &self.ctx,
                &self.scene,
                &self.config.settings,
                w,
                h,
            )?;
            self.technique = Some(technique);
        }
        let lit = self.lit.as_mut().ok_or_else(not_prepared)?;
        let frame = self.ids.frame(&self.scene, t, camera_of(&view));
        lit.upload(&self.ctx.queue, &self.scene, frame, &view);
        let (w, h) = (view.width as f32, view.height as f32);
        let camera = CameraUniform {
            view_proj: view.view_proj.to_cols_array_2d(),
            inv_view_proj: view.inv_view_proj.to_cols_array_2d(),
            position: view.position.to_array(),
            _pad: 0,
            size: [w, h],
            inv_size: [1.0 / w, 1.0 / h],
            exposure: self.display.exposure,
            light_count: lit.light_count() as u32,
            time: t,
            output: self.display.output,
        };
        self.ctx
            .queue
            .write_buffer(&self.camera_uniform, 0, bytemuck::bytes_of(&camera));
        self.last_view = Some(view);
        Ok(())
    }

    /// Records the technique's passes for the prepared frame, reading `surfaces`.
    pub(crate) fn update_gi(&mut self, surfaces: GiSurfaces) -> Result<()> {
        let (Some(lit), Some(technique), Some(view)) =
            (&self.lit, &mut self.technique, &self.last_view)
        else {
            return Err(not_prepared());
        };
        let frame = lit.frame().ok_or_else(not_prepared)?;
        let gi_frame = GiFrame {
            scene: &self.scene,
            instant: frame,
            view,
            gbuffer: surfaces,
            camera_uniform: &self.camera_uniform,
            scene_gpu: &lit.scene_gpu,
            shadows: &lit.shadows,
            shadow_layers: lit.layers(),
            lights: &lit.lights,
            sky_lights: lit.sky_lights.len(),
        };
        let name = technique.name().to_string();
        let ctx = &self.ctx;
        self.timer
            .scoped(&name, |timer| technique.update(ctx, &gi_frame, timer))
    }

    /// Builds the GPU scene, lights and shadow maps for the scene as it stands.
    fn rebuild(&mut self) -> Result<()> {
        self.drop_technique()?;
        self.lit = None;
        self.ctx.ledger.release_owner(lit::OWNER);
        if self.scene.triangle_count() == 0 {
            return Err(Error::InvalidArgument(
                "the GI scene has no triangles yet: add a mesh and an instance of it before the \
                 first frame"
                    .into(),
            ));
        }
        self.lit = Some(LitScene::new(
            &self.ctx,
            &self.scene,
            self.config.shadow_map_size,
        )?);
        Ok(())
    }

    /// Drops the technique (after the GPU is done with it) and its ledger entries.
    fn drop_technique(&mut self) -> Result<()> {
        if let Some(old) = self.technique.take() {
            self.ctx.wait_idle()?;
            self.ctx.ledger.release_owner(old.name());
            for owner in old.other_ledger_owners() {
                self.ctx.ledger.release_owner(owner);
            }
        }
        Ok(())
    }

    /// The scene on the GPU with its lights and shadow maps (after [`GiEngine::prepare`]).
    pub(crate) fn lit(&self) -> Option<&LitScene> {
        self.lit.as_ref()
    }

    /// The camera uniform (`Camera` of `frame/common.wgsl`) of the prepared frame.
    pub(crate) fn camera_uniform(&self) -> &wgpu::Buffer {
        &self.camera_uniform
    }

    /// Runs `f` with the timer and the GPU scene of the prepared frame (octolux's renderer
    /// draws its shadow maps, G-buffer and direct light there).
    pub(crate) fn with_lit<R>(
        &mut self,
        f: impl FnOnce(&mut PassTimer, &mut LitScene) -> R,
    ) -> Result<R> {
        let lit = self.lit.as_mut().ok_or_else(not_prepared)?;
        Ok(f(&mut self.timer, lit))
    }

    /// The GPU scene, mutable (octolux's renderer sets its shadow options).
    pub(crate) fn lit_mut(&mut self) -> Option<&mut LitScene> {
        self.lit.as_mut()
    }

    /// The timer every pass of octolux's own renderer goes through.
    pub(crate) fn timer(&mut self) -> &mut PassTimer {
        &mut self.timer
    }

    /// Takes from `scene` (a copy of the engine's scene with the same lights and objects) what
    /// may change between frames without a rebuild: its lights and the placement and
    /// animation of its moving objects. Octolux's renderer is handed its scene every frame.
    pub(crate) fn follow(&mut self, scene: &Scene) {
        let kind = |l: &crate::scene::Light| std::mem::discriminant(&l.kind);
        if scene.lights.len() == self.scene.lights.len()
            && scene
                .lights
                .iter()
                .zip(&self.scene.lights)
                .all(|(a, b)| kind(a) == kind(b))
        {
            self.scene.lights.clone_from(&scene.lights);
        }
        if scene.objects.len() == self.scene.objects.len() {
            for (mine, theirs) in self.scene.objects.iter_mut().zip(&scene.objects) {
                if mine.animation.is_some() && theirs.animation.is_some() {
                    mine.transform = theirs.transform;
                    mine.animation.clone_from(&theirs.animation);
                }
            }
        }
    }

    /// Builds the GPU scene and the technique now instead of at the first frame (octolux's
    /// renderer does, so that construction reports their errors).
    pub(crate) fn build_now(&mut self) -> Result<()> {
        let view =
            Camera::framing(self.scene.bounds_at(0.0)).view(self.config.width, self.config.height);
        self.prepare(0.0, view)
    }
}

/// A camera whose position is the view's (the frame's `camera` field; techniques read the
/// matrices).
fn camera_of(view: &CameraView) -> Camera {
    let forward = view.view.inverse().transform_vector3(Vec3::NEG_Z);
    let mut camera = Camera::framing((Vec3::ZERO, Vec3::ONE));
    camera.position = view.position;
    camera.target = view.position + forward;
    camera
}

/// A clear error for a name that is not one of [`gi::TECHNIQUES`], before anything is built.
fn check_technique(name: &str) -> Result<()> {
    gi::technique(name).map(|_| ())
}

fn not_prepared() -> Error {
    Error::Gpu("internal: the GI frame was not prepared".into())
}

/// How octolux's own compose shows a frame (`Camera.exposure` and `Camera.output` of
/// `frame/common.wgsl`); an embedding renderer composes itself and leaves the defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Display {
    /// Exposure scale 2^ev.
    pub exposure: f32,
    /// [`crate::render::Output`] as a number.
    pub output: u32,
}

impl Default for Display {
    fn default() -> Display {
        Display {
            exposure: 1.0,
            output: 0,
        }
    }
}
