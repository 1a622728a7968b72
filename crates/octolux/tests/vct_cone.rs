//! The cone marcher on the GPU against its CPU twin (`gi::vct::cone`), through a small dense
//! voxel grid with box-filtered mips whose sampler is written twice (WGSL below, Rust here) in
//! the same way: empty space, a half-filled grid of a semi-transparent medium, and an opaque
//! coloured wall, with narrow and wide cones in several directions.
//!
//! Tolerance: 1e-4 absolute + 1e-4 relative per channel. The two sides run the same f32
//! operations in the same order but `tan`, `log2` and `pow` may differ by a few ulps between
//! adapters; every quantity they feed is continuous in its inputs (the level blend is
//! quadrilinear, so a footprint on a level boundary reads the same from either side), so such
//! differences stay near 1e-6 relative. The march's two discrete decisions (a sample past
//! `max_distance`, the accumulated opacity past `stop_opacity`) are kept off their boundaries:
//! the test checks on the CPU that no sample position comes within 1e-3 m of `max_distance`
//! and no accumulated opacity within 1e-3 of `stop_opacity`, so both sides take the same
//! samples.

use crate::lit_floor;
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};
use octolux::gi::vct::gather::diffuse_cone_dir;
use octolux::gi::vct::{cone_set_wgsl, gather_irradiance, march_cone, ConeMarch, ConeParams};
use octolux::gpu::{read_buffer, storage_entry, GpuContext, GpuOptions};

const N: usize = 8;
const LEVELS: usize = 4;
const VOXEL: f32 = 0.125;

/// A dense N^3 grid of premultiplied RGBA with box-filtered mips, levels concatenated.
struct Grid {
    origin: Vec3,
    levels: Vec<Vec<Vec4>>,
}

impl Grid {
    fn new(voxel: impl Fn(usize, usize, usize) -> Vec4) -> Grid {
        let mut levels = vec![(0..N * N * N)
            .map(|i| voxel(i % N, (i / N) % N, i / (N * N)))
            .collect::<Vec<_>>()];
        for l in 1..LEVELS {
            let (n, fine) = (N >> l, &levels[l - 1]);
            let m = N >> (l - 1);
            let level = (0..n * n * n)
                .map(|i| {
                    let (x, y, z) = (i % n, (i / n) % n, i / (n * n));
                    let mut sum = Vec4::ZERO;
                    for k in 0..8 {
                        let (a, b, c) = (2 * x + (k & 1), 2 * y + ((k >> 1) & 1), 2 * z + (k >> 2));
                        sum += fine[a + m * b + m * m * c];
                    }
                    sum * 0.125
                })
                .collect();
            levels.push(level);
        }
        Grid {
            origin: Vec3::new(-0.5, -0.5, -0.5),
            levels,
        }
    }

    fn voxel(&self, l: usize, i: [i32; 3]) -> Vec4 {
        let n = (N >> l) as i32;
        if i.iter().any(|&c| c < 0 || c >= n) {
            return Vec4::ZERO;
        }
        self.levels[l][(i[0] + n * i[1] + n * n * i[2]) as usize]
    }

    /// Trilinear sample of level l (voxel centres on the lattice, zero outside).
    fn sample_level(&self, p: Vec3, l: usize) -> Vec4 {
        let size = VOXEL * (1u32 << l) as f32;
        let g = (p - self.origin) / size - Vec3::splat(0.5);
        let i0 = g.floor();
        let f = g - i0;
        let mut sum = Vec4::ZERO;
        for k in 0..8u32 {
            let o = [k & 1, (k >> 1) & 1, k >> 2];
            let w = (if o[0] == 1 { f.x } else { 1.0 - f.x })
                * (if o[1] == 1 { f.y } else { 1.0 - f.y })
                * (if o[2] == 1 { f.z } else { 1.0 - f.z });
            let i = [
                i0.x as i32 + o[0] as i32,
                i0.y as i32 + o[1] as i32,
                i0.z as i32 + o[2] as i32,
            ];
            sum += w * self.voxel(l, i);
        }
        sum
    }

