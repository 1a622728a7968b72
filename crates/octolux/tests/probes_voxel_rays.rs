//! GPU twins of the voxel rays (`rays = "voxels"`): the lattice ends and the surfel of the
//! first occupied voxel on the GPU against `rays::voxel_ray` and `rays::voxel_surfel` over the
//! octree read back, static and dynamic parts; and the voxel hits against the BVH's exact ones.

use glam::{IVec3, Vec3};
use octolux::gi::probes::bvh::SceneBvh;
use octolux::gi::probes::rays::{voxel_ray, voxel_surfel, VoxelSurfel};
use octolux::gpu::{read_buffer, GpuContext, GpuOptions};
use octolux::scene::Scene;
use octolux::voxel::objects_triangles;
use octolux::voxel::svo::walk::{walk_bindings, SvoWalk, SvoWalkCpu};
use octolux::voxel::svo::{Svo, SvoBuilder};

const OWNER: &str = "voxel rays test";

/// One ray's GPU result: lattice ends (`None`: the ray misses the grid) and surfel.
struct GpuRay {
    ends: Option<(IVec3, IVec3)>,
    surfel: Option<VoxelSurfel>,
}

/// Runs `voxel_ray` and `voxel_closest` on the GPU for `rays` (origin, direction, t_max).
fn trace(ctx: &GpuContext, svo: &Svo, walk: &SvoWalk, rays: &[(Vec3, Vec3, f32)]) -> Vec<GpuRay> {
    let source = octolux::gpu::shader::compose_text(
        "voxel rays test",
        include_str!("shaders/probes_voxel_rays.wgsl"),
        &[],
        &[],
    )
    .unwrap();
    let module = ctx.shader("voxel rays test", &source);
    let pipeline = ctx.compute_pipeline("voxel rays test", &module, "main");
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let input: Vec<[f32; 4]> = rays
        .iter()
        .flat_map(|&(o, d, t_max)| [o.extend(t_max).to_array(), d.extend(0.0).to_array()])
        .collect();
    let params = ctx.create_buffer_init(OWNER, "walk", bytemuck::bytes_of(walk), usage);
    let input = ctx.create_buffer_init(OWNER, "rays", bytemuck::cast_slice(&input), usage);
    let out_bytes = rays.len() as u64 * 5 * 16;
    let out = ctx.create_buffer_init(OWNER, "out", &vec![0u8; out_bytes as usize], usage);
    let placeholder = ctx.create_buffer_init(OWNER, "placeholder", &[0; 16], usage);
    let mut entries = vec![(5, input.as_entire_binding()), (6, out.as_entire_binding())];
    entries.extend(walk_bindings(&params, svo, &placeholder));
    let group = octolux::gpu::pass::bind(ctx, &pipeline, &entries);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((rays.len() as u32).div_ceil(64), 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    let bytes = read_buffer(ctx, &out, 0, out_bytes).unwrap();
    ctx.check_errors().unwrap();
    let words: &[[u32; 4]] = bytemuck::cast_slice(&bytes);
    words
        .chunks(5)
        .map(|w| {
            let ivec = |v: [u32; 4]| IVec3::new(v[0] as i32, v[1] as i32, v[2] as i32);
            let f = |v: u32| f32::from_bits(v);
            let t = f(w[3][0]);
            GpuRay {
                ends: (w[0][3] != 0).then(|| (ivec(w[0]), ivec(w[1]))),
                surfel: (t >= 0.0).then(|| VoxelSurfel {
                    voxel: ivec(w[2]),
                    t,
                    normal: Vec3::new(f(w[3][1]), f(w[3][2]), f(w[3][3])),
                    albedo: [w[2][3] & 255, (w[2][3] >> 8) & 255, (w[2][3] >> 16) & 255],
                    emission: Vec3::new(f(w[4][0]), f(w[4][1]), f(w[4][2])),
                }),
            }
        })
        .collect()
}

/// Rays from a 5^3 lattice of points inside `bounds` along 64 Fibonacci directions each.
fn probe_rays(bounds: (Vec3, Vec3)) -> Vec<(Vec3, Vec3, f32)> {
    let (lo, hi) = bounds;
    let reach = (hi - lo).length() * 1.01;
    let mut rays = Vec::new();
    for i in 0..125 {
        let cell = Vec3::new((i % 5) as f32, (i / 5 % 5) as f32, (i / 25) as f32);
        let o = lo + (hi - lo) * (cell + 0.5) / 5.0;
        for k in 0..64 {
            let d = octolux::gi::probes::lattice::direction(
                octolux::gi::probes::Lattice::Fibonacci,
                k,
                64,
            )
            .0;
            rays.push((o, d, reach));
        }
    }
    rays
}

/// The animated Cornell box's octree at t = 1.3 s: static part and dynamic part.
fn animated_box(ctx: &GpuContext, resolution: u32) -> (Scene, Svo) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/cornell-animated.toml"
    );
    let scene = Scene::load(path).unwrap();
    let builder = SvoBuilder::new(ctx);
    let mut svo = builder.build_scene(ctx, &scene, resolution, OWNER).unwrap();
    let moving = objects_triangles(&scene, &scene.frame(1.3, 0), true);
    assert!(!moving.is_empty(), "the short block moves");
    builder.update_dynamic(ctx, &mut svo, &moving).unwrap();
    (scene, svo)
}

