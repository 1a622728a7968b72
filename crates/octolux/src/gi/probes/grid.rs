//! `probes-grid`: probes at the cell centres of a uniform grid over the scene's bounds, with
//! surfels placed around each by rays, lit every frame, integrated into each probe's encoding
//! and interpolated per pixel (see the module documentation of [`super`] and docs/probes.md).

use super::bvh::{Bvh, GpuNode, GpuTri, BVH_WGSL};
use super::encoding::{COEFFS, ENCODING_WGSL};
use super::lattice::{direction, LATTICE_WGSL};
use super::ProbeSettings;
use crate::gi::{GiFrame, GiTechnique};
use crate::gpu::{GpuContext, PassTimer};
use crate::render::dispatch_2d;
use crate::voxel::objects_triangles;
use crate::voxel::voxelize::dispatch;
use crate::{Error, Result};
use glam::{UVec3, Vec3};

const OWNER: &str = "probes-grid";
/// `vec4`s per probe and per surfel (`PROBE_VEC4`, `SURFEL_VEC4` in grid.wgsl).
pub(crate) const PROBE_VEC4: u64 = 9;
pub(crate) const SURFEL_VEC4: u64 = 3;
/// Root of an absent BVH part.
const NO_ROOT: u32 = u32::MAX;

/// `ProbeParams` in grid.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct ProbeParams {
    lo: [f32; 4],
    spacing: [f32; 4],
    dims: [u32; 4],
    misc: [u32; 4],
    roots: [u32; 4],
    limits: [u32; 4],
}

/// The probe grid's placement: the box it fills and the probe spacing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeGrid {
    /// Lower corner of the box.
    pub lo: Vec3,
    /// Distance between neighbouring probes per axis.
    pub spacing: Vec3,
    /// Probes per axis.
    pub dims: UVec3,
}

impl ProbeGrid {
    /// The grid of `dims` probes over `bounds`, one probe at the centre of each cell. Flat
    /// axes get a thickness of 1/1000 of the largest extent.
    pub fn over(bounds: (Vec3, Vec3), dims: [u32; 3]) -> Result<ProbeGrid> {
        let (lo, hi) = bounds;
        let extent = hi - lo;
        let largest = extent.max_element();
        if !(largest.is_finite() && largest > 0.0) {
            return Err(Error::InvalidArgument(format!(
                "probes need a scene with extent; its bounds are {lo} to {hi}"
            )));
        }
        let extent = extent.max(Vec3::splat(largest * 1e-3));
        let dims = UVec3::from(dims);
        Ok(ProbeGrid {
            lo,
            spacing: extent / dims.as_vec3(),
            dims,
        })
    }

    /// World position of the probe at grid coordinate `c`.
    pub fn position(&self, c: UVec3) -> Vec3 {
        self.lo + (c.as_vec3() + 0.5) * self.spacing
    }

    /// Probe count.
    pub fn count(&self) -> u32 {
        self.dims.x * self.dims.y * self.dims.z
    }
}

/// CPU twin of integrate.wgsl for one probe: its encoding's coefficients and (back-face
/// share, hit share, valid, 0) from its surfels' states (0 miss, 1 front, 2 back) and outgoing
/// radiance, in lattice order.
pub fn integrate_probe(
    settings: &ProbeSettings,
    states: &[f32],
    radiance: &[Vec3],
) -> ([Vec3; COEFFS], [f32; 4]) {
    let n = settings.surfels;
    let mut coeffs = [Vec3::ZERO; COEFFS];
    let (mut hits, mut back) = (0, 0);
    for k in 0..n {
        let state = states[k as usize];
        hits += (state > 0.5) as u32;
        back += (state > 1.5) as u32;
        let (dir, dw) = direction(settings.lattice, k, n);
        settings
            .encoding
            .add(&mut coeffs, radiance[k as usize], dir, dw);
    }
    let valid = if back <= settings.max_back_faces() {
        1.0
    } else {
        0.0
    };
    (
        coeffs,
        [back as f32 / n as f32, hits as f32 / n as f32, valid, 0.0],
    )
}