    /// The sampler the marcher sees: the level of the footprint, blended between two levels.
    fn sample(&self, p: Vec3, footprint: f32) -> Vec4 {
        let lambda = (footprint / VOXEL).log2().clamp(0.0, (LEVELS - 1) as f32);
        let l0 = lambda.floor();
        let f = lambda - l0;
        let l0 = l0 as usize;
        let l1 = (l0 + 1).min(LEVELS - 1);
        let a = self.sample_level(p, l0);
        let b = self.sample_level(p, l1);
        a + f * (b - a)
    }

    fn flat(&self) -> Vec<[f32; 4]> {
        self.levels.iter().flatten().map(|v| v.to_array()).collect()
    }
}

/// The cones to march and their results (bindings 8 and 9, after any sampler's), and the
/// kernel marching one cone per invocation through the structure's `vct_sample` (the module
/// composed in as `gi/vct/structure`).
const CONE_KERNEL_WGSL: &str = r#"
import octolux::gi::vct::cone::{ConeParams, march_cone};
import octolux::gi::vct::gather::{diffuse_cone_dir, diffuse_cone_weight};
import octolux::gi::vct::cone_set::DIFFUSE_CONES;

struct Cone { origin: vec4<f32>, dir: vec4<f32>, params: ConeParams }
@group(0) @binding(8) var<storage, read> cones: array<Cone>;
@group(0) @binding(9) var<storage, read_write> results: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&results) {
        return;
    }
    let c = cones[id.x];
    results[id.x] = march_cone(c.origin.xyz, c.dir.xyz, c.params);
}
"#;

/// The test's structure: a dense mipmapped grid, sampled quadrilinearly.
const SAMPLER_WGSL: &str = r#"
struct GridInfo { origin: vec4<f32>, misc: vec4<u32> }
@group(0) @binding(0) var<storage, read> info: GridInfo;
@group(0) @binding(1) var<storage, read> grid: array<vec4<f32>>;


fn level_offset(l: u32) -> u32 {
    var offset = 0u;
    for (var k = 0u; k < l; k++) {
        let n = info.misc.x >> k;
        offset += n * n * n;
    }
    return offset;
}

fn grid_voxel(l: u32, i: vec3<i32>) -> vec4<f32> {
    let n = i32(info.misc.x >> l);
    if any(i < vec3<i32>(0)) || any(i >= vec3<i32>(n)) {
        return vec4<f32>(0.0);
    }
    return grid[level_offset(l) + u32(i.x + n * i.y + n * n * i.z)];
}

fn sample_level(p: vec3<f32>, l: u32) -> vec4<f32> {
    let size = info.origin.w * f32(1u << l);
    let g = (p - info.origin.xyz) / size - vec3<f32>(0.5);
    let i0 = floor(g);
    let f = g - i0;
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let o = vec3<u32>(k & 1u, (k >> 1u) & 1u, k >> 2u);
        let w = select(1.0 - f.x, f.x, o.x == 1u) * select(1.0 - f.y, f.y, o.y == 1u)
            * select(1.0 - f.z, f.z, o.z == 1u);
        sum += w * grid_voxel(l, vec3<i32>(i0) + vec3<i32>(o));
    }
    return sum;
}

fn vct_sample(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    let lambda = clamp(log2(footprint / info.origin.w), 0.0, f32(info.misc.y - 1u));
    let l0 = floor(lambda);
    let f = lambda - l0;
    let a = sample_level(p, u32(l0));
    let b = sample_level(p, min(u32(l0) + 1u, info.misc.y - 1u));
    return a + f * (b - a);
}
"#;

/// Entry points of the gather test (after [`CONE_KERNEL_WGSL`]).
const GATHER_KERNEL_WGSL: &str = r#"
// The diffuse gather at apex `origin` around the normal `dir`: irradiance in rgb.
@compute @workgroup_size(64)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&results) {
        return;
    }
    let c = cones[id.x];
    var e = vec3<f32>(0.0);
    for (var i = 0u; i < DIFFUSE_CONES; i++) {
        let l = march_cone(c.origin.xyz, diffuse_cone_dir(c.dir.xyz, i), c.params);
        e += diffuse_cone_weight(i) * l.rgb;
    }
    results[id.x] = vec4<f32>(3.14159265 * e, 0.0);
}