#[test]
fn gpu_voxel_rays_equal_their_cpu_twin() {
    // 8000 rays through the animated box's octree (static walls and tall block, the short
    // block in the dynamic part). The lattice ends come from float arithmetic (a clip to the
    // grid, then a floor at 2^14 steps per grid side), which may round differently on a GPU:
    // they agree within one step. Everything after them is integer (the walk, the voxel's
    // sums, the rounded mean albedo), so the CPU twin handed the GPU's ends finds the same
    // voxel and albedo bit for bit. The float results (normalised normal, emission, the
    // plane's distance) agree to a few ULPs; 1e-5 relative is generous.
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let (scene, svo) = animated_box(&ctx, 64);
    let walk = SvoWalk::new(&svo, 0.0).unwrap();
    let tree = SvoWalkCpu::read(&ctx, &svo, walk).unwrap();
    let rays = probe_rays(scene.bounds_at(1.3));
    let gpu = trace(&ctx, &svo, &walk, &rays);
    let (mut hits, mut dynamic_hits, mut same_ends) = (0, 0, 0);
    for (i, (&(o, d, t_max), g)) in rays.iter().zip(&gpu).enumerate() {
        let cpu_ends = voxel_ray(&walk, o, d, t_max);
        let Some((a, b)) = g.ends else {
            assert!(cpu_ends.is_none(), "ray {i}: the GPU misses the grid");
            continue;
        };
        let (ca, cb) = cpu_ends.unwrap_or_else(|| panic!("ray {i}: the CPU misses the grid"));
        let step = (a - ca).abs().max((b - cb).abs()).max_element();
        assert!(step <= 1, "ray {i}: ends {a} {b} against {ca} {cb}");
        same_ends += (step == 0) as u32;
        let cpu = voxel_surfel(&tree, o, d, a, b);
        match (g.surfel, cpu) {
            (None, None) => {}
            (Some(g), Some(c)) => {
                hits += 1;
                let slot = tree
                    .dynamic_slots
                    .get(tree_node_of(&tree, c.voxel) as usize)
                    .copied()
                    .unwrap_or(0);
                dynamic_hits += (slot != 0) as u32;
                assert_eq!((g.voxel, g.albedo), (c.voxel, c.albedo), "ray {i}");
                let close = |x: Vec3, y: Vec3| {
                    (x - y).abs().max_element() <= 1e-5 * y.abs().max_element().max(1.0)
                };
                assert!(close(g.normal, c.normal), "ray {i}: {g:?} {c:?}");
                assert!(close(g.emission, c.emission), "ray {i}: {g:?} {c:?}");
                assert!(
                    (g.t - c.t).abs() <= 1e-5 * c.t.max(1.0),
                    "ray {i}: {g:?} {c:?}"
                );
            }
            (g, c) => panic!("ray {i}: gpu {g:?}, cpu {c:?}"),
        }
    }
    println!(
        "{hits} of {} rays hit, {dynamic_hits} in the dynamic part's leaves; {same_ends} with \
         identical ends",
        rays.len()
    );
    // The box is open at its front: about a sixth of the directions leave it.
    assert!(hits > rays.len() * 3 / 4, "{hits}");
    assert!(
        dynamic_hits > 50,
        "{dynamic_hits}: the moving block is seen"
    );
    assert!(same_ends * 100 >= rays.len() as u32 * 99, "{same_ends}");
}

/// The leaf node holding voxel `v`.
fn tree_node_of(tree: &SvoWalkCpu, v: IVec3) -> u32 {
    let mut node = 0u32;
    for k in (1..tree.params.depth).rev() {
        let c = tree.child[node as usize];
        if c == 0 {
            return u32::MAX;
        }
        let o = (v >> k as i32) & IVec3::ONE;
        node = c + (o.x | (o.y << 1) | (o.z << 2)) as u32;
    }
    node
}

#[test]
fn voxel_hits_agree_with_the_bvh_to_a_voxel() {
    // The same rays through the exact two-part BVH of the same frame. A voxel ray stops at
    // the first voxel its triangles touch (conservatively), then at the voxel's own plane
    // inside it: it lies within about a voxel of the exact surface across that surface (along
    // the ray the gap grows as 1 / cos at grazing angles). It differs where the exact ray
    // passes an edge or a surface closer than a voxel (grazing a wall, past a block's edge,
    // out through the box's open front beside an edge) and the voxel ray is caught there:
    // 3.6 % of these rays at 64^3 on lavapipe, so more than 5 % means a fault.
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let (scene, svo) = animated_box(&ctx, 64);
    let walk = SvoWalk::new(&svo, 0.0).unwrap();
    let frame = scene.frame(1.3, 0);
    let bvh = SceneBvh::build(&scene);
    let (_, _, roots) = bvh.flatten();
    let instances = bvh.instances(&scene, &frame, &roots).unwrap();
    let rays = probe_rays(scene.bounds_at(1.3));
    let gpu = trace(&ctx, &svo, &walk, &rays);
    let voxel = walk.voxel;
    let (mut agree, mut both, mut far) = (0usize, 0usize, 0usize);
    for (&(o, d, t_max), g) in rays.iter().zip(&gpu) {
        let exact = bvh
            .closest(&instances, o, d, t_max)
            .map(|h| (h.hit.t, bvh.normal(&instances, &h)));
        match (g.surfel, exact) {
            (None, None) => agree += 1,
            (Some(s), Some((t, n))) => {
                both += 1;
                // How far the voxel surfel lies off the exact surface, along its normal.
                if ((s.t - t) * d.dot(n)).abs() <= 1.5 * voxel {
                    agree += 1;
                } else {
                    far += 1;
                }
            }
            _ => {}
        }
    }
    println!(
        "{agree} of {} rays agree within 1.5 voxels across the surface ({both} hit both, {far} \
         of those farther)",
        rays.len()
    );
    assert!(agree * 100 >= rays.len() * 95, "{agree} of {}", rays.len());
}
