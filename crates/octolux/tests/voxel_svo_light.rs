//! Light injection into the sparse voxel octree: lit floor voxels against the closed form
//! albedo/pi x I cos / r^2 of a point light (visibility from the renderer's shadow maps),
//! voxels in an occluder's shadow, emission carried into radiance, and every radiance mip
//! level against the CPU mip filter of the injected leaf voxels; the radiance's facing
//! (`SvoBuilder::with_facing`) against its CPU twin, on a wall thinner than a voxel and in a
//! dynamic part, and its sampler against the CPU sampler.

use crate::common::{context, run_probe};
use glam::{IVec3, Mat4, Vec3, Vec4};
use octolux::frame::{GpuLight, LayerView, ShadowLookupBuffers};
use octolux::gpu::{GpuContext, PassTimer};
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::{Camera, Light, LightKind, Material, Mesh, Object, Scene};
use octolux::voxel::svo::{Svo, SvoBuilder, SvoCpu};
use octolux::voxel::{cpu, scene_triangles, VoxelGrid, VoxelTriangle};
use std::collections::BTreeMap;

/// Node indices of level `d`, static then dynamic.
fn level_nodes(svo: &Svo, d: usize) -> impl Iterator<Item = u32> {
    let (s0, s1) = svo.levels()[d];
    let (d0, d1) = svo.dynamic_levels().get(d).copied().unwrap_or((0, 0));
    (s0..s1).chain(d0..d1)
}

/// Leaf voxel radiance by voxel coordinates (occupied voxels only; static and dynamic leaves).
fn voxel_map(svo: &Svo, cpu_svo: &SvoCpu, ctx: &GpuContext) -> BTreeMap<[u32; 3], Vec4> {
    let radiance = svo.read_voxel_radiance(ctx).unwrap();
    let coords = cpu_svo.coordinates();
    let leaf = svo.levels().len() - 1;
    let mut out = BTreeMap::new();
    // Radiance slots: static leaves in order, then dynamic leaves in order.
    for (slot, n) in level_nodes(svo, leaf).enumerate() {
        let c = coords[n as usize];
        for o in 0..8u32 {
            let v = radiance[slot * 8 + o as usize];
            if v.w > 0.0 {
                out.insert(
                    [
                        2 * c[0] + (o & 1),
                        2 * c[1] + ((o >> 1) & 1),
                        2 * c[2] + (o >> 2),
                    ],
                    v,
                );
            }
        }
    }
    out
}

/// Largest difference between the radiance bricks of every level and the CPU lattices of the
/// leaf voxels' radiance, relative to the largest lattice value.
fn mip_error(svo: &Svo, cpu_svo: &SvoCpu, ctx: &GpuContext) -> f32 {
    let voxels = voxel_map(svo, cpu_svo, ctx);
    let bricks = svo.read_radiance(ctx).unwrap();
    lattice_error(svo, cpu_svo, &voxels, &bricks)
}

/// Largest difference between `bricks` (every level's) and the CPU lattices of the leaf
/// values `voxels`, relative to the largest lattice component.
fn lattice_error(
    svo: &Svo,
    cpu_svo: &SvoCpu,
    voxels: &BTreeMap<[u32; 3], Vec4>,
    bricks: &[[Vec4; 27]],
) -> f32 {
    let depth = svo.grid().depth();
    let lattices = cpu::lattices(depth, voxels);
    let coords = cpu_svo.coordinates();
    let scale = lattices
        .iter()
        .flat_map(|l| l.values.iter())
        .map(|v| v.abs().max_element())
        .fold(0.0f32, f32::max)
        .max(1e-6);
    let mut worst = 0.0f32;
    for (d, lattice) in lattices.iter().enumerate() {
        for n in level_nodes(svo, d) {
            let b = cpu_svo.brick_of[n as usize];
            if b == 0 {
                continue;
            }
            let c = IVec3::from_array(coords[n as usize].map(|x| x as i32));
            for t in 0..27 {
                let i = IVec3::new(t % 3, (t / 3) % 3, t / 9);
                let want = lattice.get(2 * c + i);
                let got = bricks[b as usize - 1][t as usize];
                worst = worst.max((want - got).abs().max_element() / scale);
            }
        }
    }
    worst
}

fn quad(name: &str, corners: [Vec3; 4], material: u32) -> Mesh {
    let n = (corners[1] - corners[0])
        .cross(corners[2] - corners[0])
        .normalize();
    Mesh {
        name: name.into(),
        positions: corners.to_vec(),
        normals: vec![n; 4],
        uvs: vec![glam::Vec2::ZERO; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
    }
}

/// A grey floor (half-size 1, y = 0, normal +y), a small occluder square at y = 0.6 over
/// x in [0.3, 0.7], z in [-0.2, 0.2], and a point light at (0, 1.2, 0).
fn shadow_scene() -> Scene {
    let floor = quad(
        "floor",
        [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, -1.0),
        ],
        0,
    );
    let occluder = quad(
        "occluder",
        [
            Vec3::new(0.3, 0.6, -0.2),
            Vec3::new(0.3, 0.6, 0.2),
            Vec3::new(0.7, 0.6, 0.2),
            Vec3::new(0.7, 0.6, -0.2),
        ],
        0,
    );
    Scene {
        name: "shadow".into(),
        meshes: vec![floor, occluder],
        materials: vec![Material {
            base_color: Vec3::splat(0.5),
            ..Material::default()
        }],
        textures: vec![],
        objects: vec![Object {
            name: "all".into(),
            meshes: vec![0, 1],
            transform: Mat4::IDENTITY,
            animation: None,
        }],
        lights: vec![Light {
            name: "lamp".into(),
            kind: LightKind::Point,
            color: Vec3::ONE,
            intensity: 2.0,
            position: Vec3::new(0.0, 1.2, 0.0),
            direction: Vec3::NEG_Y,
            animation: None,
        }],
        cameras: vec![Camera {
            position: Vec3::new(0.0, 2.0, 2.0),
            target: Vec3::ZERO,
            near: 0.05,
            far: 10.0,
            ..Camera::default()
        }],
        exposure: 0.0,
        sky: None,
        requests: vec![],
    }
}