// The cone directions around the normal `dir` (one invocation per cone of the set).
@compute @workgroup_size(64)
fn directions(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&results) {
        return;
    }
    let c = cones[id.x / DIFFUSE_CONES];
    results[id.x] = vec4<f32>(diffuse_cone_dir(c.dir.xyz, id.x % DIFFUSE_CONES), 0.0);
}
"#;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuCone {
    origin: [f32; 4],
    dir: [f32; 4],
    params: ConeParams,
}

/// Runs entry point `entry` with one invocation per result (`results` of them).
fn gpu_run(
    ctx: &GpuContext,
    grid: &Grid,
    cones: &[ConeMarch],
    entry: &str,
    results: usize,
) -> Vec<Vec4> {
    let module = ctx.shader(
        "cone test",
        &compose_kernel(
            &format!("{CONE_KERNEL_WGSL}\n{GATHER_KERNEL_WGSL}"),
            SAMPLER_WGSL,
        ),
    );
    // One explicit layout for every entry point (some read only part of the bindings).
    let layout = ctx
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[
                storage_entry(0, true),
                storage_entry(1, true),
                storage_entry(8, true),
                storage_entry(9, false),
            ],
        });
    let pipeline_layout = ctx
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
    let pipeline = ctx
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
    let storage = wgpu::BufferUsages::STORAGE;
    let info: [f32; 8] = [
        grid.origin.x,
        grid.origin.y,
        grid.origin.z,
        VOXEL,
        f32::from_bits(N as u32),
        f32::from_bits(LEVELS as u32),
        0.0,
        0.0,
    ];
    let info = ctx.create_buffer_init("test", "info", bytemuck::cast_slice(&info), storage);
    let voxels =
        ctx.create_buffer_init("test", "grid", bytemuck::cast_slice(&grid.flat()), storage);
    let grid_buffers = [info, voxels];
    dispatch_cones(
        ctx,
        &pipeline,
        &layout,
        &[(0, &grid_buffers[0]), (1, &grid_buffers[1])],
        cones,
        results,
    )
}

/// Binds `buffers` plus the cones (binding 8) and `results` result slots (binding 9), runs
/// `pipeline` with one invocation per result and reads the results back.
fn dispatch_cones(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    layout: &wgpu::BindGroupLayout,
    buffers: &[(u32, &wgpu::Buffer)],
    cones: &[ConeMarch],
    results: usize,
) -> Vec<Vec4> {
    let storage = wgpu::BufferUsages::STORAGE;
    let gpu_cones: Vec<GpuCone> = cones
        .iter()
        .map(|c| GpuCone {
            origin: c.origin.extend(0.0).to_array(),
            dir: c.dir.extend(0.0).to_array(),
            params: c.params,
        })
        .collect();
    let cone_buffer =
        ctx.create_buffer_init("test", "cones", bytemuck::cast_slice(&gpu_cones), storage);
    let size = results as u64 * 16;
    let out = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("results"),
        size,
        usage: storage | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .map(|&(binding, b)| wgpu::BindGroupEntry {
            binding,
            resource: b.as_entire_binding(),
        })
        .collect();
    for (binding, b) in [(8, &cone_buffer), (9, &out)] {
        entries.push(wgpu::BindGroupEntry {
            binding,
            resource: b.as_entire_binding(),
        });
    }
    let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout,
        entries: &entries,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((results as u32).div_ceil(64), 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    let bytes = read_buffer(ctx, &out, 0, size).unwrap();
    bytemuck::cast_slice::<u8, [f32; 4]>(&bytes)
        .iter()
        .map(|v| Vec4::from_array(*v))
        .collect()
}

fn params(aperture: f32) -> ConeParams {
    ConeParams {
        aperture,
        start: 0.1,
        step: 0.5,
        max_distance: 1.7,
        voxel: VOXEL,
        stop_opacity: 0.98,
        max_steps: 128,
        max_footprint: 1e30,
    }
}

fn cones() -> Vec<ConeMarch> {
    let mut out = Vec::new();
    let origins = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(-0.31, 0.12, 0.07),
        Vec3::new(0.2, -0.35, 0.18),
    ];
    let dirs = [
        Vec3::X,
        Vec3::new(1.0, 0.3, -0.2),
        Vec3::new(-0.4, 1.0, 0.5),
        Vec3::new(0.2, -0.7, -1.0),
    ];
    for &origin in &origins {
        for &dir in &dirs {
            for aperture in [0.05f32, 0.6, 1.2] {
                out.push(ConeMarch {
                    origin,
                    dir: dir.normalize(),
                    params: params(aperture),
                });
            }
        }
    }
    out
}

