//! No per-frame growth of the voxel structures' per-frame work: the octree's dynamic update
//! with moving geometry, its light injection, an octree rebuild, and the clipmap's incremental
//! update for a moving camera with its light injection, repeated many times. After warm-up the
//! process's resident memory, wgpu's count of live objects and the memory ledger stay flat.
//!
//! This binary holds one test on purpose: resident memory is a property of the process, so no
//! other test may run beside it.

mod growth;
use glam::{Mat4, Vec3};
use growth::snapshot;
use octolux::frame::{GpuLight, LayerView, ShadowLookupBuffers};
use octolux::gpu::{GpuContext, GpuOptions, PassTimer};
use octolux::scene::{Light, LightKind};
use octolux::voxel::clipmap::{Clipmap, ClipmapOptions, ClipmapSettings};
use octolux::voxel::svo::dynamic::DynamicReserve;
use octolux::voxel::svo::SvoBuilder;
use octolux::voxel::{VoxelGrid, VoxelTriangle};
use std::f32::consts::TAU;

/// Frames of one period of the motion (camera, moving block, lights): the work of frame `f`
/// and of frame `f + PERIOD` is the same, so the ledger (which keeps the size of the last
/// update's scratch) can be compared exactly.
const PERIOD: usize = 4;
/// Frames run before the baseline is taken (pipelines, caches and allocator pools fill).
const WARMUP: usize = PERIOD;
/// Frames run after the baseline.
const MEASURED: usize = 3 * PERIOD;
/// Allowed growth of resident memory over the measured frames of one part. Mesa's lavapipe
/// compiles and keeps a shader variant whenever a pipeline whose branches or loop bounds depend
/// on a small uniform block is bound: with its parameters in a uniform block, the octree's
/// light injection (two dispatches per frame, a loop over the lights) grew by 16.3 MiB over 12
/// frames here. With every parameter block in a storage buffer no part moves by 0.1 MiB.
const RSS_SLACK_MIB: f64 = 1.0;

fn tri(a: Vec3, b: Vec3, c: Vec3, albedo: [u8; 3], emission: Vec3) -> VoxelTriangle {
    VoxelTriangle {
        positions: [a, b, c],
        albedo,
        normal: (b - a).cross(c - a).normalize_or(Vec3::Y),
        emission,
    }
}

/// An axis-aligned box from `lo` to `hi` (12 triangles).
fn cube(lo: Vec3, hi: Vec3, albedo: [u8; 3]) -> Vec<VoxelTriangle> {
    let p = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let faces = [
        [0, 2, 6, 4],
        [1, 5, 7, 3],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 6, 7, 5],
    ];
    faces
        .iter()
        .flat_map(|f| {
            [
                tri(p(f[0]), p(f[1]), p(f[2]), albedo, Vec3::ZERO),
                tri(p(f[0]), p(f[2]), p(f[3]), albedo, Vec3::ZERO),
            ]
        })
        .collect()
}

/// A floor, an emissive back wall and a slanted triangle in the unit cube.
fn static_scene() -> Vec<VoxelTriangle> {
    let grey = [200, 200, 200];
    let mut tris = vec![
        tri(
            Vec3::new(0.05, 0.1, 0.05),
            Vec3::new(0.95, 0.1, 0.05),
            Vec3::new(0.95, 0.1, 0.95),
            grey,
            Vec3::ZERO,
        ),
        tri(
            Vec3::new(0.05, 0.1, 0.05),
            Vec3::new(0.95, 0.1, 0.95),
            Vec3::new(0.05, 0.1, 0.95),
            grey,
            Vec3::ZERO,
        ),
        tri(
            Vec3::new(0.3, 0.2, 0.4),
            Vec3::new(0.7, 0.8, 0.5),
            Vec3::new(0.4, 0.6, 0.8),
            [30, 220, 40],
            Vec3::new(0.5, 0.2, 0.1),
        ),
    ];
    tris.extend(cube(
        Vec3::new(0.05, 0.1, 0.9),
        Vec3::new(0.95, 0.9, 0.93),
        [220, 30, 30],
    ));
    tris
}

