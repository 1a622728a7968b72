//! GPU twins of the probe kernels: lattice directions and BVH traversal on the GPU against the
//! CPU code in `lattice.rs` and `bvh.rs`, and the BVH against the reference's ray queries.

use crate::common::context;
use octolux::gi::probes::bvh::{BvhHit, SceneBvh, SceneHit};
use octolux::gi::probes::lattice::{direction, Lattice};
use octolux::gpu::{read_buffer, GpuContext};
use octolux::reference::RayQueries;
use octolux::scene::Scene;
use octolux::voxel::objects_triangles;

use glam::Vec3;

const OWNER: &str = "probes test";
const MISS: u32 = u32::MAX;

fn upload(ctx: &GpuContext, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    ctx.create_buffer_init(
        OWNER,
        label,
        bytes,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    )
}

/// Runs entry `entry` of the test kernels over `count` invocations with `buffers` at their
/// bindings; returns the output (binding 7) as `vec4`s.
fn run(
    ctx: &GpuContext,
    entry: &str,
    buffers: &[(u32, &wgpu::Buffer)],
    count: u32,
    out_vec4: usize,
) -> Vec<[f32; 4]> {
    let source = octolux::gpu::shader::compose_text(
        "probes test",
        include_str!("shaders/probes_kernels.wgsl"),
        &[],
        &[],
    )
    .unwrap();
    let module = ctx.shader("probes test", &source);
    let pipeline = ctx.compute_pipeline(entry, &module, entry);
    let out = upload(ctx, "out", &vec![0u8; out_vec4 * 16]);
    let mut entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .map(|&(binding, b)| wgpu::BindGroupEntry {
            binding,
            resource: b.as_entire_binding(),
        })
        .collect();
    entries.push(wgpu::BindGroupEntry {
        binding: 7,
        resource: out.as_entire_binding(),
    });
    let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(count.div_ceil(64), 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    let bytes = read_buffer(ctx, &out, 0, out_vec4 as u64 * 16).unwrap();
    ctx.check_errors().unwrap();
    bytemuck::cast_slice(&bytes).to_vec()
}

#[test]
fn gpu_lattices_equal_the_cpu_lattices() {
    // Tolerance: WGSL bounds sin and cos on [-pi, pi) only to 2^-11 absolute (both sides
    // reduce the angle there first), and division and sqrt to a few ULPs; a direction
    // component is a product of at most two such values, so 3 x 2^-11 bounds it on any
    // adapter. The solid angles use only cos of angles in [0, pi] and division: same bound.
    // Fibonacci's z uses only division, so it agrees to a few ULPs.
    let ctx = context();
    for (lattice, n) in [
        (Lattice::Fibonacci, 64),
        (Lattice::Fibonacci, 1024),
        (Lattice::LatLong, 64),
        (Lattice::LatLong, 128),
    ] {
        let params: [u32; 8] = [lattice.gpu_kind(), n, 0, 0, 0, 0, 0, 0];
        let p = upload(&ctx, "params", bytemuck::cast_slice(&params));
        let gpu = run(&ctx, "dirs", &[(0, &p)], n, n as usize);
        let mut worst = 0.0f32;
        for (k, g) in gpu.iter().enumerate() {
            let (d, w) = direction(lattice, k as u32, n);
            let err = (Vec3::from_slice(g) - d)
                .abs()
                .max_element()
                .max((g[3] - w).abs());
            worst = worst.max(err);
            if lattice == Lattice::Fibonacci {
                assert!((g[1] - d.y).abs() < 1e-6, "{lattice:?} {n} {k}: z");
            }
        }
        println!("{lattice:?} {n}: largest difference {worst:e}");
        assert!(worst < 3.0 / 2048.0, "{lattice:?} {n}: {worst}");
    }
}

/// Whether the hit lies within `eps` (barycentric) of its triangle's edges.
fn near_edge(h: &BvhHit, eps: f32) -> bool {
    h.u < eps || h.v < eps || 1.0 - h.u - h.v < eps
}

#[test]
fn gpu_traversal_equals_the_cpu_bvh_and_agrees_with_the_reference() {
    // The shipped animated Cornell box at t = 1.3 s (the short block moved and turned): the
    // two-level BVH as `probes-grid` holds it, the static objects in world space and the
    // short block in its model space placed by its transform at 1.3 s. 4096 random rays from
    // inside the box: the GPU's closest hit equals the CPU traversal of the same BVHs
    // (triangle, object, distance, world normal) and the reference's obvhs BVH over the
    // world triangles of that frame (hit or miss, and distance).
    //
    // Tolerances: the same Möller-Trumbore arithmetic runs on both sides, but WGSL may fuse
    // multiply-adds and divides to 2.5 ULPs, so t, u, v agree to ~1e-6 relative (the ray's
    // move into the object's space adds a few ULPs on both sides), and a ray through an edge
    // (a barycentric within 1e-4 of 0) may go to either of the triangles sharing it, or slip
    // between them; such rays are allowed to differ and must be rare.
    let ctx = context();
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/cornell-animated.toml"
    );
    let scene = Scene::load(path).unwrap();
    let frame = scene.frame(1.3, 0);
    let bvh = SceneBvh::build(&scene);
    assert_eq!(bvh.objects.len(), 1, "the short block moves");
    let (nodes, tris, roots) = bvh.flatten();
    let instances = bvh.instances(&scene, &frame, &roots).unwrap();
    assert_ne!(
        instances[0].world_to_object[0],
        [1.0, 0.0, 0.0, 0.0],
        "the block is moved and turned at 1.3 s"
    );
    let tri_base = bvh.still.tris.len() as u32;
    let reference = RayQueries::build(&scene, &frame).unwrap();
    let (lo, hi) = scene.bounds_at(1.3);
    let mut seed = 12345u32;
    let mut rnd = move || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1 << 24) as f32
    };
    let count = 4096u32;
    let mut rays = Vec::new();
    let mut cases = Vec::new();
    for i in 0..count {
        let o = lo + (hi - lo) * Vec3::new(rnd(), rnd(), rnd()) * 0.98 + (hi - lo) * 0.01;
        let d = loop {
            let v = Vec3::new(rnd(), rnd(), rnd()) * 2.0 - 1.0;
            if (0.01..1.0).contains(&v.length_squared()) {
                break v.normalize();
            }
        };
        // Every fourth ray gets a short reach, so that t_max cuts some hits off.
        let t_max = if i % 4 == 0 { 0.2 } else { 1e30 };
        rays.push([o.x, o.y, o.z, t_max]);
        rays.push([d.x, d.y, d.z, 0.0]);
        cases.push((o, d, t_max));
    }
    let params: [u32; 8] = [0, 0, count, 0, 0, instances.len() as u32, 0, 0];
    let p = upload(&ctx, "params", bytemuck::cast_slice(&params));
    let n = upload(&ctx, "nodes", bytemuck::cast_slice(&nodes));
    let t = upload(&ctx, "tris", bytemuck::cast_slice(&tris));
    let r = upload(&ctx, "rays", bytemuck::cast_slice(&rays));
    let inst = upload(&ctx, "instances", bytemuck::cast_slice(&instances));
    let gpu = run(
        &ctx,
        "trace",
        &[(0, &p), (2, &n), (3, &t), (4, &inst), (6, &r)],
        count,
        2 * count as usize,
    );
    let (mut hits, mut moving, mut edges) = (0, 0, 0);
    for (i, &(o, d, t_max)) in cases.iter().enumerate() {
        let g = gpu[2 * i];
        let g_tri = g[0].to_bits();
        let g_object = gpu[2 * i + 1][1].to_bits();
        // The GPU's triangle in the buffers, as the CPU's object and local triangle.
        let g_hit = (g_tri != MISS).then(|| SceneHit {
            hit: BvhHit {
                tri: if g_object == MISS {
                    g_tri
                } else {
                    g_tri - tri_base
                },
                t: g[1],
                u: g[2],
                v: g[3],
            },
            object: (g_object != MISS).then_some(g_object as usize),
        });
        let occluded = gpu[2 * i + 1][0] > 0.5;
        let cpu = bvh.closest(&instances, o, d, t_max);
        let r = reference.closest_distance(o, d, t_max);
        hits += cpu.is_some() as u32;
        moving += cpu.is_some_and(|h| h.object.is_some()) as u32;
        assert_eq!(occluded, g_hit.is_some(), "ray {i}: occluded vs closest");
        let edge = cpu.is_some_and(|h| near_edge(&h.hit, 1e-4))
            || g_hit.is_some_and(|h| near_edge(&h.hit, 1e-4));
        let same = |a: Option<f32>, b: Option<f32>| match (a, b) {
            (Some(a), Some(b)) => (a - b).abs() <= 1e-5 * a.max(1.0),
            (None, None) => true,
            _ => false,
        };
        let key = |h: &SceneHit| (h.hit.tri, h.object);
        let ok_gpu = g_hit.map(|h| key(&h)) == cpu.map(|h| key(&h))
            && same(g_hit.map(|h| h.hit.t), cpu.map(|h| h.hit.t));
        let ok_ref = same(r, cpu.map(|h| h.hit.t));
        if !(ok_gpu && ok_ref) {
            assert!(
                edge,
                "ray {i} {o} {d}: gpu {g_hit:?}, cpu {cpu:?}, reference {:?}",
                r
            );
            edges += 1;
        } else if let Some(h) = cpu {
            let normal = bvh.normal(&instances, &h);
            let g_normal = gpu[2 * i + 1];
            assert!(
                (normal.x - g_normal[2]).abs() < 1e-5 && (normal.y - g_normal[3]).abs() < 1e-5,
                "ray {i}: normal {normal} against {g_normal:?}"
            );
            // The world normal of the moved block is the world triangle's.
            let world = objects_triangles(&scene, &frame, h.object.is_some());
            assert!(world.iter().any(|w| w.normal.dot(normal) > 1.0 - 1e-4));
        }
    }
    println!("{hits} of {count} rays hit, {moving} the moving block; {edges} differ at an edge");
    assert!(hits > count / 2, "{hits}");
    assert!(moving > count / 50, "{moving}");
    assert!(edges * 200 < count, "{edges} rays differ at edges");
}