/// The march's discrete decisions are off their boundaries for this grid and cone.
fn assert_decisions_are_clear(grid: &Grid, cone: &ConeMarch) {
    let c = &cone.params;
    let spread = 2.0 * (0.5 * c.aperture).tan();
    let (mut t, mut acc) = (c.start, Vec4::ZERO);
    for _ in 0..c.max_steps {
        assert!((t - c.max_distance).abs() > 1e-3, "{cone:?}: t = {t}");
        assert!(
            (acc.w - c.stop_opacity).abs() > 1e-3,
            "{cone:?}: opacity {}",
            acc.w
        );
        if t >= c.max_distance || acc.w >= c.stop_opacity {
            break;
        }
        let footprint = (spread * t).max(c.voxel);
        let step = c.step * footprint;
        let s = grid.sample(cone.origin + t * cone.dir, footprint);
        acc = octolux::gi::vct::cone::cone_composite(acc, s, step, footprint);
        t += step;
    }
}

#[test]
fn gpu_cones_equal_the_cpu_twin_through_known_grids() {
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let grids = [
        ("empty", Grid::new(|_, _, _| Vec4::ZERO)),
        (
            "half-filled medium",
            Grid::new(|_, y, _| {
                if y < N / 2 {
                    Vec4::new(0.3, 0.15, 0.05, 0.25)
                } else {
                    Vec4::ZERO
                }
            }),
        ),
        (
            "opaque wall",
            Grid::new(|x, _, _| {
                if x == 6 {
                    Vec4::new(0.8, 0.4, 0.1, 1.0)
                } else {
                    Vec4::ZERO
                }
            }),
        ),
    ];
    let cones = cones();
    for (name, grid) in &grids {
        for cone in &cones {
            assert_decisions_are_clear(grid, cone);
        }
        let gpu = gpu_run(&ctx, grid, &cones, "main", cones.len());
        let mut nonzero = 0;
        for (cone, g) in cones.iter().zip(&gpu) {
            let cpu = march_cone(|p, f| grid.sample(p, f), cone);
            if cpu.w > 0.0 {
                nonzero += 1;
            }
            for k in 0..4 {
                assert!(
                    (g[k] - cpu[k]).abs() <= 1e-4 + 1e-4 * cpu[k].abs(),
                    "{name}: {cone:?}: GPU {g} CPU {cpu}"
                );
            }
        }
        if *name == "empty" {
            assert_eq!(nonzero, 0);
        } else {
            assert!(
                nonzero > cones.len() / 3,
                "{name}: {nonzero} cones saw something"
            );
        }
    }
    // A narrow cone straight into the one-voxel wall takes its colour, and most of its
    // opacity: trilinear samples of a wall one voxel thick are partly transparent, so about
    // a fifth leaks through (the thin-wall leak every voxel cone tracer has).
    let wall = &grids[2].1;
    let straight = march_cone(|p, f| wall.sample(p, f), &cones[0]);
    assert!(straight.w > 0.75, "{straight}");
    let colour = straight.truncate() / straight.w;
    assert!(
        (colour - Vec3::new(0.8, 0.4, 0.1)).abs().max_element() < 1e-4,
        "{straight}"
    );
}