/// Phase of frame `f` in the motion, in [0, 1).
fn phase(f: usize) -> f32 {
    (f % PERIOD) as f32 / PERIOD as f32
}

/// The moving block of frame `f`.
fn moving(f: usize) -> Vec<VoxelTriangle> {
    let a = TAU * phase(f);
    let at = Vec3::new(
        0.4 + 0.2 * a.cos(),
        0.3 + 0.1 * a.sin(),
        0.4 + 0.2 * a.sin(),
    );
    cube(at, at + Vec3::new(0.17, 0.13, 0.11), [40, 90, 250])
}

/// A spot light and a sun, the spot moving with the frame.
fn scene_lights(f: usize) -> Vec<Light> {
    let a = TAU * phase(f);
    vec![
        Light {
            name: "spot".into(),
            kind: LightKind::Spot {
                inner_angle: 0.5,
                outer_angle: 0.7,
            },
            color: Vec3::ONE,
            intensity: 2.0,
            position: Vec3::new(0.5 + 0.1 * a.cos(), 1.2, 0.5 + 0.1 * a.sin()),
            direction: Vec3::NEG_Y,
            animation: None,
        },
        Light {
            name: "sun".into(),
            kind: LightKind::Directional,
            color: Vec3::ONE,
            intensity: 0.5,
            position: Vec3::ZERO,
            direction: Vec3::new(0.2, -1.0, 0.3).normalize(),
            animation: None,
        },
    ]
}

/// The same lights as the renderer uploads them for the octree's injection: the spot through
/// shadow layer 0 (perspective), the sun through layer 1 (orthographic).
fn gpu_lights(f: usize) -> Vec<GpuLight> {
    let [spot, sun] = &scene_lights(f)[..] else {
        unreachable!("two lights")
    };
    vec![
        GpuLight {
            shadow_view: 0,
            shadow_texel: 0.004,
            ..GpuLight::unshadowed(spot)
        },
        GpuLight {
            shadow_view: 1,
            shadow_texel: 0.003,
            shadow_orthographic: 1,
            ..GpuLight::unshadowed(sun)
        },
    ]
}

/// The clipmap's camera in frame `f`: a circle of about 2.5 finest voxels per frame.
fn camera(f: usize) -> Vec3 {
    let a = TAU * phase(f);
    Vec3::new(0.5 + 0.2 * a.cos(), 0.45, 0.5 + 0.2 * a.sin())
}

/// The parts of a frame's voxel work, measured one after the other.
#[derive(Clone, Copy, Debug)]
enum Part {
    OctreeUpdate,
    /// The wait-free form of the update, recorded into the frame's timer.
    OctreeRecord,
    OctreeInject,
    OctreeRebuild,
    ClipmapUpdate,
    ClipmapInject,
}

impl Part {
    const ALL: [Part; 6] = [
        Part::OctreeUpdate,
        Part::OctreeRecord,
        Part::OctreeInject,
        Part::OctreeRebuild,
        Part::ClipmapUpdate,
        Part::ClipmapInject,
    ];
}