/// The six cube-face layers the renderer fits to a point light (`render/shadow.rs`).
fn point_layers(light: Vec3, bounds: (Vec3, Vec3), size: u32) -> Vec<LayerView> {
    let (lo, hi) = bounds;
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let far = (light - centre).length() + radius;
    let (near, far) = ((far * 1e-3).max(1e-3), far * 1.01);
    let half = (1.0 + 6.0 / size as f32).atan();
    let faces = [
        (Vec3::X, Vec3::NEG_Y),
        (Vec3::NEG_X, Vec3::NEG_Y),
        (Vec3::Y, Vec3::Z),
        (Vec3::NEG_Y, Vec3::NEG_Z),
        (Vec3::Z, Vec3::NEG_Y),
        (Vec3::NEG_Z, Vec3::NEG_Y),
    ];
    faces
        .iter()
        .map(|&(dir, up)| {
            let view = Mat4::look_at_rh(light, light + dir, up);
            let proj = Mat4::perspective_rh(2.0 * half, 1.0, near, far);
            LayerView {
                view_proj: proj * view,
                raster_view_proj: proj * view,
                texel: 2.0 * half.tan() / size as f32,
                extent: 2.0 * half.tan(),
                orthographic: false,
                sky_layer: None,
                depth_range: 0.0,
            }
        })
        .collect()
}

fn storage_init(ctx: &GpuContext, label: &str, words: &[f32]) -> wgpu::Buffer {
    ctx.create_buffer_init(
        "test",
        label,
        bytemuck::cast_slice(words),
        wgpu::BufferUsages::STORAGE,
    )
}

/// The renderer's shadow maps of `scene`'s first light (a point light) and a one-light buffer
/// for the injection (`frame/lights.wgsl`'s `Light`), with the texel of its layers.
fn point_light_shadows(
    ctx: &GpuContext,
    scene: &Scene,
    size: u32,
) -> (Renderer, Vec<LayerView>, wgpu::Buffer) {
    let mut renderer = Renderer::new(
        ctx,
        scene,
        RenderSettings {
            width: 16,
            height: 16,
            shadow_map_size: size,
            gi: "none".into(),
            ..RenderSettings::default()
        },
    )
    .unwrap();
    renderer.render(scene, 0.0).unwrap();
    let light = &scene.lights[0];
    let layers = point_layers(light.position, scene.bounds_at(0.0), size);
    let texel = layers[0].texel;
    // The point light with its shadow views from 0 (perspective), as the renderer uploads it.
    let gpu = GpuLight {
        shadow_view: 0,
        shadow_texel: texel,
        ..GpuLight::unshadowed(light)
    };
    let lights = storage_init(ctx, "lights", bytemuck::cast_slice(&[gpu]));
    (renderer, layers, lights)
}

#[test]
fn lit_floor_matches_the_point_light_closed_form_and_the_occluder_casts_a_shadow() {
    let ctx = context();
    let scene = shadow_scene();
    let size = 512;
    let (renderer, layers, lights) = point_light_shadows(&ctx, &scene, size);
    let light = &scene.lights[0];
    let radiant = light.radiant();
    // 32^3 voxels of 2.5/32 m; the floor plane y = 0 passes through the centres of voxel
    // layer 8, so the floor is one voxel thick and its voxel centres lie on the surface.
    let res = 32;
    let vs = 2.5 / res as f32;
    let grid = VoxelGrid::new(Vec3::new(-1.25, -8.5 * vs, -1.25), vs, res).unwrap();
    let frame = scene.frame(0.0, 0);
    let tris = scene_triangles(&scene, &frame);
    let builder = SvoBuilder::new(&ctx);
    let (svo, _) = builder.build(&ctx, &grid, &tris).unwrap();
    let mut timer = PassTimer::new(&ctx);
    let shadows = ShadowLookupBuffers::new(&ctx, "test", renderer.shadow_maps().texture(), &layers);
    builder
        .inject(&ctx, &mut timer, &svo, shadows.lookup(), &lights, 1)
        .unwrap();
    let timings = timer.finish_frame().unwrap();
    let cpu_svo = svo.read_back(&ctx).unwrap();
    let voxels = voxel_map(&svo, &cpu_svo, &ctx);
    let albedo = 128.0 / 255.0; // 0.5 quantised to 8 bits
    let mut lit_worst = 0.0f32;
    let mut lit_count = 0;
    let mut shadow_worst = 0.0f32;
    let mut shadow_count = 0;
    for (v, value) in &voxels {
        if v[1] != 8 {
            continue;
        }
        let p = grid.origin + (Vec3::from_array(v.map(|c| c as f32)) + 0.5) * vs;
        let d = light.position - p;
        let r2 = d.length_squared();
        let cos = d.y / r2.sqrt();
        let want = albedo / std::f32::consts::PI * radiant.x * cos / r2;
        if p.x.abs() < 0.5 && p.z.abs() < 0.5 {
            lit_worst = lit_worst.max((value.x - want).abs() / want);
            lit_count += 1;
        }
        // Umbra of the occluder: x in [0.6, 1.4], |z| < 0.4 on the floor.
        if (0.7..0.95).contains(&p.x) && p.z.abs() < 0.3 {
            shadow_worst = shadow_worst.max(value.x / want);
            shadow_count += 1;
        }
    }
    let inject_ms: f64 = timings
        .iter()
        .filter(|t| t.name.starts_with("svo inject") || t.name.starts_with("svo radiance"))
        .map(|t| t.ms)
        .sum();
    let mip = mip_error(&svo, &cpu_svo, &ctx);
    println!(
        "lit voxels {lit_count}: worst relative error {lit_worst:.2e}; shadowed voxels \
         {shadow_count}: worst radiance / unshadowed {shadow_worst:.3}; mip error {mip:.2e}; \
         inject + mip {inject_ms:.3} ms"
    );
    assert!(lit_count > 100 && shadow_count > 6);
    // The voxel centres lie on the surface, so the only errors are f16 storage (< 0.1%) and
    // the PCF visibility of fully lit voxels: 2% bounds both.
    assert!(lit_worst < 0.02, "lit floor error {lit_worst}");
    assert!(shadow_worst < 0.1, "shadowed voxels keep {shadow_worst}");
    assert!(mip < 4e-3, "radiance mip error {mip}");
}