#[test]
fn gpu_gather_equals_the_cpu_and_a_closed_uniform_shell_gives_pi_l() {
    // White furnace: the apex in a hollow at the centre of a grid that is opaque, emitting
    // radiance L, everywhere else. Every cone ends in fully opaque samples, so each sees L and
    // the gather gives pi L, whatever the normal (1e-4 relative: the opacity reaches 1 up to
    // the rounding of trilinear weights).
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let l = Vec3::new(0.5, 1.0, 2.0);
    let shell = Grid::new(|x, y, z| {
        let c = Vec3::new(x as f32, y as f32, z as f32) + Vec3::splat(0.5) - Vec3::splat(4.0);
        if c.length() < 1.8 {
            Vec4::ZERO
        } else {
            l.extend(1.0)
        }
    });
    let mut p = params(0.3);
    p.max_distance = 3.0;
    p.stop_opacity = 1.0;
    let normals = [
        Vec3::Y,
        Vec3::NEG_Z,
        Vec3::new(0.3, -0.8, 0.52).normalize(),
        Vec3::new(-0.9, 0.1, 0.42).normalize(),
    ];
    let apexes: Vec<ConeMarch> = normals
        .iter()
        .map(|&n| ConeMarch {
            origin: Vec3::new(0.01, -0.02, 0.015),
            dir: n,
            params: p,
        })
        .collect();
    let gpu = gpu_run(&ctx, &shell, &apexes, "gather", apexes.len());
    let pi_l = std::f32::consts::PI * l;
    for (apex, g) in apexes.iter().zip(&gpu) {
        let radiance: [Vec3; 6] = std::array::from_fn(|i| {
            let cone = ConeMarch {
                dir: diffuse_cone_dir(apex.dir, i),
                ..*apex
            };
            let r = march_cone(|q, f| shell.sample(q, f), &cone);
            // Opaque up to the rounding of trilinear weights (they sum to 1 within ulps);
            // what a cone adds after that is below 1e-5 of L on either side.
            assert!(
                r.w > 0.99999,
                "cone {i} around {} ends opaque: {r}",
                apex.dir
            );
            r.truncate()
        });
        let cpu = gather_irradiance(&radiance);
        assert!(
            (cpu - pi_l).abs().max_element() < 1e-4 * pi_l.max_element(),
            "{cpu}"
        );
        assert!(
            (g.truncate() - cpu).abs().max_element() < 1e-4 * pi_l.max_element(),
            "GPU {g} CPU {cpu}"
        );
    }
    // The cone directions themselves, GPU against CPU.
    let dirs = gpu_run(&ctx, &shell, &apexes, "directions", apexes.len() * 6);
    for (k, d) in dirs.iter().enumerate() {
        let cpu = diffuse_cone_dir(apexes[k / 6].dir, k % 6);
        assert!((d.truncate() - cpu).abs().max_element() < 1e-5, "{d} {cpu}");
    }
}

/// `kernel` (text importing the library's modules) with `structure` as the module
/// `gi/vct/structure` the marcher samples, and the six-cone set.
fn compose_kernel(kernel: &str, structure: &str) -> String {
    let cones = cone_set_wgsl(6);
    octolux::gpu::shader::compose_text(
        "cone test",
        kernel,
        &[],
        &[("gi/vct/cone_set", &cones), ("gi/vct/structure", structure)],
    )
    .unwrap()
}

const CLIPMAP_TEST_WGSL: &str = r#"
import octolux::voxel::clipmap::radiance_sample::clip_radiance_sample;

// The clipmap back-end of the marcher's sampling function.
fn vct_sample(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    return clip_radiance_sample(p, footprint);
}

"#;

