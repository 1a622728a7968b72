//! The passes every probe technique shares (docs/probes.md): surfel placement through the
//! scene's BVH or voxels ([`super::rays`]), surfel light, probe integration and the pixel
//! gather, over a *probe set* that says where the probes are, which are live, which to
//! (re)place and how a point reads them:
//! the uniform grid (grid.wgsl, grid_sample.wgsl) or the octree (octree_set.wgsl,
//! octree_sample.wgsl, with its buffers in bind group 1). Each pass is a WGSL module that
//! imports the set as `gi/probes/set` (and `set_sample`) and the ray structure as
//! `gi/probes/rays`; the technique says which modules those are ([`ProbeSetModules`]).

use super::moments::{variance_floor, Visibility, MOMENT_BYTES};
use super::params::{probe_storage, rotation_rows, ProbeParams};
use super::rays::Rays;
use super::ProbeSettings;
use crate::frame::light_bindings;
use crate::gi::GiFrame;
use crate::gpu::pass::{dispatch_size, KeptBindGroup};
use crate::gpu::shader::{library_shader_with, module_source};
use crate::gpu::work::WorkRegion;
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::Scene;
use crate::{Error, Result};
use glam::{Mat4, UVec3, Vec3};

/// `vec4`s per probe in the probe buffer (`PROBE_VEC4` in probes.wgsl): the encoding's 8
/// coefficients, then the probe's state.
pub const PROBE_VEC4: u64 = 9;
/// `vec4`s per surfel in the surfel buffer ([`GpuSurfel`], `SURFEL_VEC4` in probes.wgsl).
pub const SURFEL_VEC4: u64 = (std::mem::size_of::<GpuSurfel>() / 16) as u64;

/// One surfel as the probe passes store it (`Surfel` in probes.wgsl): where a probe's ray hit.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuSurfel {
    /// Hit point.
    pub position: [f32; 3],
    /// 0 miss, 1 front face, 2 back face (a float, as the CPU twins read it).
    pub state: f32,
    /// Unit normal, towards the probe.
    pub normal: [f32; 3],
    /// Linear albedo x 255 as RGBA8.
    pub albedo: u32,
    /// Emitted radiance, W/(m^2 sr).
    pub emission: [f32; 3],
    /// Hit distance; negative: the hit lies beyond the probe's cube.
    pub distance: f32,
}

/// A probe set's WGSL modules: the one every pass imports as `gi/probes/set` (positions,
/// liveness, placement), the one the passes that read probes import as
/// `gi/probes/set_sample` (`probes_irradiance`), and the bindings of the tree its functions
/// read (`gi/probes/tree_bindings`; the octree's).
pub(crate) struct ProbeSetModules {
    pub set: &'static str,
    pub sample: &'static str,
    pub tree: Option<&'static str>,
    /// What the set's `count_sample_work` counts (`probes_irradiance`'s work).
    pub sample_work: &'static [&'static str],
}

/// What `probes-grid`'s lookups count (`count_sample_work` in grid_sample.wgsl).
pub(crate) const GRID_SAMPLE_WORK: &[&str] = &["probes read"];
/// What `probes-octree`'s lookups count (`count_sample_work` in octree_sample.wgsl).
pub(crate) const OCTREE_SAMPLE_WORK: &[&str] = &["probes read", "octree lookups", "octree nodes"];
/// What the placement counts before its rays' work (place.wgsl; then [`Rays::work`]).
const PLACE_WORK: &[&str] = &["probes", "rays"];
/// What the depth moments count (moments_build.wgsl).
const MOMENTS_WORK: &[&str] = &["texels", "kernel terms"];
/// What the surfel light counts before its probe lookups' (light.wgsl).
const LIGHT_WORK: &[&str] = &["surfels", "shadow lookups"];
/// What the integration counts (integrate.wgsl).
const INTEGRATE_WORK: &[&str] = &["probes", "surfels"];
/// What the gather counts before its lookups' (gather.wgsl).
const GATHER_WORK: &[&str] = &["pixels"];