/// CPU twin of `grid_irradiance` (grid_sample.wgsl): irradiance at `p` (unit normal `n`)
/// from `probes` (the probe buffer's `vec4`s) on `grid`.
pub fn grid_irradiance(
    grid: &ProbeGrid,
    settings: &ProbeSettings,
    probes: &[[f32; 4]],
    p: Vec3,
    n: Vec3,
) -> Vec3 {
    let q = p + n * (settings.normal_bias * grid.spacing.min_element());
    let g = (q - grid.lo) / grid.spacing - 0.5;
    let hi = grid.dims.as_ivec3() - 2;
    let base = g.floor().as_ivec3().clamp(glam::IVec3::ZERO, hi);
    let t = (g - base.as_vec3()).clamp(Vec3::ZERO, Vec3::ONE);
    let (mut sum, mut total) = (Vec3::ZERO, 0.0);
    for c in 0..8u32 {
        let off = UVec3::new(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        let coord = base.as_uvec3() + off;
        let probe = (coord.x + grid.dims.x * (coord.y + grid.dims.y * coord.z)) as usize;
        let b = probe * PROBE_VEC4 as usize;
        if probes[b + 8][2] < 0.5 {
            continue;
        }
        let tri = Vec3::select(off.cmpeq(UVec3::ONE), t, Vec3::ONE - t);
        let to_probe = grid.position(coord) - p;
        let len = to_probe.length();
        let facing = if len > 1e-6 {
            (to_probe.dot(n) / len + 1.0) * 0.5
        } else {
            1.0
        };
        let w = tri.x * tri.y * tri.z * (facing * facing + 0.2);
        let coeffs: [Vec3; COEFFS] = std::array::from_fn(|k| Vec3::from_slice(&probes[b + k]));
        sum += settings.encoding.irradiance(&coeffs, n) * w;
        total += w;
    }
    if total > 0.0 {
        sum / total
    } else {
        Vec3::ZERO
    }
}

/// Probe + surfel GI on a uniform grid.
pub struct ProbesGrid {
    settings: ProbeSettings,
    grid: ProbeGrid,
    params: ProbeParams,
    params_buffer: wgpu::Buffer,
    nodes: wgpu::Buffer,
    tris: wgpu::Buffer,
    /// Nodes and triangles of the static part (the animated part follows them).
    static_size: (u32, u32),
    /// Whether any object moves: then the animated part is rebuilt and surfels re-placed
    /// every frame.
    animated: bool,
    placed: bool,
    surfels: wgpu::Buffer,
    radiance: wgpu::Buffer,
    probes: wgpu::Buffer,
    matrices: Option<(wgpu::Buffer, usize)>,
    place: wgpu::ComputePipeline,
    light: wgpu::ComputePipeline,
    integrate: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    size: (u32, u32),
}

/// WGSL: `grid_irradiance(p, n)`, the gather from the probe grid.
const GRID_SAMPLE_WGSL: &str = include_str!("grid_sample.wgsl");

/// The WGSL of one probe pass: the shared parts, `extra` and `pass`.
pub(crate) fn pass_source(pass: &str, extra: &[&str]) -> String {
    let mut parts = vec![
        include_str!("../../render/common.wgsl"),
        LATTICE_WGSL,
        ENCODING_WGSL,
        include_str!("grid.wgsl"),
    ];
    parts.extend(extra);
    parts.push(pass);
    parts.join("\n")
}

/// A storage buffer of `bytes`, or a clear error where one binding of that size exceeds what
/// the adapter allows.
fn storage(ctx: &GpuContext, label: &str, bytes: u64) -> Result<wgpu::Buffer> {
    let limit = ctx.device.limits().max_storage_buffer_binding_size;
    if bytes > limit {
        return Err(Error::InvalidArgument(format!(
            "probes-grid: its {label} need {} MiB, more than the adapter's {} MiB per storage \
             binding; use fewer probes or surfels",
            bytes.div_ceil(1 << 20),
            limit >> 20
        )));
    }
    Ok(ctx.create_buffer(
        OWNER,
        &wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        },
    ))
}

fn buf(b: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
    b.as_entire_binding()
}

/// A bind group of `pipeline` with `entries` at bindings 0, 1, ...
pub(crate) fn bind(
    ctx: &GpuContext,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    entries: &[wgpu::BindingResource],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = entries
        .iter()
        .enumerate()
        .map(|(i, resource)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: resource.clone(),
        })
        .collect();
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