#[test]
fn cones_through_a_lit_clipmap_equal_the_cpu_twin() {
    // The marcher over the clipmap's injected radiance (`clip_radiance_sample`): a floor lit
    // by a point light, cones from above it looking down at different apertures. The CPU twin
    // marches the radiance read back, through the CPU twin of the same sampler. Radiance is
    // stored as f16 and read back as stored, so both sides sample the same values; every
    // sample stays 0.1 m (3 voxels) inside level 0, far from the level-choice boundary.
    use octolux::voxel::clipmap::sample::{
        clip_radiance_sample, ClipInfo, CLIP_BINDINGS, CLIP_RADIANCE_BINDING,
    };
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let clipmap = lit_floor::lit_clipmap(&ctx, &lit_floor::floor());
    let settings = clipmap.settings;
    let radiance = clipmap.read_radiance(&ctx).unwrap();
    let info = ClipInfo::new(&clipmap.settings, &clipmap.origins);
    assert_eq!(
        clipmap.origins[0],
        Some(glam::IVec3::ZERO),
        "level 0 spans the unit box"
    );

    let mut cones = Vec::new();
    for (i, apex) in [
        Vec3::new(0.5, 0.55, 0.5),
        Vec3::new(0.3, 0.5, 0.62),
        Vec3::new(0.71, 0.6, 0.33),
    ]
    .into_iter()
    .enumerate()
    {
        for (j, dir) in [
            Vec3::NEG_Y,
            Vec3::new(0.3, -1.0, 0.1),
            Vec3::new(-0.2, -1.0, -0.35),
        ]
        .into_iter()
        .enumerate()
        {
            let aperture = [0.1f32, 0.5, 1.0][(i + j) % 3];
            cones.push(ConeMarch {
                origin: apex,
                dir: dir.normalize(),
                params: ConeParams {
                    aperture,
                    start: 0.02,
                    step: 0.5,
                    max_distance: 0.3 + 0.0123 * j as f32,
                    voxel: settings.voxel_size,
                    stop_opacity: 0.95,
                    max_steps: 256,
                    max_footprint: 1e30,
                },
            });
        }
    }
    let sample = |p: Vec3, f: f32| {
        assert!(
            p.cmpge(Vec3::splat(0.1)).all() && p.cmple(Vec3::splat(0.9)).all(),
            "sample at {p} leaves the inner part of level 0"
        );
        clip_radiance_sample(&info, &radiance, p, f)
    };
    let cpu: Vec<Vec4> = cones.iter().map(|c| march_cone(sample, c)).collect();
    for (cone, r) in cones.iter().zip(&cpu) {
        // Off the march's decision boundaries (see the file's header).
        let p = &cone.params;
        let spread = 2.0 * (0.5 * p.aperture).tan();
        let (mut t, mut acc) = (p.start, Vec4::ZERO);
        while t < p.max_distance && acc.w < p.stop_opacity {
            let footprint = (spread * t).max(p.voxel);
            acc = octolux::gi::vct::cone::cone_composite(
                acc,
                sample(cone.origin + t * cone.dir, footprint),
                p.step * footprint,
                footprint,
            );
            t += p.step * footprint;
            assert!((t - p.max_distance).abs() > 1e-4 && (acc.w - p.stop_opacity).abs() > 1e-4);
        }
        assert_eq!(acc, *r);
    }
    assert!(
        cpu.iter().filter(|r| r.w > 0.2).count() >= 6,
        "most cones reach the floor: {cpu:?}"
    );

    let module = ctx.shader(
        "cone clipmap test",
        &compose_kernel(CONE_KERNEL_WGSL, CLIPMAP_TEST_WGSL),
    );
    let pipeline = ctx.compute_pipeline("cone clipmap test", &module, "main");
    let info_buffer = ctx.create_buffer_init(
        "test",
        "info",
        bytemuck::bytes_of(&info),
        wgpu::BufferUsages::STORAGE,
    );
    let layout = pipeline.get_bind_group_layout(0);
    // (the albedo voxels are declared by the sampler but unused here)
    let radiance_buffer = clipmap.radiance.as_ref().unwrap();
    let gpu = dispatch_cones(
        &ctx,
        &pipeline,
        &layout,
        &[
            (CLIP_BINDINGS, &info_buffer),
            (CLIP_RADIANCE_BINDING, radiance_buffer),
        ],
        &cones,
        cones.len(),
    );
    let scale = cpu.iter().map(|r| r.max_element()).fold(0.0f32, f32::max);
    for ((cone, g), c) in cones.iter().zip(&gpu).zip(&cpu) {
        let g = *g;
        assert!(
            (g - *c).abs().max_element() <= 1e-5 * scale + 1e-4 * c.abs().max_element(),
            "{cone:?}: GPU {g} CPU {c}"
        );
    }
}

