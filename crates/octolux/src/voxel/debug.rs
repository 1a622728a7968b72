//! Looking at the voxel structures: [`probe`] samples one at given points on the GPU (tests
//! compare it with the CPU twins), and [`render_view`] ray-marches it from a camera and returns
//! an RGBA8 image of the stored albedo (front-to-back compositing of filtered samples, shaded
//! by the opacity gradient where the ray first passes half opacity, so that equally coloured
//! surfaces stay apart), so a person can check that the structure matches the scene.

use super::clipmap::sample::{clip_bindings, ClipInfo, CLIP_BINDINGS, CLIP_RADIANCE_BINDING};
use super::clipmap::Clipmap;
use super::svo::sample::{svo_albedo_bindings, svo_bindings, SvoInfo};
use super::svo::Svo;
use crate::gpu::{read_buffer, GpuContext, PassTimer, PassTiming};
use crate::scene::CameraView;
use crate::{Error, Result};
use glam::{Vec3, Vec4};

/// A structure to sample.
#[derive(Clone, Copy)]
pub enum Structure<'a> {
    /// A sparse voxel octree.
    Svo(&'a Svo),
    /// A clipmap (albedo).
    Clipmap(&'a Clipmap),
    /// A clipmap's injected radiance ([`Clipmap::inject`] must have run).
    ClipmapRadiance(&'a Clipmap),
}

/// The sampler each structure's debug kernels call (`sample_structure` in `debug.wgsl`).
const SVO_HEADER: &str = "import octolux::voxel::svo::sample::svo_sample;
fn sample_structure(p: vec3<f32>, footprint: f32) -> vec4<f32> { return svo_sample(p, footprint); }
";

const RADIANCE_HEADER: &str = "import octolux::voxel::clipmap::radiance_sample::clip_radiance_sample;
fn sample_structure(p: vec3<f32>, footprint: f32) -> vec4<f32> { return clip_radiance_sample(p, footprint); }
";

const CLIP_HEADER: &str = "import octolux::voxel::clipmap::sample::clip_sample;
fn sample_structure(p: vec3<f32>, footprint: f32) -> vec4<f32> { return clip_sample(p, footprint); }
";

/// Parameter block `View` of `debug.wgsl`: what the probe and the ray march read.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ViewBlock {
    inv_view_proj: [[f32; 4]; 4],
    /// The camera's position.
    eye: [f32; 3],
    /// The samples' footprint (m).
    footprint: f32,
    /// The box the rays march through.
    lo: [f32; 3],
    /// The step length (m).
    step: f32,
    hi: [f32; 3],
    /// The most steps one ray takes.
    max_steps: u32,
    /// The image's size in pixels.
    width: u32,
    height: u32,
    /// Points to probe.
    points: u32,
    _pad: u32,
}

impl ViewBlock {
    /// The block with every field zero but the identity transform.
    fn new() -> ViewBlock {
        ViewBlock {
            inv_view_proj: glam::Mat4::IDENTITY.to_cols_array_2d(),
            ..bytemuck::Zeroable::zeroed()
        }
    }
}

impl Structure<'_> {
    fn ready(&self) -> Result<()> {
        match self {
            Structure::ClipmapRadiance(c) if c.radiance.is_none() => Err(Error::InvalidArgument(
                "the clipmap has no radiance yet: run Clipmap::inject first".into(),
            )),
            _ => Ok(()),
        }
    }

    fn source(&self) -> Result<String> {
        let header = match self {
            Structure::Svo(_) => SVO_HEADER,
            Structure::Clipmap(_) => CLIP_HEADER,
            Structure::ClipmapRadiance(_) => RADIANCE_HEADER,
        };
        debug_source(header)
    }

    fn info(&self, ctx: &GpuContext) -> wgpu::Buffer {
        let bytes = match self {
            Structure::Svo(svo) => {
                bytemuck::bytes_of(&SvoInfo::new(svo.grid(), svo.pool_bricks())).to_vec()
            }
            Structure::Clipmap(c) | Structure::ClipmapRadiance(c) => {
                bytemuck::bytes_of(&ClipInfo::new(&c.settings, &c.origins)).to_vec()
            }
        };
        ctx.create_buffer_init("voxel debug", "info", &bytes, wgpu::BufferUsages::STORAGE)
    }

    /// World-space box the structure covers (the coarsest clipmap level).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self {
            Structure::Svo(svo) => {
                let g = svo.grid();
                (
                    g.origin,
                    g.origin + Vec3::splat(g.voxel_size * g.resolution as f32),
                )
            }
            Structure::Clipmap(c) | Structure::ClipmapRadiance(c) => {
                let l = c.settings.levels - 1;
                let v = c.settings.level_voxel(l);
                let o = c.origins[l as usize].unwrap_or_default().as_vec3() * v;
                (o, o + Vec3::splat(v * c.settings.resolution as f32))
            }
        }
    }

    /// The footprint (m) of level `level` of the structure: the octree's lattice spacing on
    /// that level, or the clipmap level's voxel edge.
    pub fn level_footprint(&self, level: u32) -> Result<f32> {
        match self {
            Structure::Svo(svo) => {
                let depth = svo.grid().depth();
                if level >= depth {
                    return Err(Error::InvalidArgument(format!(
                        "level {level}: the octree has levels 0 to {}",
                        depth - 1
                    )));
                }
                Ok(svo.grid().voxel_size * (1u32 << (depth - 1 - level)) as f32)
            }
            Structure::Clipmap(c) | Structure::ClipmapRadiance(c) => {
                if level >= c.settings.levels {
                    return Err(Error::InvalidArgument(format!(
                        "level {level}: the clipmap has levels 0 to {}",
                        c.settings.levels - 1
                    )));
                }
                Ok(c.settings.level_voxel(level))
            }
        }
    }

    fn bind(
        &self,
        ctx: &GpuContext,
        pipeline: &wgpu::ComputePipeline,
        view: &wgpu::Buffer,
        info: &wgpu::Buffer,
        extra: &[(u32, &wgpu::Buffer)],
    ) -> wgpu::BindGroup {
        let mut entries = vec![(0, view.as_entire_binding())];
        match self {
            Structure::Svo(svo) => {
                entries.extend(svo_bindings(info, svo));
                entries.extend(svo_albedo_bindings(svo));
            }
            Structure::Clipmap(c) => entries.extend(clip_bindings(info, &c.voxels)),
            Structure::ClipmapRadiance(c) => {
                entries.push((CLIP_BINDINGS, info.as_entire_binding()));
                if let Some(radiance) = &c.radiance {
                    entries.push((CLIP_RADIANCE_BINDING, radiance.as_entire_binding()));
                }
            }
        }
        entries.extend(
            extra
                .iter()
                .map(|&(b, buffer)| (b, buffer.as_entire_binding())),
        );
        crate::gpu::pass::bind(ctx, pipeline, &entries)
    }
}