/// The work regions of the five shared passes, where `ctx` counts work: place, moments,
/// light, integrate and gather, named `<owner> <pass>` as the timer names them.
fn work_regions(
    ctx: &GpuContext,
    owner: &str,
    rays: &Rays,
    set: &ProbeSetModules,
) -> Result<[Option<WorkRegion>; 5]> {
    let Some(work) = ctx.work() else {
        return Ok([None; 5]);
    };
    let passes: [(&str, Vec<&'static str>); 5] = [
        ("place", [PLACE_WORK, rays.work()].concat()),
        ("moments", MOMENTS_WORK.to_vec()),
        ("light", [LIGHT_WORK, set.sample_work].concat()),
        ("integrate", INTEGRATE_WORK.to_vec()),
        ("gather", [GATHER_WORK, set.sample_work].concat()),
    ];
    let mut out = [None; 5];
    for (slot, (pass, quantities)) in out.iter_mut().zip(passes) {
        *slot = Some(work.region(&format!("{owner} {pass}"), &quantities)?);
    }
    Ok(out)
}

/// The bind group entry of `region` where `ctx` counts work.
fn work_entry(
    ctx: &GpuContext,
    region: Option<WorkRegion>,
) -> Option<(u32, wgpu::BindingResource<'_>)> {
    ctx.work().zip(region).map(|(work, r)| work.entry(r))
}

/// The source of the library module `path` (one of [`crate::gpu::shader::MODULES`]).
pub(crate) fn module(path: &str) -> &'static str {
    module_source(path).unwrap_or_else(|| panic!("internal shader error: no module {path}"))
}

/// Where the probes sit, as the shared parameters hold it.
pub(crate) struct ProbeLayout {
    /// The grid's lower corner (the octree's: its root cube's).
    pub lo: Vec3,
    /// The grid's probe spacing (zero for the octree).
    pub spacing: Vec3,
    /// The grid's probes per axis (zero for the octree).
    pub dims: UVec3,
    /// Gather offset along the normal, in metres.
    pub bias: f32,
    /// The smallest probe spacing (the octree's finest cube edge), in metres.
    pub cell: f32,
    /// Probe slots.
    pub probes: u32,
}

pub(crate) fn buf(b: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
    b.as_entire_binding()
}

/// Records the named pass `name`: `pipeline` with `groups` (group i = `groups[i]`) over
/// `groups_xy` workgroups.
pub(crate) fn run_pass(
    timer: &mut PassTimer,
    name: &str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
    groups_xy: (u32, u32),
) {
    run_dispatch(timer, name, pipeline, groups, Dispatch::Groups(groups_xy));
}

/// How many workgroups a pass over the probe set launches.
#[derive(Clone, Copy)]
pub(crate) enum Dispatch<'a> {
    /// This many (x, y), known on the CPU.
    Groups((u32, u32)),
    /// Read from an indirect-dispatch buffer at this byte offset, written on the GPU (the
    /// octree's live probes, `GpuProbeOctree::live_args`).
    Indirect(&'a wgpu::Buffer, u64),
}

fn run_dispatch(
    timer: &mut PassTimer,
    name: &str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
    dispatch: Dispatch,
) {
    timer.pass(name, |encoder, stamps| {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(name),
            timestamp_writes: stamps.compute(),
        });
        pass.set_pipeline(pipeline);
        for (i, g) in groups.iter().enumerate() {
            pass.set_bind_group(i as u32, *g, &[]);
        }
        match dispatch {
            Dispatch::Groups((x, y)) => pass.dispatch_workgroups(x, y, 1),
            Dispatch::Indirect(args, offset) => pass.dispatch_workgroups_indirect(args, offset),
        }
    });
}