impl ProbesGrid {
    /// The technique for `scene` at `width` x `height`.
    pub fn new(
        ctx: &GpuContext,
        settings: &ProbeSettings,
        scene: &crate::scene::Scene,
        width: u32,
        height: u32,
    ) -> Result<ProbesGrid> {
        settings.validate()?;
        let bounds = scene.bounds_at(0.0);
        let grid = ProbeGrid::over(bounds, settings.grid)?;
        let frame = scene.frame(0.0, 0);
        let still = Bvh::build(&objects_triangles(scene, &frame, false));
        let moving = objects_triangles(scene, &frame, true);
        let animated = scene.objects.iter().any(|o| o.animation.is_some());
        let (nodes, tris) = still.flatten_at(0, 0);
        let static_size = (nodes.len() as u32, tris.len() as u32);
        // The animated part's BVH has at most 2n - 1 nodes for n triangles.
        let node_bytes = std::mem::size_of::<GpuNode>() as u64;
        let tri_bytes = std::mem::size_of::<GpuTri>() as u64;
        let node_buffer = storage(
            ctx,
            "bvh nodes",
            (nodes.len() + 2 * moving.len()) as u64 * node_bytes,
        )?;
        let tri_buffer = storage(
            ctx,
            "bvh triangles",
            (tris.len() + moving.len()) as u64 * tri_bytes,
        )?;
        ctx.queue
            .write_buffer(&node_buffer, 0, bytemuck::cast_slice(&nodes));
        ctx.queue
            .write_buffer(&tri_buffer, 0, bytemuck::cast_slice(&tris));
        let probes = grid.count();
        let surfels = probes * settings.surfels;
        let (lo, hi) = bounds;
        let params = ProbeParams {
            lo: lo.extend((hi - lo).length() * 1.01).to_array(),
            spacing: grid
                .spacing
                .extend(settings.normal_bias * grid.spacing.min_element())
                .to_array(),
            dims: grid.dims.extend(settings.surfels).to_array(),
            misc: [
                settings.lattice.gpu_kind(),
                settings.encoding.gpu_kind(),
                0,
                settings.multi_bounce as u32,
            ],
            roots: [
                if nodes.is_empty() { NO_ROOT } else { 0 },
                NO_ROOT,
                probes,
                surfels,
            ],
            limits: [settings.max_back_faces(), 0, 0, 0],
        };
        let params_buffer = storage(ctx, "params", std::mem::size_of::<ProbeParams>() as u64)?;
        let pipeline = |name: &str, source: &str, extra: &[&str]| {
            let module = ctx.shader(name, &pass_source(source, extra));
            ctx.compute_pipeline(name, &module, "main")
        };
        let (texture, view) = crate::gi::indirect_target(ctx, OWNER, width, height);
        Ok(ProbesGrid {
            settings: settings.clone(),
            grid,
            params,
            params_buffer,
            nodes: node_buffer,
            tris: tri_buffer,
            static_size,
            animated,
            placed: false,
            surfels: storage(ctx, "surfels", surfels as u64 * SURFEL_VEC4 * 16)?,
            radiance: storage(ctx, "surfel radiance", surfels as u64 * 16)?,
            probes: storage(ctx, "probes", probes as u64 * PROBE_VEC4 * 16)?,
            matrices: None,
            place: pipeline("probes place", include_str!("place.wgsl"), &[BVH_WGSL]),
            light: pipeline(
                "probes light",
                include_str!("light.wgsl"),
                &[include_str!("../../render/lights.wgsl"), GRID_SAMPLE_WGSL],
            ),
            integrate: pipeline("probes integrate", include_str!("integrate.wgsl"), &[]),
            gather: pipeline(
                "probes gather",
                include_str!("gather.wgsl"),
                &[GRID_SAMPLE_WGSL],
            ),
            texture,
            view,
            size: (width, height),
        })
    }

    /// The indirect irradiance image (as [`GiTechnique::indirect_view`] views it).
    pub fn indirect_texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    /// The grid the probes sit on.
    pub fn grid(&self) -> &ProbeGrid {
        &self.grid
    }

    /// The settings in use.
    pub fn settings(&self) -> &ProbeSettings {
        &self.settings
    }

    /// The probe buffer (per probe 8 coefficients, then back-face share, hit share, valid).
    pub fn probe_buffer(&self) -> &wgpu::Buffer {
        &self.probes
    }

    /// The surfel buffer (per surfel position + state, normal + albedo, emission + distance)
    /// and the surfels' outgoing radiance.
    pub fn surfel_buffers(&self) -> (&wgpu::Buffer, &wgpu::Buffer) {
        (&self.surfels, &self.radiance)
    }

    /// Rebuilds the animated objects' BVH for this frame after the static part.
    fn sync_moving(&mut self, ctx: &GpuContext, frame: &GiFrame) -> Result<()> {
        let moving = Bvh::build(&objects_triangles(frame.scene, frame.frame, true));
        let (node_base, tri_base) = self.static_size;
        let (nodes, tris) = moving.flatten_at(node_base, tri_base);
        let node_bytes = std::mem::size_of::<GpuNode>() as u64;
        let tri_bytes = std::mem::size_of::<GpuTri>() as u64;
        let end = |base: u32, count: usize, bytes: u64| (base as u64 + count as u64) * bytes;
        if end(node_base, nodes.len(), node_bytes) > self.nodes.size()
            || end(tri_base, tris.len(), tri_bytes) > self.tris.size()
        {
            return Err(Error::InvalidArgument(format!(
                "probes-grid: the animated objects have {} triangles at t = {} s, more than \
                 at the start",
                tris.len(),
                frame.frame.time
            )));
        }
        if !nodes.is_empty() {
            ctx.queue.write_buffer(
                &self.nodes,
                node_base as u64 * node_bytes,
                bytemuck::cast_slice(&nodes),
            );
            ctx.queue.write_buffer(
                &self.tris,
                tri_base as u64 * tri_bytes,
                bytemuck::cast_slice(&tris),
            );
        }
        self.params.roots[1] = if nodes.is_empty() { NO_ROOT } else { node_base };
        Ok(())
    }