/// The debug kernels (`debug.wgsl`) over the sampler `header` defines.
fn debug_source(header: &str) -> Result<String> {
    let text = format!(
        "{header}
{}",
        include_str!("debug.wgsl")
    );
    crate::gpu::shader::compose_text("voxel debug", &text, &[], &[])
}

/// Samples `structure` at `points` (xyz = position, w = footprint) on the GPU. Blocks.
pub fn probe(ctx: &GpuContext, structure: Structure, points: &[Vec4]) -> Result<Vec<Vec4>> {
    structure.ready()?;
    let n = points.len() as u32;
    let module = ctx.shader("voxel probe", &structure.source()?);
    let pipeline = ctx.compute_pipeline("voxel probe", &module, "probe");
    let block = ViewBlock {
        points: n,
        ..ViewBlock::new()
    };
    let view = ctx.create_buffer_init(
        "voxel debug",
        "view",
        bytemuck::bytes_of(&block),
        wgpu::BufferUsages::STORAGE,
    );
    let info = structure.info(ctx);
    let input = ctx.create_buffer_init(
        "voxel debug",
        "points",
        bytemuck::cast_slice(points),
        wgpu::BufferUsages::STORAGE,
    );
    let out = ctx.create_buffer(
        "voxel debug",
        &wgpu::BufferDescriptor {
            label: Some("samples"),
            size: (n as u64 * 16).max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        },
    );
    let group = structure.bind(ctx, &pipeline, &view, &info, &[(4, &input), (5, &out)]);
    let mut timer = PassTimer::new(ctx);
    timer.pass("voxel probe", |encoder, stamps| {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("voxel probe"),
            timestamp_writes: stamps.compute(),
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(n.div_ceil(64).max(1), 1, 1);
    });
    timer.finish_frame()?;
    let bytes = read_buffer(ctx, &out, 0, n as u64 * 16)?;
    Ok(bytemuck::cast_slice::<u8, Vec4>(&bytes).to_vec())
}