/// An emissive triangle and a thin non-emissive one, in the unit cube.
fn emissive_triangles() -> Vec<VoxelTriangle> {
    let emission = Vec3::new(3.0, 0.5, 0.25);
    let make = |a: Vec3, b: Vec3, c: Vec3, e: Vec3| VoxelTriangle {
        positions: [a, b, c],
        albedo: [200, 100, 50],
        normal: (b - a).cross(c - a).normalize_or(Vec3::Y),
        emission: e,
    };
    vec![
        make(
            Vec3::new(0.2, 0.53, 0.2),
            Vec3::new(0.8, 0.53, 0.2),
            Vec3::new(0.2, 0.53, 0.8),
            emission,
        ),
        make(
            Vec3::new(0.3, 0.1, 0.3),
            Vec3::new(0.3, 0.9, 0.3),
            Vec3::new(0.31, 0.1, 0.7),
            Vec3::ZERO,
        ),
    ]
}

/// A 16^3 octree of [`emissive_triangles`], injected without lights.
fn emissive_octree(ctx: &GpuContext) -> (VoxelGrid, Vec<VoxelTriangle>, Svo) {
    let ctx = ctx.clone();
    let res = 16;
    let grid = VoxelGrid::new(Vec3::ZERO, 1.0 / res as f32, res).unwrap();
    let tris = emissive_triangles();
    let builder = SvoBuilder::new(&ctx);
    let (svo, _) = builder.build(&ctx, &grid, &tris).unwrap();
    inject_nothing(&ctx, &builder, &svo);
    (grid, tris, svo)
}