    /// Uploads this frame's shadow matrices, growing their buffer when needed.
    fn sync_matrices(&mut self, ctx: &GpuContext, frame: &GiFrame) -> Result<()> {
        let mut matrices: Vec<[f32; 16]> = frame
            .shadow_layers
            .iter()
            .map(|l| l.view_proj.to_cols_array())
            .collect();
        if matrices.is_empty() {
            matrices.push(glam::Mat4::IDENTITY.to_cols_array());
        }
        let buffer = match &mut self.matrices {
            Some((buffer, room)) if *room >= matrices.len() => buffer,
            slot => {
                let buffer = storage(ctx, "shadow matrices", matrices.len() as u64 * 64)?;
                &slot.insert((buffer, matrices.len())).0
            }
        };
        ctx.queue
            .write_buffer(buffer, 0, bytemuck::cast_slice(&matrices));
        Ok(())
    }
}

impl GiTechnique for ProbesGrid {
    fn name(&self) -> &str {
        "probes-grid"
    }

    fn update(&mut self, ctx: &GpuContext, frame: &GiFrame, timer: &mut PassTimer) -> Result<()> {
        if self.animated {
            self.sync_moving(ctx, frame)?;
        }
        self.params.misc[2] = frame.frame.lights.len() as u32;
        ctx.queue
            .write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&self.params));
        self.sync_matrices(ctx, frame)?;
        let Some((matrices, _)) = &self.matrices else {
            return Err(Error::Gpu("probes-grid: no shadow matrices".into()));
        };
        let params = buf(&self.params_buffer);
        let surfels = self.params.roots[3];
        // 1. Surfels: rays from every probe along its lattice (once for a static scene).
        if !self.placed || self.animated {
            let group = bind(
                ctx,
                "probes place",
                &self.place,
                &[
                    params.clone(),
                    buf(&self.nodes),
                    buf(&self.tris),
                    buf(&self.surfels),
                ],
            );
            dispatch(timer, "probes place", &self.place, &group, surfels);
            self.placed = true;
        }
        // 2. Surfel light: direct light with shadow-map visibility (+ last frame's probes).
        let group = bind(
            ctx,
            "probes light",
            &self.light,
            &[
                params.clone(),
                buf(&self.surfels),
                buf(&self.radiance),
                buf(&self.probes),
                buf(frame.lights),
                buf(matrices),
                wgpu::BindingResource::TextureView(&frame.shadows.array_view),
                wgpu::BindingResource::Sampler(&frame.shadows.sampler),
            ],
        );
        dispatch(timer, "probes light", &self.light, &group, surfels);
        // 3. Probes: each integrates its surfels into its encoding.
        let group = bind(
            ctx,
            "probes integrate",
            &self.integrate,
            &[
                params.clone(),
                buf(&self.surfels),
                buf(&self.radiance),
                buf(&self.probes),
            ],
        );
        dispatch(
            timer,
            "probes integrate",
            &self.integrate,
            &group,
            self.grid.count(),
        );
        // 4. Pixels: interpolation between the 8 probes around each.
        let group = bind(
            ctx,
            "probes gather",
            &self.gather,
            &[
                params,
                buf(&self.probes),
                buf(frame.camera_uniform),
                wgpu::BindingResource::TextureView(&frame.gbuffer.depth_view),
                wgpu::BindingResource::TextureView(&frame.gbuffer.normal_view),
                wgpu::BindingResource::TextureView(&self.view),
            ],
        );
        let (w, h) = self.size;
        dispatch_2d(timer, "probes gather", &self.gather, &group, w, h);
        Ok(())
    }

    fn indirect_view(&self) -> &wgpu::TextureView {
        &self.view
    }

    fn reference_bounces(&self) -> crate::reference::Bounces {
        if self.settings.multi_bounce {
            crate::reference::Bounces::Unlimited
        } else {
            crate::reference::Bounces::Indirect(1)
        }
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}