/// Slots of a listed set's indirect-dispatch arguments (`GpuProbeOctree::live_args`, written by
/// `set_args` in `octree.wgsl` under the same names): place and light run over the live
/// probes' surfels, the moments over their maps' lanes (`MOMENT_LANES` each), the integration
/// over the probes.
pub(crate) const LIVE_SURFELS: u32 = 0;
/// See [`LIVE_SURFELS`].
pub(crate) const LIVE_MOMENT_LANES: u32 = 1;
/// See [`LIVE_SURFELS`].
pub(crate) const LIVE_PROBES: u32 = 2;

/// Invocations per probe of the integration, which sum its surfels side by side
/// (`INTEGRATE_LANES` in `octree_params.wgsl`, which `integrate.wgsl` and the octree's
/// dispatch arguments read).
const INTEGRATE_LANES: u32 = 8;
/// Slots of [`LIVE_SURFELS`]...
pub(crate) const LIVE_SLOTS: u32 = 3;

/// A probe set's bind group 1 for a shared pass and, where the set lists its probes on the
/// GPU, the indirect-dispatch buffer (`GpuProbeOctree::live_args`, slots [`LIVE_SURFELS`]...).
/// `None`: the pass runs over every probe slot.
#[derive(Clone, Copy)]
pub(crate) struct SetPass<'a> {
    pub group: &'a wgpu::BindGroup,
    pub listed: Option<&'a wgpu::Buffer>,
}

/// The dispatch of a pass over the set: listed (slot `slot` of the set's arguments) or `all`
/// workgroups.
fn set_dispatch<'a>(set: Option<SetPass<'a>>, slot: u32, all: (u32, u32)) -> Dispatch<'a> {
    match set.and_then(|s| s.listed) {
        Some(args) => Dispatch::Indirect(args, crate::gpu::pass::indirect_offset(slot)),
        None => Dispatch::Groups(all),
    }
}

/// The shared state and pipelines of a probe technique.
pub(crate) struct ProbeEngine {
    owner: &'static str,
    pub settings: ProbeSettings,
    params: ProbeParams,
    pub params_buffer: wgpu::Buffer,
    rays: Rays,
    /// Whether any object moves: then the ray structure follows the animated objects every
    /// frame.
    pub animated: bool,
    /// The boxes of the objects that moved since the surfels were placed (two per animated
    /// object at most: old and new bounds), for a placement that keeps the other surfels.
    moved: wgpu::Buffer,
    /// Per probe, the last frame that traced any of its rays (`P.frame`).
    stamps: wgpu::Buffer,
    surfels: wgpu::Buffer,
    radiance: wgpu::Buffer,
    probes: wgpu::Buffer,
    /// With a history: per probe the coefficients of the set placed most recently as last
    /// integrated (integrate.wgsl); else a placeholder.
    raw: wgpu::Buffer,
    moments: wgpu::Buffer,
    pub place: wgpu::ComputePipeline,
    pub moments_build: wgpu::ComputePipeline,
    pub light: wgpu::ComputePipeline,
    pub integrate: wgpu::ComputePipeline,
    pub gather: wgpu::ComputePipeline,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    size: (u32, u32),
    /// The bind groups of place, moments, light, integrate and gather, kept while their
    /// resources are.
    groups: [KeptBindGroup; 5],
    /// Their work regions, where the context counts work.
    work: [Option<WorkRegion>; 5],
}