#[test]
fn probe_integration_and_gather_equal_their_cpu_twins() {
    // One frame of `probes-grid` on the Cornell box (10^3 probes, both encodings, both
    // lattices): every probe's coefficients equal the CPU integration of the GPU's surfel
    // radiance, and every pixel's indirect irradiance equals the CPU gather from the GPU's
    // probes at the pixel's position and normal.
    //
    // Tolerances: the lattice directions agree to 3 x 2^-11 (test above), so a coefficient
    // may differ by that share of the probe's total sum_j |L_j| dw_j; the gather's output is
    // f16 (11-bit mantissa, 2^-11 relative) of a sum the CPU forms in the same order, from a
    // world position rebuilt from the depth buffer on both sides.
    use octolux::render::{RenderSettings, Renderer};
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    use octolux::gi::probes::moments::{build_map, MomentMaps, MOMENT_TEXELS};
    use octolux::gi::probes::Visibility;
    for (encoding, lattice, visibility) in [
        (
            octolux::gi::probes::Encoding::ShL1,
            Lattice::Fibonacci,
            Visibility::Moments,
        ),
        (
            octolux::gi::probes::Encoding::Octahedron,
            Lattice::LatLong,
            Visibility::None,
        ),
        (
            octolux::gi::probes::Encoding::ShL1,
            Lattice::LatLong,
            Visibility::Moments,
        ),
    ] {
        // The fixed lattice (no history: one surfel set per probe); probes_history.rs has
        // the turned lattices and the history.
        let probes = octolux::gi::probes::ProbeSettings {
            grid: [10; 3],
            encoding,
            lattice,
            visibility,
            history: 0,
            ..Default::default()
        };
        let settings = RenderSettings {
            width: 40,
            height: 40,
            gi: "probes-grid".into(),
            gi_settings: octolux::gi::GiSettings {
                probes: probes.clone(),
                ..Default::default()
            },
            ..RenderSettings::default()
        };
        let mut r = Renderer::new(&ctx, &scene, settings).unwrap();
        r.render(&scene, 0.0).unwrap();
        let technique = r
            .technique()
            .as_any()
            .and_then(|a| a.downcast_ref::<octolux::gi::probes::ProbesGrid>())
            .unwrap();
        let read = |b: &wgpu::Buffer| -> Vec<[f32; 4]> {
            bytemuck::cast_slice(&read_buffer(&ctx, b, 0, b.size()).unwrap()).to_vec()
        };
        let (surfel_buf, radiance_buf) = technique.surfel_buffers();
        let (surfels, radiance, probe_data) = (
            read(surfel_buf),
            read(radiance_buf),
            read(technique.probe_buffer()),
        );
        let maps: Vec<[f32; 2]> = bytemuck::cast_slice(
            &read_buffer(
                &ctx,
                technique.moment_buffer(),
                0,
                technique.moment_buffer().size(),
            )
            .unwrap(),
        )
        .to_vec();
        let n = probes.surfel_count() as usize;
        let vec4s = octolux::gi::probes::PROBE_VEC4 as usize;
        let dirs: Vec<Vec3> = (0..probes.surfel_count())
            .map(|k| octolux::gi::probes::lattice::direction(lattice, k, probes.surfel_count()).0)
            .collect();
        // The scene's maximum ray distance (ProbeParams.max_distance): a miss's distance.
        let (lo, hi) = scene.bounds_at(0.0);
        let far = (hi - lo).length() * 1.01;
        let mut worst_moment = 0.0f32;
        let surfel_vec4 = octolux::gi::probes::SURFEL_VEC4 as usize;
        let mut valid = 0;
        for probe in 0..technique.grid().count() as usize {
            let states: Vec<f32> = (0..n)
                .map(|k| surfels[(probe * n + k) * surfel_vec4][3])
                .collect();
            let l: Vec<Vec3> = (0..n)
                .map(|k| Vec3::from_slice(&radiance[probe * n + k]))
                .collect();
            let (coeffs, meta) = octolux::gi::probes::integrate_probe(&probes, &states, &l);
            let scale: f32 = l.iter().map(|x| x.max_element()).sum::<f32>() * 4.0 * 3.15 / n as f32;
            let b = probe * vec4s;
            for (k, c) in coeffs.iter().enumerate() {
                let g = Vec3::from_slice(&probe_data[b + k]);
                assert!(
                    (g - *c).abs().max_element() <= 3.0 / 2048.0 * scale + 1e-7,
                    "probe {probe} coefficient {k}: gpu {g}, cpu {c}"
                );
            }
            // Shares: a division WGSL computes to 2.5 ULPs; the validity is an integer test.
            let got = probe_data[b + 8];
            assert_eq!(got[2], meta[2], "probe {probe} validity");
            for c in 0..2 {
                assert!(
                    (got[c] - meta[c]).abs() <= 1e-6,
                    "probe {probe}: {got:?} {meta:?}"
                );
            }
            valid += (meta[2] > 0.5) as u32;
            // Depth moments: the GPU's map equals the CPU's from the same surfels. The
            // lattice directions differ by up to 3 x 2^-11 (above), which moves a kernel
            // weight max(0, t . d)^32 by at most 32 x 3 x 2^-11 of itself, so a weighted mean
            // by at most 2 x 4.7 % of the spread of the distances it averages (and a mean
            // square by as much of the squares' spread); plus f32 rounding of the sums.
            if visibility == Visibility::Moments {
                let dists: Vec<f32> = (0..n)
                    .map(|k| surfels[(probe * n + k) * surfel_vec4 + 2][3])
                    .collect();
                let t = MOMENT_TEXELS as usize;
                let want = build_map(&dirs, &states, &dists, far);
                let used: Vec<f32> = (0..n)
                    .map(|k| if states[k] > 0.5 { dists[k].abs() } else { far })
                    .collect();
                let (dlo, dhi) = used
                    .iter()
                    .fold((f32::MAX, 0.0f32), |(a, b), &d| (a.min(d), b.max(d)));
                for (i, w) in want.iter().enumerate() {
                    let g = maps[probe * t + i];
                    for c in 0..2 {
                        let spread = if c == 0 {
                            dhi - dlo
                        } else {
                            dhi * dhi - dlo * dlo
                        };
                        let err = (g[c] - w[c]).abs();
                        worst_moment = worst_moment.max(err / (spread + w[c]));
                        assert!(
                            err <= 0.094 * spread + 1e-5 * w[c],
                            "probe {probe} texel {i} moment {c}: gpu {}, cpu {}",
                            g[c],
                            w[c]
                        );
                    }
                }
            }
        }
        println!("{visibility:?}: largest moment difference {worst_moment:e} (relative)");
        // The probes inside the two blocks are the invalid ones.
        let count = technique.grid().count();
        assert!(
            valid < count && valid > count * 3 / 4,
            "{valid} of {count} valid"
        );
        let g = r.read_gbuffer().unwrap();
        let view = *r.last_view().unwrap();
        let bytes = octolux::gpu::read_texture(&ctx, technique.indirect_texture(), 0).unwrap();
        let indirect: &[u16] = bytemuck::cast_slice(&bytes);
        let mut lit = 0;
        let points = view.world_points(&g.depth);
        for (i, (point, normal)) in points.iter().zip(&g.normal).enumerate() {
            let Some(p) = *point else {
                continue;
            };
            let moments = (visibility == Visibility::Moments).then(|| MomentMaps {
                maps: &maps,
                floor: technique.variance_floor(),
            });
            let want = octolux::gi::probes::grid_irradiance(
                technique.grid(),
                &probes,
                &probe_data,
                moments,
                p,
                normal.normalize(),
            );
            let got = Vec3::from_array(std::array::from_fn(|c| {
                octolux::gpu::pack::f16_to_f32(indirect[4 * i + c])
            }));
            assert!(
                (got - want).abs().max_element() <= 2e-3 * want.max_element() + 1e-5,
                "{encoding:?} pixel {i}: gpu {got}, cpu {want}"
            );
            lit += (want.max_element() > 0.0) as u32;
        }
        assert!(lit > 1000, "{lit} pixels lit");
    }
}