fn inject_nothing(ctx: &GpuContext, builder: &SvoBuilder, svo: &Svo) {
    let ctx = ctx.clone();
    // No lights: a one-layer depth array and a one-light buffer that is not read.
    let shadows = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("no shadows"),
        size: wgpu::Extent3d {
            width: 4,
            height: 4,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Depth32Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let lights = storage_init(
        &ctx,
        "no lights",
        bytemuck::cast_slice(&[GpuLight::default()]),
    );
    let mut timer = PassTimer::new(&ctx);
    let shadows = ShadowLookupBuffers::new(&ctx, "test", &shadows, &[]);
    builder
        .inject(&ctx, &mut timer, svo, shadows.lookup(), &lights, 0)
        .unwrap();
    timer.finish_frame().unwrap();
}

#[test]
fn emission_is_carried_into_radiance_and_mipmapped() {
    let ctx = context();
    let (grid, tris, svo) = emissive_octree(&ctx);
    check_emission(&ctx, &grid, &tris, &svo);
}

/// Every occupied voxel of `svo` (lit by nothing) holds the mean emission of the fragments of
/// `tris` in it, the radiance mips are the CPU filter of those voxels, and the root holds
/// emission.
fn check_emission(ctx: &GpuContext, grid: &VoxelGrid, tris: &[VoxelTriangle], svo: &Svo) {
    let (ctx, grid) = (ctx.clone(), *grid);
    let emission = tris.iter().map(|t| t.emission.x).fold(0.0, f32::max);
    let cpu_svo = svo.read_back(&ctx).unwrap();
    let voxels = voxel_map(svo, &cpu_svo, &ctx);
    // The CPU voxel emission: the mean of the touching fragments' emission.
    let fragments = cpu::voxelize(&grid, tris);
    let mut sums: BTreeMap<[u32; 3], (Vec3, u32)> = BTreeMap::new();
    for (v, t) in &fragments {
        let s = sums.entry(*v).or_insert((Vec3::ZERO, 0));
        s.0 += tris[*t as usize].emission;
        s.1 += 1;
    }
    assert_eq!(sums.len(), voxels.len());
    let mut worst = 0.0f32;
    for (v, (e, n)) in &sums {
        let want = *e / *n as f32;
        let got = voxels.get(v).copied().unwrap_or(Vec4::ZERO);
        assert_eq!(got.w, 1.0);
        worst = worst.max((got.truncate() - want).abs().max_element() / emission);
    }
    let mip = mip_error(svo, &cpu_svo, &ctx);
    println!("emission worst error {worst:.2e} (of the largest), mip error {mip:.2e}");
    // f16 storage: 2^-11 relative.
    assert!(worst < 1e-3, "emission error {worst}");
    assert!(mip < 4e-3, "radiance mip error {mip}");
    // The coarsest level still holds emission (the root brick is not zero).
    let root = cpu_svo.brick_of[0];
    assert!(root != 0);
    let bricks = svo.read_radiance(&ctx).unwrap();
    assert!(bricks[root as usize - 1].iter().any(|t| t.x > 0.0));
}

#[test]
fn a_moving_emitter_in_the_dynamic_part_is_injected_with_the_static_part() {
    use octolux::voxel::svo::dynamic::DynamicReserve;
    let ctx = context();
    let (grid, tris, _) = emissive_octree(&ctx);
    // The slanted, non-emissive triangle is static; the emissive one moves down through it.
    // Built with the radiance's facing, which the dynamic leaves and levels carry too.
    let statics = vec![tris[1]];
    let builder = SvoBuilder::new(&ctx).with_facing(true);
    let (mut svo, _) = builder
        .build_with_reserve(&ctx, &grid, &statics, DynamicReserve::new(4096))
        .unwrap();
    for dy in [0.0, -0.2, -0.31] {
        let mut moving = tris[0];
        for p in &mut moving.positions {
            p.y += dy;
        }
        builder.update_dynamic(&ctx, &mut svo, &[moving]).unwrap();
        inject_nothing(&ctx, &builder, &svo);
        check_emission(&ctx, &grid, &[statics[0], moving], &svo);
        check_emission_facing(&ctx, &grid, &[statics[0], moving], &svo);
    }
}

/// The facing pool of `svo` (lit by nothing) against its CPU twin: every occupied voxel's
/// emission weight r + g + b times its mean normal (the sum of its fragments' snorm8
/// normals, as the GPU sums them), filtered up every level, static and dynamic nodes.
fn check_emission_facing(ctx: &GpuContext, grid: &VoxelGrid, tris: &[VoxelTriangle], svo: &Svo) {
    let cpu_svo = svo.read_back(ctx).unwrap();
    let voxels = voxel_map(svo, &cpu_svo, ctx);
    let mut normals: BTreeMap<[u32; 3], Vec3> = BTreeMap::new();
    for (v, t) in cpu::voxelize(grid, tris) {
        let n = (tris[t as usize].normal.clamp(Vec3::NEG_ONE, Vec3::ONE) * 127.0).round();
        *normals.entry(v).or_default() += n;
    }
    let facing: BTreeMap<[u32; 3], Vec4> = voxels
        .iter()
        .map(|(v, value)| {
            let n = normals[v];
            assert!(n.length() > 12.7, "voxel {v:?} has no dominant normal");
            let weight = value.x + value.y + value.z;
            (*v, (n.normalize() * weight).extend(0.0))
        })
        .collect();
    let bricks = svo.read_facing(ctx).unwrap().expect("built with facing");
    let error = lattice_error(svo, &cpu_svo, &facing, &bricks);
    println!("emission facing lattice error {error:.2e}");
    // f16 storage, as the radiance mip's bound.
    assert!(error < 4e-3, "facing lattice error {error}");
}

fn svo_info_buffer(ctx: &GpuContext, grid: &VoxelGrid, svo: &Svo) -> wgpu::Buffer {
    use octolux::voxel::svo::sample::SvoInfo;
    ctx.create_buffer_init(
        "test",
        "svo info",
        bytemuck::bytes_of(&SvoInfo::new(grid, svo.pool_bricks())),
        wgpu::BufferUsages::STORAGE,
    )
}

#[test]
fn gpu_radiance_samples_equal_the_cpu_twin() {
    use octolux::voxel::svo::sample::{svo_bindings, svo_radiance_bindings, svo_sample};
    let ctx = context();
    let (grid, _, svo) = emissive_octree(&ctx);
    let mut cpu_svo = svo.read_back(&ctx).unwrap();
    cpu_svo.bricks = svo.read_radiance(&ctx).unwrap();
    // The sampler's own bindings (`voxel/svo/sample.wgsl`, `radiance_sample.wgsl`) are bound
    // by the library's entries; the kernel adds its points and output.
    let kernel = "import octolux::voxel::svo::radiance_sample::svo_radiance_sample;
@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&points) {
        return;
    }
    let q = points[id.x];
    out[id.x] = svo_radiance_sample(q.xyz, q.w);
}
";
    // Points spread over the emitter's neighbourhood, footprints from a voxel to 8 voxels.
    let mut points = Vec::new();
    for i in 0..400u32 {
        let f = |k: u32| ((i * k) % 97) as f32 / 97.0;
        let p = Vec3::new(0.1 + 0.8 * f(31), 0.3 + 0.5 * f(57), 0.1 + 0.8 * f(71));
        let footprint = grid.voxel_size * (1.0 + 7.0 * f(13));
        points.push(p.extend(footprint));
    }
    let info = svo_info_buffer(&ctx, &grid, &svo);
    let mut bindings = svo_bindings(&info, &svo).to_vec();
    bindings.extend(svo_radiance_bindings(&svo));
    let gpu = run_probe(&ctx, kernel, bindings, &points, 1);
    let mut worst = 0.0f32;
    let mut nonzero = 0;
    for (q, g) in points.iter().zip(&gpu) {
        let c = svo_sample(&cpu_svo, &grid, q.truncate(), q.w);
        worst = worst.max((c - *g).abs().max_element());
        if c.x > 0.0 {
            nonzero += 1;
        }
    }
    println!("radiance samples: {nonzero} of 400 non-zero, worst GPU-CPU difference {worst:.2e}");
    assert!(nonzero > 100);
    // Radiance up to 3 W/(m^2 sr): 1e-4 relative, as for the albedo sampler.
    assert!(
        worst < 3e-4,
        "GPU and CPU radiance samples differ by {worst}"
    );
}