impl ProbeEngine {
    /// The passes for `scene` at `width` x `height` over the probe set `set` laid out as
    /// `layout`; buffers are recorded under `owner`.
    pub fn new(
        ctx: &GpuContext,
        owner: &'static str,
        settings: &ProbeSettings,
        scene: &crate::scene::Scene,
        (width, height): (u32, u32),
        layout: &ProbeLayout,
        set: &ProbeSetModules,
    ) -> Result<ProbeEngine> {
        let bounds = scene.gi_bounds_at(0.0);
        let animated_objects = scene
            .objects
            .iter()
            .filter(|o| o.animation.is_some())
            .count();
        let animated = animated_objects > 0;
        let probes = layout.probes;
        let sets = settings.surfel_sets();
        let surfels = probes as u64 * settings.surfel_count() as u64 * sets as u64;
        if surfels > u32::MAX as u64 / SURFEL_VEC4 as u32 as u64 {
            return Err(Error::InvalidArgument(format!(
                "{owner}: {surfels} surfels are too many"
            )));
        }
        let (lo, hi) = bounds;
        let mut params = ProbeParams {
            lo: layout.lo.to_array(),
            max_distance: (hi - lo).length() * 1.01,
            spacing: layout.spacing.to_array(),
            normal_offset: layout.bias,
            dims: layout.dims.to_array(),
            surfels_per_set: settings.surfel_count(),
            lattice: settings.lattice.gpu_kind(),
            encoding: settings.encoding.gpu_kind(),
            light_count: 0,
            multi_bounce: settings.bounces_over_frames() as u32,
            // The BVH roots are set by `Rays::new`.
            static_root: 0,
            instance_count: 0,
            probe_slots: probes,
            surfel_count: surfels as u32,
            max_back_faces: settings.max_back_faces(),
            visibility: settings.visibility.gpu_kind(),
            moved_boxes: 0,
            keep_unmoved: 0,
            variance_floor: variance_floor(layout.cell),
            moments_keep: 0.0,
            bounce_scale: 1.0,
            forgetting: 1.0,
            frame: 0,
            set_count: sets,
            latest_set: 0,
            latest_placed: 0,
            max_history: settings.history,
            _pad: [0; 3],
            rot: rotation_rows([glam::Mat3::IDENTITY; 2]),
        };
        let rays = Rays::new(
            ctx,
            owner,
            settings.rays,
            settings.voxel_resolution,
            scene,
            &mut params,
        )?;
        let params_buffer = probe_storage(
            ctx,
            owner,
            "params",
            std::mem::size_of::<ProbeParams>() as u64,
        )?;
        // Each pass over this set and ray structure.
        let mut modules = vec![
            ("gi/probes/set", module(set.set)),
            ("gi/probes/set_sample", module(set.sample)),
            ("gi/probes/rays", module(rays.place_module())),
        ];
        modules.extend(set.tree.map(|t| ("gi/probes/tree_bindings", module(t))));
        let pipeline = |name: &str, pass: &str| {
            let source = library_shader_with(pass, &[ctx.work_feature()], &modules);
            let module = ctx.shader(name, &source);
            ctx.compute_pipeline(name, &module, "main")
        };
        let (texture, view) = crate::gi::indirect_target(ctx, owner, width, height);
        let work = work_regions(ctx, owner, &rays, set)?;
        Ok(ProbeEngine {
            owner,
            settings: settings.clone(),
            params,
            params_buffer,
            animated,
            surfels: probe_storage(ctx, owner, "surfels", surfels * SURFEL_VEC4 * 16)?,
            radiance: probe_storage(ctx, owner, "surfel radiance", surfels * 16)?,
            probes: probe_storage(ctx, owner, "probes", probes as u64 * PROBE_VEC4 * 16)?,
            raw: probe_storage(
                ctx,
                owner,
                "probe samples",
                if sets > 1 { probes as u64 * 8 * 16 } else { 16 },
            )?,
            // Without visibility the gather never reads the maps: a placeholder binding.
            moments: probe_storage(
                ctx,
                owner,
                "probe depth moments",
                match settings.visibility {
                    Visibility::Moments => probes as u64 * MOMENT_BYTES,
                    Visibility::None => 16,
                },
            )?,
            rays,
            moved: probe_storage(ctx, owner, "moved boxes", animated_objects as u64 * 2 * 32)?,
            stamps: probe_storage(ctx, owner, "probe stamps", probes as u64 * 4)?,
            place: pipeline("place", "gi/probes/place"),
            moments_build: pipeline("moments", "gi/probes/moments_build"),
            light: pipeline("light", "gi/probes/light"),
            integrate: pipeline("integrate", "gi/probes/integrate"),
            gather: pipeline("gather", "gi/probes/gather"),
            texture,
            view,
            size: (width, height),
            groups: Default::default(),
            work,
        })
    }