/// Ray-marches `structure` as seen through `view` with samples of footprint `footprint` (m),
/// half a footprint per step, and returns the composited albedo as RGBA8 rows (top first) and the
/// time of the pass (`voxel debug view`). Blocks.
pub fn render_view(
    ctx: &GpuContext,
    structure: Structure,
    view: &CameraView,
    footprint: f32,
) -> Result<(Vec<u8>, Vec<PassTiming>)> {
    if !(footprint.is_finite() && footprint > 0.0) {
        return Err(Error::InvalidArgument(format!("footprint {footprint}")));
    }
    structure.ready()?;
    let (lo, hi) = structure.bounds();
    let block = ViewBlock {
        inv_view_proj: view.inv_view_proj.to_cols_array_2d(),
        eye: view.position.to_array(),
        footprint,
        lo: lo.to_array(),
        step: 0.5 * footprint,
        hi: hi.to_array(),
        // lavapipe ends any invocation after 65535 loop iterations; 2048 steps stay far below.
        max_steps: 2048,
        width: view.width,
        height: view.height,
        points: 0,
        _pad: 0,
    };
    let module = ctx.shader("voxel debug view", &structure.source()?);
    let pipeline = ctx.compute_pipeline("voxel debug view", &module, "raymarch");
    let view_buffer = ctx.create_buffer_init(
        "voxel debug",
        "view",
        bytemuck::bytes_of(&block),
        wgpu::BufferUsages::STORAGE,
    );
    let info = structure.info(ctx);
    let pixels = view.width as u64 * view.height as u64;
    let image = ctx.create_buffer(
        "voxel debug",
        &wgpu::BufferDescriptor {
            label: Some("image"),
            size: (pixels * 4).max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        },
    );
    let group = structure.bind(ctx, &pipeline, &view_buffer, &info, &[(6, &image)]);
    let mut timer = PassTimer::new(ctx);
    timer.pass("voxel debug view", |encoder, stamps| {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("voxel debug view"),
            timestamp_writes: stamps.compute(),
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(view.width.div_ceil(8), view.height.div_ceil(8), 1);
    });
    let timings = timer.finish_frame()?;
    Ok((read_buffer(ctx, &image, 0, pixels * 4)?, timings))
}

/// Which structure [`render_scene`] builds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StructureKind {
    /// Sparse voxel octree.
    Svo,
    /// Clipmap (albedo).
    Clipmap,
    /// Clipmap with light injected from the scene's lights (radiance).
    ClipmapRadiance,
}

impl std::str::FromStr for StructureKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<StructureKind> {
        match s {
            "svo" => Ok(StructureKind::Svo),
            "clipmap" => Ok(StructureKind::Clipmap),
            "clipmap-radiance" => Ok(StructureKind::ClipmapRadiance),
            _ => Err(Error::InvalidArgument(format!(
                "voxel structure '{s}': expected svo, clipmap or clipmap-radiance"
            ))),
        }
    }
}

/// The clipmap that stands beside an `n`^3 octree in the debug view and the measurements:
/// finest voxel equal to the octree's, levels of `min(n, 64)`^3, as many as it takes for the
/// coarsest to span twice the octree's grid (so that the whole scene stays inside the part of
/// the coarsest level that may be sampled wherever the clipmap is centred in the scene).
pub fn matching_clipmap(grid: &super::VoxelGrid) -> super::clipmap::ClipmapSettings {
    let resolution = grid.resolution.clamp(4, 64);
    super::clipmap::ClipmapSettings {
        resolution,
        levels: (grid.resolution / resolution).trailing_zeros() + 2,
        voxel_size: grid.voxel_size,
    }
}