#[test]
fn gpu_facing_samples_equal_the_cpu_twin() {
    use octolux::voxel::facing::facing_toward;
    use octolux::voxel::svo::sample::{
        svo_bindings, svo_facing_bindings, svo_radiance_bindings, svo_sample,
    };
    let ctx = context();
    let (_, grid, svo) = lit_thin_wall_octree(&ctx);
    let vs = grid.voxel_size;
    let mut radiance = svo.read_back(&ctx).unwrap();
    radiance.bricks = svo.read_radiance(&ctx).unwrap();
    let mut facing = svo.read_back(&ctx).unwrap();
    facing.bricks = svo.read_facing(&ctx).unwrap().unwrap();
    let kernel = "import octolux::voxel::svo::radiance_sample::svo_radiance_facing_sample;
import octolux::voxel::facing::facing_toward;
@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x / 2u;
    if i >= arrayLength(&points) / 2u || id.x % 2u != 0u {
        return;
    }
    let q = points[2u * i];
    let s = svo_radiance_facing_sample(q.xyz, q.w);
    out[3u * i] = s.radiance;
    out[3u * i + 1u] = vec4<f32>(s.facing, 0.0);
    out[3u * i + 2u] = vec4<f32>(facing_toward(s.radiance, s.facing, points[2u * i + 1u].xyz));
}
";
    // Points around the wall and over the floor, footprints of 1 to 8 voxels, and the
    // directions of cones looking at the wall from either side, along it and at the floor.
    let dirs = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::new(1.0, -1.0, 0.5).normalize(),
        Vec3::NEG_Y,
        Vec3::Z,
    ];
    let mut points = Vec::new();
    for i in 0..400u32 {
        let f = |k: u32| ((i * k) % 97) as f32 / 97.0;
        let p = Vec3::new(-0.8 + 0.8 * f(31), -0.1 + 0.9 * f(57), -0.5 + f(71));
        points.push(p.extend(vs * (1.0 + 7.0 * f(13))));
        points.push(dirs[i as usize % dirs.len()].extend(0.0));
    }
    let info = svo_info_buffer(&ctx, &grid, &svo);
    let mut bindings = svo_bindings(&info, &svo).to_vec();
    bindings.extend(svo_radiance_bindings(&svo));
    bindings.extend(svo_facing_bindings(&svo).unwrap());
    let gpu = run_probe(&ctx, kernel, bindings, &points, 2);
    let (mut worst, mut worst_toward) = (0.0f32, 0.0f32);
    let (mut lit, mut partial) = (0, 0);
    for (q, g) in points.chunks_exact(2).zip(gpu.chunks_exact(3)) {
        let (p, dir) = (q[0].truncate(), q[1].truncate());
        let r = svo_sample(&radiance, &grid, p, q[0].w);
        let f = svo_sample(&facing, &grid, p, q[0].w);
        worst = worst.max(
            (r - g[0])
                .abs()
                .max_element()
                .max((f - g[1]).abs().max_element()),
        );
        let toward = facing_toward(r, f.truncate(), dir);
        if r.x > 1e-3 {
            lit += 1;
            worst_toward = worst_toward.max((toward - g[2].x).abs());
            partial += (toward < 0.9) as u32;
        }
    }
    println!(
        "facing samples: {lit} of 400 lit, {partial} of them partly facing away; worst GPU-CPU \
         difference {worst:.2e}, of the share towards the apex {worst_toward:.2e}"
    );
    assert!(
        lit > 100 && partial > 20,
        "lit {lit}, partly facing away {partial}"
    );
    // Radiance and facing sums below 1: f32 sums of the same f16 texels, 1e-4 as above. The
    // share divides two such sums of at least 1e-3: 1e-3 bounds its error.
    assert!(worst < 1e-4, "GPU and CPU samples differ by {worst}");
    assert!(
        worst_toward < 1e-3,
        "GPU and CPU shares differ by {worst_toward}"
    );
}