    /// The indirect irradiance image.
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    /// The indirect irradiance image's view.
    pub fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// The probe buffer (per probe 8 coefficients, then back-face share, hit share, valid).
    pub fn probe_buffer(&self) -> &wgpu::Buffer {
        &self.probes
    }

    /// The probes' depth moment maps (`MOMENT_TEXELS` texels of (mean, mean square) each;
    /// 16 bytes when the visibility is off).
    pub fn moment_buffer(&self) -> &wgpu::Buffer {
        &self.moments
    }

    /// The surfel buffer and the surfels' outgoing radiance.
    pub fn surfel_buffers(&self) -> (&wgpu::Buffer, &wgpu::Buffer) {
        (&self.surfels, &self.radiance)
    }

    /// Per probe, the 8 coefficients of the latest surfel set as last integrated (16 bytes
    /// without a history).
    pub fn sample_buffer(&self) -> &wgpu::Buffer {
        &self.raw
    }

    /// Brings the rays and lights up to date with `frame`: the animated objects in the ray
    /// structure (their transforms in the two-level BVH, or the octree's dynamic part rebuilt
    /// by passes recorded into `timer`) and the light count.
    pub fn begin_frame(
        &mut self,
        ctx: &GpuContext,
        frame: &GiFrame,
        timer: &mut PassTimer,
    ) -> Result<()> {
        if self.animated {
            self.rays.sync_moving(ctx, frame, timer, &mut self.params)?;
        }
        self.params.light_count = frame.instant.lights.len() as u32;
        self.params.frame = self.params.frame.wrapping_add(1).max(1);
        ctx.queue
            .write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&self.params));
        Ok(())
    }

    /// What the next placement re-traces: every surfel of the probes the set asks for
    /// (`None`), or only those whose rays cross one of `boxes` (the old and new bounds of the
    /// objects that moved since the surfels were placed; the others keep their hits, which
    /// nothing that moved can have changed). At most two boxes per animated object. Call it
    /// before [`ProbeEngine::begin_frame`], which uploads the parameters.
    pub fn set_moved(&mut self, ctx: &GpuContext, boxes: Option<&[(Vec3, Vec3)]>) -> Result<()> {
        let selective = boxes.is_some();
        let boxes = boxes.unwrap_or(&[]);
        let margin = self.rays.hit_margin();
        let words: Vec<[f32; 4]> = boxes
            .iter()
            .flat_map(|&(lo, hi)| {
                // Padded: a hit on a face of the box must count as inside on every adapter,
                // and a voxel hit may lie beyond the triangles' bounds.
                let pad = (hi - lo).length() * 1e-3 + 1e-5 + margin;
                [
                    (lo - pad).extend(0.0).to_array(),
                    (hi + pad).extend(0.0).to_array(),
                ]
            })
            .collect();
        let bytes: &[u8] = bytemuck::cast_slice(&words);
        if bytes.len() as u64 > self.moved.size() {
            return Err(Error::InvalidArgument(format!(
                "{}: {} moved boxes, more than two per animated object",
                self.owner,
                boxes.len()
            )));
        }
        ctx.queue.write_buffer(&self.moved, 0, bytes);
        self.params.moved_boxes = boxes.len() as u32;
        self.params.keep_unmoved = u32::from(selective);
        Ok(())
    }

    /// This frame's rays, for a probe set with a history (two surfel sets; call before
    /// [`ProbeEngine::begin_frame`]): `sample` places set `set` anew along its lattice turned
    /// by `rotations[set]` (a new sample for every probe) or, `None`, keeps both sets and
    /// relights the latest; `moments_keep` is the weight of the depth maps' history in this
    /// frame's blend (0: made afresh).
    pub fn set_rays(
        &mut self,
        sample: Option<u32>,
        latest: u32,
        rotations: [glam::Mat3; 2],
        moments_keep: f32,
    ) {
        self.params.latest_set = sample.unwrap_or(latest);
        self.params.latest_placed = u32::from(sample.is_some());
        self.params.rot = rotation_rows(rotations);
        self.params.moments_keep = moments_keep;
    }

    fn surfel_groups(&self) -> (u32, u32) {
        dispatch_size(self.params.surfel_count)
    }

    /// Surfels: rays from the probes the set asks for along their lattices.
    pub fn place(&self, ctx: &GpuContext, timer: &mut PassTimer, set: Option<SetPass>) {
        let mut entries = vec![
            (0, buf(&self.params_buffer)),
            (1, buf(&self.surfels)),
            (7, buf(&self.moved)),
            (8, buf(&self.stamps)),
        ];
        entries.extend(self.rays.place_bindings());
        entries.extend(work_entry(ctx, self.work[0]));
        let group = self.groups[0].get(ctx, "place", &self.place, &entries);
        let groups: Vec<&wgpu::BindGroup> = std::iter::once(&group)
            .chain(set.map(|s| s.group))
            .collect();
        let dispatch = set_dispatch(set, LIVE_SURFELS, self.surfel_groups());
        run_dispatch(timer, "place", &self.place, &groups, dispatch);
    }

    /// Depth moments of the probes just placed (nothing without visibility).
    pub fn build_moments(&self, ctx: &GpuContext, timer: &mut PassTimer, set: Option<SetPass>) {
        if self.settings.visibility == Visibility::None {
            return;
        }
        let mut entries = vec![
            (0, buf(&self.params_buffer)),
            (1, buf(&self.surfels)),
            (2, buf(&self.moments)),
            (3, buf(&self.stamps)),
        ];
        entries.extend(work_entry(ctx, self.work[1]));
        let group = self.groups[1].get(ctx, "moments", &self.moments_build, &entries);
        let groups: Vec<&wgpu::BindGroup> = std::iter::once(&group)
            .chain(set.map(|s| s.group))
            .collect();
        let size = dispatch_size(self.params.probe_slots * super::moments::MOMENT_LANES);
        let dispatch = set_dispatch(set, LIVE_MOMENT_LANES, size);
        run_dispatch(timer, "moments", &self.moments_build, &groups, dispatch);
    }

    /// The scale of last frame's probe light in this frame's surfel light (call before
    /// [`ProbeEngine::begin_frame`]).
    pub fn set_bounce_scale(&mut self, scale: f32) {
        self.params.bounce_scale = scale;
    }

    /// How strongly the probes' histories forget in proportion to their change this frame.
    pub fn set_forgetting(&mut self, strength: f32) {
        self.params.forgetting = strength;
    }

    /// Surfel light: direct light with shadow-map visibility (+ last frame's probes).
    pub fn light(
        &self,
        ctx: &GpuContext,
        frame: &GiFrame,
        timer: &mut PassTimer,
        set: Option<SetPass>,
    ) -> Result<()> {
        let mut entries = vec![
            (0, buf(&self.params_buffer)),
            (1, buf(&self.surfels)),
            (2, buf(&self.radiance)),
            (3, buf(&self.probes)),
            (8, buf(&self.moments)),
        ];
        entries.extend(light_bindings(frame.lights, frame.shadows.lookup()));
        entries.extend(work_entry(ctx, self.work[2]));
        let group = self.groups[2].get(ctx, "light", &self.light, &entries);
        let groups: Vec<&wgpu::BindGroup> = std::iter::once(&group)
            .chain(set.map(|s| s.group))
            .collect();
        let dispatch = set_dispatch(set, LIVE_SURFELS, self.surfel_groups());
        run_dispatch(timer, "light", &self.light, &groups, dispatch);
        Ok(())
    }

    /// Probes: each integrates its surfels into its encoding.
    pub fn integrate(&self, ctx: &GpuContext, timer: &mut PassTimer, set: Option<SetPass>) {
        let mut entries = vec![
            (0, buf(&self.params_buffer)),
            (1, buf(&self.surfels)),
            (2, buf(&self.radiance)),
            (3, buf(&self.probes)),
            (4, buf(&self.raw)),
        ];
        entries.extend(work_entry(ctx, self.work[3]));
        let group = self.groups[3].get(ctx, "integrate", &self.integrate, &entries);
        let groups: Vec<&wgpu::BindGroup> = std::iter::once(&group)
            .chain(set.map(|s| s.group))
            .collect();
        let lanes = self.params.probe_slots * INTEGRATE_LANES;
        let dispatch = set_dispatch(set, LIVE_PROBES, dispatch_size(lanes));
        run_dispatch(timer, "integrate", &self.integrate, &groups, dispatch);
    }

    /// Pixels: the probe set's irradiance at each.
    pub fn gather(
        &self,
        ctx: &GpuContext,
        frame: &GiFrame,
        timer: &mut PassTimer,
        set: Option<&wgpu::BindGroup>,
    ) {
        let tex = wgpu::BindingResource::TextureView;
        let mut entries = vec![
            (0, buf(&self.params_buffer)),
            (1, buf(frame.camera_uniform)),
            (2, tex(frame.gbuffer.depth_view)),
            (3, buf(&self.probes)),
            (4, tex(frame.gbuffer.normal_view)),
            (5, tex(&self.view)),
            (8, buf(&self.moments)),
        ];
        entries.extend(work_entry(ctx, self.work[4]));
        let group = self.groups[4].get(ctx, "gather", &self.gather, &entries);
        let groups: Vec<&wgpu::BindGroup> = std::iter::once(&group).chain(set).collect();
        let (w, h) = self.size;
        run_pass(
            timer,
            "gather",
            &self.gather,
            &groups,
            (w.div_ceil(8), h.div_ceil(8)),
        );
    }

    /// The ledger owners of what the passes use but do not own: the voxel rays' octree.
    pub fn other_ledger_owners(&self) -> &'static [&'static str] {
        match self.rays.svo() {
            Some(_) => &[crate::voxel::svo::OWNER],
            None => &[],
        }
    }

    /// The light transport the passes compute.
    pub fn reference_transport(&self) -> crate::transport::Transport {
        // Surfels store emission with the reflected direct light, so emissive surfaces light
        // the scene through the probes, one bounce behind the lights.
        crate::transport::Transport {
            bounces: if self.settings.bounces_over_frames() {
                crate::transport::Bounces::Unlimited
            } else {
                crate::transport::Bounces::Indirect(1)
            },
            emissive: crate::transport::EmissiveSurfaces::OneBounceFewer,
        }
    }
}