/// Builds `kind` for `scene` at time `t` (octree: the `resolution`^3 grid enclosing the scene;
/// clipmap: [`matching_clipmap`] centred on the scene's centre) and ray-marches it from camera
/// `camera` at footprint level `level` (default: the finest). Returns sRGB-encoded RGB8 rows
/// and a one-line summary (nodes or voxels, memory, pass times).
#[allow(clippy::too_many_arguments)]
pub fn render_scene(
    ctx: &GpuContext,
    scene: &crate::scene::Scene,
    t: f32,
    camera: usize,
    width: u32,
    height: u32,
    kind: StructureKind,
    resolution: u32,
    level: Option<u32>,
) -> Result<(Vec<u8>, String)> {
    let frame = scene.frame(t, camera);
    let tris = super::scene_triangles(scene, &frame);
    let bounds = scene.bounds_at(t);
    let grid = super::VoxelGrid::enclosing(bounds, resolution)?;
    let view = frame.camera.view(width, height);
    let (rgba, summary) = match kind {
        StructureKind::Svo => {
            let (svo, timings) = super::svo::SvoBuilder::new(ctx).build(ctx, &grid, &tris)?;
            let s = Structure::Svo(&svo);
            let footprint = s.level_footprint(level.unwrap_or(grid.depth() - 1))?;
            let (rgba, _) = render_view(ctx, s, &view, footprint)?;
            let ms: f64 = timings.iter().map(|t| t.ms).sum();
            let summary = format!(
                "octree {r}^3: {} nodes, {} fragments, {:.1} MB, build {ms:.1} ms",
                svo.node_count(),
                svo.fragment_count(),
                svo.bytes() as f64 / 1e6,
                r = grid.resolution
            );
            (rgba, summary)
        }
        StructureKind::Clipmap | StructureKind::ClipmapRadiance => {
            let settings = matching_clipmap(&grid);
            let mut clipmap = super::clipmap::Clipmap::new(ctx, settings)?;
            let mut timer = PassTimer::new(ctx);
            let centre = (bounds.0 + bounds.1) * 0.5;
            clipmap.update(ctx, &mut timer, &tris, centre)?;
            if kind == StructureKind::ClipmapRadiance {
                clipmap.inject(ctx, &mut timer, &frame.lights, 1024)?;
            }
            let ms: f64 = timer.finish_frame()?.iter().map(|t| t.ms).sum();
            let s = if kind == StructureKind::ClipmapRadiance {
                Structure::ClipmapRadiance(&clipmap)
            } else {
                Structure::Clipmap(&clipmap)
            };
            let footprint = s.level_footprint(level.unwrap_or(0))?;
            let (rgba, _) = render_view(ctx, s, &view, footprint)?;
            let summary = format!(
                "clipmap {} levels of {}^3: {:.1} MB, build {ms:.1} ms",
                settings.levels,
                settings.resolution,
                clipmap.bytes() as f64 / 1e6
            );
            (rgba, summary)
        }
    };
    let rgb = rgba
        .chunks_exact(4)
        .flat_map(|p| {
            [p[0], p[1], p[2]]
                .map(|c| (crate::image_io::linear_to_srgb(c as f32 / 255.0) * 255.0).round() as u8)
        })
        .collect();
    Ok((rgb, summary))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_block_mirrors_the_wgsl_block() {
        let fields = [
            (
                "inv_view_proj",
                std::mem::offset_of!(ViewBlock, inv_view_proj),
            ),
            ("eye", std::mem::offset_of!(ViewBlock, eye)),
            ("footprint", std::mem::offset_of!(ViewBlock, footprint)),
            ("lo", std::mem::offset_of!(ViewBlock, lo)),
            ("step", std::mem::offset_of!(ViewBlock, step)),
            ("hi", std::mem::offset_of!(ViewBlock, hi)),
            ("max_steps", std::mem::offset_of!(ViewBlock, max_steps)),
            ("width", std::mem::offset_of!(ViewBlock, width)),
            ("height", std::mem::offset_of!(ViewBlock, height)),
            ("points", std::mem::offset_of!(ViewBlock, points)),
            ("_pad", std::mem::offset_of!(ViewBlock, _pad)),
        ];
        // The same block whichever structure the kernels sample.
        for header in [SVO_HEADER, CLIP_HEADER, RADIANCE_HEADER] {
            crate::gpu::layout::assert_mirrors(
                &debug_source(header).unwrap(),
                "View",
                std::mem::size_of::<ViewBlock>(),
                &fields,
            );
        }
    }
}