/// Builds `svo`'s anisotropic radiance from its injected voxels and compares every brick's
/// 6 values with the CPU twin. The GPU stores every level in f16 (2^-11 relative) and each
/// level composites rounded values (a convex combination per channel), so the error stays
/// below one rounding per level of the largest radiance: depth x 2^-10 of it, with margin.
fn check_aniso_radiance(ctx: &GpuContext, svo: &Svo, largest: f32) {
    use octolux::voxel::svo::aniso_radiance::SvoAnisoRadiance;
    use octolux::voxel::svo::sample::svo_radiance_aniso;
    let aniso = SvoAnisoRadiance::new(ctx, svo).unwrap();
    let mut timer = PassTimer::new(ctx);
    aniso.record(&mut timer, svo);
    let timings = timer.finish_frame().unwrap();
    assert!(timings.iter().any(|t| t.name == "svo anisotropic radiance"));
    let gpu = aniso.read_back(ctx, svo).unwrap();
    let tree = svo.read_back(ctx).unwrap();
    let voxels = svo.read_voxel_radiance(ctx).unwrap();
    let want = cpu::svo_aniso_radiance(&tree, &voxels);
    assert_eq!(gpu.len(), want.len());
    let tolerance = svo.levels().len() as f32 * largest / 1024.0;
    let mut worst = 0.0f32;
    let mut directional = 0;
    for (g, w) in gpu.iter().zip(&want) {
        for (a, b) in g.iter().zip(w) {
            worst = worst.max((*a - *b).abs().max_element());
        }
        directional += g.iter().any(|v| (*v - g[0]).abs().max_element() > 0.01) as usize;
    }
    println!(
        "anisotropic radiance: {} bricks, {directional} directional, worst error {worst:.2e}",
        gpu.len()
    );
    assert!(worst <= tolerance, "worst error {worst} > {tolerance}");
    // The thin emitter is seen differently along different axes.
    assert!(directional > 10, "{directional} directional bricks");
    // The root holds the emitter in every direction.
    let root = tree.brick_of[0] as usize;
    assert!(root != 0 && gpu[root - 1].iter().all(|v| v.x > 0.0 && v.w > 0.0));
    // Directional samples: GPU against the CPU twin over the GPU's values, at points around
    // the emitter, footprints from 2 to 16 voxels, directions all round. Same values, same
    // arithmetic order: f32 rounding only.
    let grid = svo.grid();
    let mut points = Vec::new();
    let mut dirs = Vec::new();
    for i in 0..400u32 {
        let f = |k: u32| ((i * k) % 97) as f32 / 97.0;
        let p = Vec3::new(0.1 + 0.8 * f(31), 0.1 + 0.8 * f(57), 0.1 + 0.8 * f(71));
        points.push(p.extend(grid.voxel_size * (2.0 + 14.0 * f(13))));
        dirs.push(Vec3::new(f(17) - 0.5, f(23) - 0.5, f(29) - 0.5).normalize_or(Vec3::X));
    }
    let samples = aniso.probe(ctx, svo, &points, &dirs).unwrap();
    let mut lit = 0;
    for ((q, d), g) in points.iter().zip(&dirs).zip(&samples) {
        let c = svo_radiance_aniso(&tree, &gpu, grid, q.truncate(), q.w, *d);
        assert!(
            (*g - c).abs().max_element() <= 1e-5 * (1.0 + c.abs().max_element()),
            "at {q} along {d}: GPU {g} CPU {c}"
        );
        lit += (c.x > 0.0) as usize;
    }
    assert!(lit > 40, "{lit} of 400 samples see the emitter");
}

#[test]
fn anisotropic_radiance_equals_the_cpu_twin_with_and_without_a_dynamic_part() {
    use octolux::voxel::svo::dynamic::DynamicReserve;
    let ctx = context();
    let (grid, tris, svo) = emissive_octree(&ctx);
    let largest = tris.iter().map(|t| t.emission.x).fold(0.0, f32::max);
    check_aniso_radiance(&ctx, &svo, largest);
    // The emitter moving through the static triangle: its leaves are dynamic nodes.
    let builder = SvoBuilder::new(&ctx);
    let (mut svo, _) = builder
        .build_with_reserve(&ctx, &grid, &tris[1..], DynamicReserve::new(4096))
        .unwrap();
    for dy in [0.0, -0.2] {
        let mut moving = tris[0];
        for p in &mut moving.positions {
            p.y += dy;
        }
        builder.update_dynamic(&ctx, &mut svo, &[moving]).unwrap();
        inject_nothing(&ctx, &builder, &svo);
        assert!(svo.dynamic_levels().iter().any(|&(a, b)| b > a));
        check_aniso_radiance(&ctx, &svo, largest);
    }
}

/// Per node with a brick, keyed by level and coordinates: the bits of its albedo and its
/// radiance texels.
type NodeBits = BTreeMap<(usize, [u32; 3]), Vec<u32>>;

fn bricks_by_node(svo: &Svo, cpu_svo: &SvoCpu, radiance: &[[Vec4; 27]]) -> (NodeBits, NodeBits) {
    let coords = cpu_svo.coordinates();
    let bits = |b: &[Vec4; 27]| -> Vec<u32> {
        b.iter()
            .flat_map(|t| t.to_array().map(f32::to_bits))
            .collect()
    };
    let (mut albedo, mut light) = (NodeBits::new(), NodeBits::new());
    for d in 0..svo.levels().len() {
        for n in level_nodes(svo, d) {
            let b = cpu_svo.brick_of[n as usize];
            if b != 0 {
                let key = (d, coords[n as usize]);
                albedo.insert(key, bits(&cpu_svo.bricks[b as usize - 1]));
                light.insert(key, bits(&radiance[b as usize - 1]));
            }
        }
    }
    (albedo, light)
}