/// Per item and cone a value whose sum depends on its order: an integer below 1001 times 2^26
/// for every third cone, times 2^0 to 2^7 for the others (each exact in f32, so the CPU
/// computes the same values), summed in f32.
const LANE_SUM_WGSL: &str = r#"
import octolux::gi::vct::cone_lanes::{
    first_lane, gather_item, keep_cone, lane_cone, sum_item_cones,
};
import octolux::gi::vct::cone_set::{CONES_PER_LANE, DIFFUSE_CONES};

@group(0) @binding(0) var<storage, read_write> sums: array<vec4<f32>>;

fn cone_value(item: u32, k: u32) -> vec4<f32> {
    let x = f32((item * 7919u + k * 104729u) % 1000u + 1u);
    let e = select((k * 5u + item) % 8u, 26u, k % 3u == 0u);
    return vec4<f32>(x * exp2(f32(e)), x, f32(k), 1.0);
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let item = gather_item(wg.x, li);
    for (var j = 0u; j < CONES_PER_LANE; j++) {
        let k = lane_cone(li, j);
        if k < DIFFUSE_CONES {
            keep_cone(li, k, cone_value(item, k));
        }
    }
    let sum = sum_item_cones(li);
    if first_lane(li) {
        sums[item] = sum;
    }
}
"#;

#[test]
fn cone_lanes_sum_every_cone_of_an_item_in_cone_order() {
    // The gathers spread an item's cones over lanes and sum them in the first lane; the sum
    // must equal the loop over the cones in cone order, bit for bit (small values added
    // to large ones round away in one order and not in another), for every lane layout the cone counts give.
    use octolux::gi::vct::gather::{cone_lanes, cones_per_lane};
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    for cones in [6u32, 8, 16, 33, 64] {
        let module = ctx.shader(
            "cone lanes test",
            &octolux::gpu::shader::compose_text(
                "cone lanes test",
                LANE_SUM_WGSL,
                &[],
                &[("gi/vct/cone_set", &cone_set_wgsl(cones))],
            )
            .unwrap(),
        );
        let pipeline = ctx.compute_pipeline("cone lanes test", &module, "main");
        let (groups, items_per_group) = (5u32, 64 / cone_lanes(cones));
        let items = groups * items_per_group;
        let size = items as u64 * 16;
        let out = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sums"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: out.as_entire_binding(),
            }],
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(groups, 1, 1);
        }
        ctx.queue.submit([encoder.finish()]);
        let bytes = read_buffer(&ctx, &out, 0, size).unwrap();
        let sums: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
        let value = |item: u32, k: u32| {
            let x = ((item * 7919 + k * 104729) % 1000 + 1) as f32;
            let e = if k.is_multiple_of(3) {
                26
            } else {
                (k * 5 + item) % 8
            };
            [x * 2f32.powi(e as i32), x, k as f32, 1.0]
        };
        let mut reordered = 0;
        for item in 0..items {
            let mut serial = [0.0f32; 4];
            for k in 0..cones {
                let v = value(item, k);
                for c in 0..4 {
                    serial[c] += v[c];
                }
            }
            // Another order: smallest first.
            let mut firsts: Vec<f32> = (0..cones).map(|k| value(item, k)[0]).collect();
            firsts.sort_by(f32::total_cmp);
            let smallest_first: f32 = firsts.iter().sum();
            assert_eq!(
                sums[item as usize].map(f32::to_bits),
                serial.map(f32::to_bits),
                "{cones} cones ({} lanes of {}), item {item}",
                cone_lanes(cones),
                cones_per_lane(cones)
            );
            reordered += (smallest_first != serial[0]) as u32;
        }
        // The case can fail: for some items another order (smallest first) gives another sum.
        assert!(
            reordered > 0,
            "{cones} cones: no item's sum depends on the order"
        );
    }
}