/// CPU twin of `probe_facing_weight` (probes.wgsl): DDGI's smooth back-face weight
/// ((1 + cos)/2)^2 + 0.2 of a probe at `to_probe` from a point with unit normal `n`.
pub(crate) fn facing_weight(to_probe: Vec3, n: Vec3) -> f32 {
    let len = to_probe.length();
    let facing = if len > 1e-6 {
        (to_probe.dot(n) / len + 1.0) * 0.5
    } else {
        1.0
    };
    facing * facing + 0.2
}

/// World bounds of object `i` of `scene` under `m`.
fn object_bounds(scene: &Scene, i: usize, m: &Mat4) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for &mesh in &scene.objects[i].meshes {
        for &p in &scene.meshes[mesh as usize].positions {
            let w = m.transform_point3(p);
            lo = lo.min(w);
            hi = hi.max(w);
        }
    }
    (lo, hi)
}

/// The boxes of the objects that moved between two frames' transforms: old and new bounds of
/// each.
pub(crate) fn moved_boxes(scene: &Scene, before: &[Mat4], now: &[Mat4]) -> Vec<(Vec3, Vec3)> {
    let mut out = Vec::new();
    for (i, (a, b)) in before.iter().zip(now).enumerate() {
        if a != b {
            out.push(object_bounds(scene, i, a));
            out.push(object_bounds(scene, i, b));
        }
    }
    out
}