/// The coarsest levels filtered in one dispatch (`mip_coarse`, the default) give the bricks
/// and the radiance of four dispatches per level, bit for bit, static and dynamic nodes: the
/// same taps summed in the same order, and every tap weight is a power of two, so the products
/// are exact and a fused multiply-add rounds as a multiply and an add do, on every adapter.
#[test]
fn fused_coarse_levels_equal_the_per_level_dispatches_bit_for_bit() {
    use octolux::voxel::svo::dynamic::DynamicReserve;
    // Counting work: the radiance mip reports its dispatches and its static part's texels.
    let ctx = context().with_work_counter();
    // 64^3: levels 0-2 are fused, 3 and 4 filtered one by one, 5 holds the leaves.
    let grid = VoxelGrid::new(Vec3::ZERO, 1.0 / 64.0, 64).unwrap();
    let tris = emissive_triangles();
    // Static slanted triangle and a dynamic emitter (dynamic nodes from level 3 on, below the
    // static nodes of the fused levels), then both dynamic (dynamic nodes from level 1 on).
    for split in [1, 2] {
        let (dynamic, statics) = tris.split_at(split);
        let run = |fused: bool| {
            let builder = SvoBuilder::new(&ctx).with_fused_coarse_levels(fused);
            let (mut svo, _) = builder
                .build_with_reserve(&ctx, &grid, statics, DynamicReserve::new(1 << 14))
                .unwrap();
            builder.update_dynamic(&ctx, &mut svo, dynamic).unwrap();
            ctx.work().unwrap().take(&ctx).unwrap();
            inject_nothing(&ctx, &builder, &svo);
            let counts = ctx.work().unwrap().take(&ctx).unwrap();
            let count = |quantity: &str| {
                counts
                    .iter()
                    .find(|c| c.pass == "svo radiance mip" && c.quantity == quantity)
                    .map(|c| c.count)
            };
            let dispatches = count("dispatches");
            // The static part's work: 27 texels filtered per node above the leaves, a face
            // transfer per node and axis, whether the coarse levels are fused or not.
            let nodes: Vec<u64> = svo
                .levels()
                .iter()
                .map(|&(a, b)| u64::from(b - a))
                .collect();
            let leaf = nodes.len() - 1;
            assert_eq!(
                count("static texels filtered"),
                Some(27 * nodes[..leaf].iter().sum::<u64>())
            );
            assert_eq!(
                count("static face transfers"),
                Some(3 * nodes.iter().sum::<u64>())
            );
            let albedo = svo.read_back(&ctx).unwrap();
            let radiance = svo.read_radiance(&ctx).unwrap();
            (svo, albedo, radiance, dispatches)
        };
        let (svo, albedo, radiance, dispatches) = run(true);
        let (svo_per_level, albedo_per_level, radiance_per_level, per_level) = run(false);
        // Static and dynamic ranges, 4 dispatches each per level (3 on the leaf level):
        // 2 x (3 + 5 x 4) = 46 level by level, 2 x (3 + 2 x 4) + 1 = 23 with levels 0-2 in one.
        assert_eq!((dispatches, per_level), (Some(23), Some(46)));
        assert_eq!(svo.levels().len(), 6);
        let first_dynamic = if statics.is_empty() { 1 } else { 3 };
        assert!(
            svo.dynamic_levels()[first_dynamic..]
                .iter()
                .all(|&(a, b)| b > a),
            "dynamic nodes from level {first_dynamic} on: {:?}",
            svo.dynamic_levels()
        );
        // Node and brick indices are handed out by atomics in whatever order the invocations
        // run: compare the bricks by node level and coordinates.
        let (albedo_a, radiance_a) = bricks_by_node(&svo, &albedo, &radiance);
        let (albedo_b, radiance_b) =
            bricks_by_node(&svo_per_level, &albedo_per_level, &radiance_per_level);
        for (what, a, b) in [
            ("albedo", albedo_a, albedo_b),
            ("radiance", radiance_a, radiance_b),
        ] {
            assert_eq!(a.len(), b.len(), "{what}: node counts");
            let differ = a.iter().filter(|(k, v)| b.get(*k) != Some(*v)).count();
            assert_eq!(differ, 0, "{what}: {differ} of {} nodes differ", a.len());
        }
        // Not an all-zero comparison: the fused levels hold light.
        for d in 0..=2 {
            let lit = level_nodes(&svo, d)
                .map(|n| albedo.brick_of[n as usize])
                .filter(|&b| b != 0 && radiance[b as usize - 1].iter().any(|t| t.x > 0.0))
                .count();
            assert!(lit > 0, "level {d} holds no radiance");
        }
    }
}

/// The floor of [`shadow_scene`] without its occluder, a wall thinner than a voxel (two quads
/// facing away from each other a quarter voxel apart in voxel column 10 of the 32^3 grid of
/// `lit_floor_...`, split along the same diagonal: their fragments' normals cancel in every
/// voxel) and the point light on the wall's +x side, at the height of its middle. The lit
/// face lies just in front of the voxels' centres, where the injection looks up its shadow.
fn thin_wall_scene(vs: f32) -> Scene {
    let mut scene = shadow_scene();
    let x = -1.25 + 10.5 * vs;
    let face = |x: f32, corners: [(f32, f32); 4]| {
        quad("wall", corners.map(|(y, z)| Vec3::new(x, y, z)), 0)
    };
    // Normals +x and -x ((c1 - c0) x (c2 - c0)); both split along (0.2, -0.3)-(0.8, 0.3).
    scene.meshes[1] = face(
        x + 0.01 * vs,
        [(0.2, -0.3), (0.8, -0.3), (0.8, 0.3), (0.2, 0.3)],
    );
    scene.meshes.push(face(
        x - 0.25 * vs,
        [(0.2, -0.3), (0.2, 0.3), (0.8, 0.3), (0.8, -0.3)],
    ));
    scene.objects[0].meshes = vec![0, 1, 2];
    scene.lights[0].position = Vec3::new(0.3, 0.5, 0.0);
    scene
}