#[test]
fn voxel_updates_do_not_grow_from_frame_to_frame() {
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    assert!(
        ctx.resource_counts().is_some(),
        "wgpu reports its live objects"
    );
    let builder = SvoBuilder::new(&ctx);
    let grid = VoxelGrid::new(Vec3::ZERO, 1.0 / 32.0, 32).unwrap();
    let statics = static_scene();
    let (mut svo, _) = builder
        .build_with_reserve(&ctx, &grid, &statics, DynamicReserve::new(20_000))
        .unwrap();
    // Shadow maps stand-in: two cleared depth layers with fixed matrices (what is sampled
    // does not matter here, only that injection runs as in a frame).
    let shadow = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("test shadow maps"),
        size: wgpu::Extent3d {
            width: 64,
            height: 64,
            depth_or_array_layers: 2,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Depth32Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let spot = Mat4::perspective_rh(1.5, 1.0, 0.05, 3.0)
        * Mat4::look_at_rh(Vec3::new(0.5, 1.2, 0.5), Vec3::new(0.5, 0.0, 0.5), Vec3::Z);
    let sun = Mat4::orthographic_rh(-1.0, 1.0, -1.0, 1.0, 0.1, 4.0)
        * Mat4::look_at_rh(Vec3::new(0.2, 2.0, 0.8), Vec3::splat(0.5), Vec3::Z);
    let layers = [
        LayerView {
            view_proj: spot,
            raster_view_proj: spot,
            texel: 0.004,
            extent: 0.004 * 64.0,
            orthographic: false,
            sky_layer: None,
            depth_range: 0.0,
        },
        LayerView {
            view_proj: sun,
            raster_view_proj: sun,
            texel: 0.003,
            extent: 0.003 * 64.0,
            orthographic: true,
            sky_layer: None,
            depth_range: 0.0,
        },
    ];
    let shadows = ShadowLookupBuffers::new(&ctx, "test", &shadow, &layers);
    let lights = ctx.create_buffer_init(
        "test",
        "lights",
        bytemuck::cast_slice(&gpu_lights(0)),
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
    );
    let settings = ClipmapSettings {
        resolution: 16,
        levels: 3,
        voxel_size: 1.0 / 32.0,
    };
    let options = ClipmapOptions {
        filtered: true,
        anisotropic: true,
    };
    let mut clipmap = Clipmap::with_options(&ctx, settings, options).unwrap();

    // The per-frame work, part by part.
    let mut run = |part: Part, f: usize| {
        let block = moving(f);
        let all: Vec<VoxelTriangle> = statics.iter().chain(&block).copied().collect();
        let mut timer = PassTimer::new(&ctx);
        match part {
            Part::OctreeUpdate => {
                builder.update_dynamic(&ctx, &mut svo, &block).unwrap();
            }
            Part::OctreeRecord => {
                builder
                    .record_dynamic(&ctx, &mut timer, &mut svo, &block)
                    .unwrap();
            }
            Part::OctreeInject => {
                ctx.queue
                    .write_buffer(&lights, 0, bytemuck::cast_slice(&gpu_lights(f)));
                builder
                    .inject(&ctx, &mut timer, &svo, shadows.lookup(), &lights, 2)
                    .unwrap();
            }
            Part::OctreeRebuild => {
                builder.build(&ctx, &grid, &all).unwrap();
            }
            Part::ClipmapUpdate => {
                clipmap.update(&ctx, &mut timer, &all, camera(f)).unwrap();
            }
            Part::ClipmapInject => {
                clipmap
                    .inject(&ctx, &mut timer, &scene_lights(f), 64)
                    .unwrap();
            }
        }
        timer.finish_frame().unwrap();
    };
    for f in 0..WARMUP {
        for part in Part::ALL {
            run(part, f);
        }
    }
    let mut failures = Vec::new();
    for part in Part::ALL {
        let start = std::time::Instant::now();
        let before = snapshot(&ctx);
        for f in WARMUP..WARMUP + MEASURED {
            run(part, f);
        }
        let after = snapshot(&ctx);
        let rss = match (before.rss, after.rss) {
            (Some(a), Some(b)) => format!("resident {a:.1} -> {b:.1} MiB"),
            _ => "resident memory unknown".into(),
        };
        println!(
            "{part:?}: {rss} over {MEASURED} frames ({:.2} s); {:?}",
            start.elapsed().as_secs_f64(),
            after.counts
        );
        if before.counts != after.counts {
            failures.push(format!(
                "{part:?}: wgpu objects alive {:?} -> {:?}",
                before.counts, after.counts
            ));
        }
        if before.ledger != after.ledger {
            failures.push(format!(
                "{part:?}: ledger {} -> {} bytes",
                before.ledger, after.ledger
            ));
        }
        if let (Some(a), Some(b)) = (before.rss, after.rss) {
            if b - a > RSS_SLACK_MIB {
                failures.push(format!(
                    "{part:?}: resident memory grew by {:.1} MiB over {MEASURED} frames",
                    b - a
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