/// The 32^3 octree of [`thin_wall_scene`], with facing, lit by its point light.
fn lit_thin_wall_octree(ctx: &GpuContext) -> (Scene, VoxelGrid, Svo) {
    let res = 32;
    let vs = 2.5 / res as f32;
    let scene = thin_wall_scene(vs);
    let (renderer, layers, lights) = point_light_shadows(ctx, &scene, 512);
    let grid = VoxelGrid::new(Vec3::new(-1.25, -8.5 * vs, -1.25), vs, res).unwrap();
    let tris = scene_triangles(&scene, &scene.frame(0.0, 0));
    let builder = SvoBuilder::new(ctx).with_facing(true);
    let (svo, _) = builder.build(ctx, &grid, &tris).unwrap();
    let mut timer = PassTimer::new(ctx);
    let shadows = ShadowLookupBuffers::new(ctx, "test", renderer.shadow_maps().texture(), &layers);
    builder
        .inject(ctx, &mut timer, &svo, shadows.lookup(), &lights, 1)
        .unwrap();
    timer.finish_frame().unwrap();
    (scene, grid, svo)
}

#[test]
fn facing_points_where_the_radiance_leaves_and_is_filtered_as_the_radiance() {
    use octolux::voxel::facing::facing_toward;
    let ctx = context();
    let (scene, grid, svo) = lit_thin_wall_octree(&ctx);
    let (light, vs) = (scene.lights[0].position, grid.voxel_size);
    let cpu_svo = svo.read_back(&ctx).unwrap();
    let voxels = voxel_map(&svo, &cpu_svo, &ctx);
    // The CPU facing of every voxel: its radiance's weight r + g + b times the floor's normal,
    // or, for the wall's voxels (no dominant normal: lit as facing the light), the direction
    // to the light from the voxel's centre.
    let wall_column = 10;
    let mut facing = BTreeMap::new();
    let (mut floor_lit, mut wall_lit) = (0, 0);
    for (v, value) in &voxels {
        let weight = value.x + value.y + value.z;
        let p = grid.origin + (Vec3::from_array(v.map(|c| c as f32)) + 0.5) * vs;
        let dir = if v[0] == wall_column && v[1] > 8 {
            wall_lit += (weight > 0.0) as u32;
            (light - p).normalize()
        } else {
            assert_eq!(v[1], 8, "only the floor and the wall are occupied");
            floor_lit += (weight > 0.0) as u32;
            Vec3::Y
        };
        facing.insert(*v, (dir * weight).extend(0.0));
    }
    let bricks = svo.read_facing(&ctx).unwrap().expect("built with facing");
    let error = lattice_error(&svo, &cpu_svo, &facing, &bricks);
    // From the wall's far side (a cone travelling +x towards it) its light is not seen; from
    // the lit side (travelling -x) all of it. Leaf texels on the wall's column of the lattice.
    let radiance = svo.read_radiance(&ctx).unwrap();
    let coords = cpu_svo.coordinates();
    let leaf = svo.levels().len() - 1;
    let (mut far_side, mut near_side, mut texels) = (0.0f32, 1.0f32, 0);
    for n in level_nodes(&svo, leaf) {
        let b = cpu_svo.brick_of[n as usize];
        let c = coords[n as usize];
        // The wall's column's centres lie on the texels of x = 1 of nodes with 2c = 10.
        if b == 0 || 2 * c[0] != wall_column {
            continue;
        }
        for t in 0..27usize {
            let (r, f) = (radiance[b as usize - 1][t], bricks[b as usize - 1][t]);
            let y = 2 * c[1] + (t as u32 / 3) % 3;
            let z = 2 * c[2] + t as u32 / 9;
            // Texels of the wall's middle rows, where the light meets it head on.
            if t % 3 != 1 || r.x <= 0.0 || !(14..=16).contains(&y) || !(15..=17).contains(&z) {
                continue;
            }
            texels += 1;
            far_side = far_side.max(facing_toward(r, f.truncate(), Vec3::X));
            near_side = near_side.min(facing_toward(r, f.truncate(), Vec3::NEG_X));
        }
    }
    println!(
        "lit voxels: floor {floor_lit}, wall {wall_lit}; facing lattice error {error:.2e}; \
         wall texels {texels}: seen from the far side at most {far_side:.3}, from the lit side \
         at least {near_side:.3}"
    );
    assert!(
        floor_lit > 100 && wall_lit > 20,
        "lit voxels: floor {floor_lit}, wall {wall_lit}"
    );
    // f16 storage of the facing sums, as the radiance mip's bound.
    assert!(error < 4e-3, "facing lattice error {error}");
    assert!(texels >= 6);
    assert!(
        far_side < 0.1,
        "the far side sees {far_side} of the wall's light"
    );
    assert!(
        near_side > 0.999,
        "the lit side sees {near_side} of the wall's light"
    );
}
