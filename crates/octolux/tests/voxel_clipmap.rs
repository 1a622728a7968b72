//! Clipmap level filtering, blending between levels by distance and anisotropic voxels, on
//! whatever adapter is present, against their CPU twins.

use glam::{IVec3, Vec3, Vec4};
use octolux::gpu::{GpuContext, GpuOptions, PassTimer};
use octolux::voxel::clipmap::{Clipmap, ClipmapOptions, ClipmapSettings};
use octolux::voxel::clipmap_sample::{
    blend_choice, clip_sample_aniso, clip_sample_blend, clip_sample_blend_with, probe_blend,
};
use octolux::voxel::sample::ClipInfo;
use octolux::voxel::{cpu, VoxelTriangle};

fn context() -> GpuContext {
    GpuContext::new(&GpuOptions::default()).expect("a GPU adapter (install mesa-vulkan-drivers)")
}

fn tri(a: Vec3, b: Vec3, c: Vec3, albedo: [u8; 3]) -> VoxelTriangle {
    VoxelTriangle {
        positions: [a, b, c],
        albedo,
        normal: (b - a).cross(c - a).normalize_or(Vec3::Y),
        emission: Vec3::ZERO,
    }
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * (hi - lo) + Vec3::splat(lo)
    }
}

fn scene() -> Vec<VoxelTriangle> {
    let mut rng = Rng(4242);
    (0..24)
        .map(|i| {
            let c = rng.vec(0.1, 0.9);
            tri(
                c + rng.vec(-0.15, 0.15),
                c + rng.vec(-0.15, 0.15),
                c + rng.vec(-0.15, 0.15),
                [(i * 10) as u8, 255 - (i * 9) as u8, (40 + i * 7) as u8],
            )
        })
        .collect()
}

const SETTINGS: ClipmapSettings = ClipmapSettings {
    resolution: 16,
    levels: 3,
    voxel_size: 1.0 / 32.0,
};

fn build(ctx: &GpuContext, options: ClipmapOptions, tris: &[VoxelTriangle], at: Vec3) -> Clipmap {
    let mut c = Clipmap::with_options(ctx, SETTINGS, options).unwrap();
    let mut timer = PassTimer::new(ctx);
    c.update(ctx, &mut timer, tris, at).unwrap();
    timer.finish_frame().unwrap();
    c
}

fn origins(c: &Clipmap) -> Vec<IVec3> {
    c.origins.iter().map(|o| o.unwrap()).collect()
}

#[test]
fn filtered_levels_equal_cpu_twin_and_incremental_equals_rebuild() {
    let ctx = context();
    let tris = scene();
    let options = ClipmapOptions {
        filtered: true,
        anisotropic: true,
    };
    // An odd finest origin, so that the coarse voxels on the finer level's edge are only
    // partly covered and keep their own voxelization.
    let start = Vec3::new(0.51, 0.49, 0.47);
    let mut clipmap = build(&ctx, options, &tris, start);
    let check = |c: &Clipmap| {
        let o = origins(c);
        let mut reference = cpu::clipmap_voxels(&SETTINGS, &o, &tris);
        let unfiltered = reference.clone();
        cpu::clipmap_filter(&SETTINGS, &o, &mut reference);
        let got = c.read_voxels(&ctx).unwrap();
        let wrong = got.iter().zip(&reference).filter(|(a, b)| a != b).count();
        assert_eq!(wrong, 0, "{wrong} filtered voxels differ from the CPU twin");
        // Filtering changed something: fractional opacity exists on coarse levels.
        assert_ne!(reference, unfiltered);
        let n = 16 * 16 * 16;
        let fractional = got[n..]
            .iter()
            .filter(|&&w| (w >> 24) != 0 && (w >> 24) != 255)
            .count();
        assert!(fractional > 50, "{fractional} partly covered coarse voxels");
        let aniso = cpu::clipmap_aniso(&SETTINGS, &o, &reference);
        let got_aniso = c.read_aniso(&ctx).unwrap();
        assert_eq!(got_aniso.len(), aniso.len());
        let wrong = got_aniso.iter().zip(&aniso).filter(|(a, b)| a != b).count();
        assert_eq!(
            wrong, 0,
            "{wrong} directional values differ from the CPU twin"
        );
    };
    check(&clipmap);
    let mut timer = PassTimer::new(&ctx);
    for step in [
        Vec3::new(3.0, -2.0, 1.0),
        Vec3::new(-1.0, 5.0, 2.0),
        Vec3::new(11.0, 0.0, -9.0),
    ] {
        let at = start + step * SETTINGS.voxel_size;
        clipmap.update(&ctx, &mut timer, &tris, at).unwrap();
        timer.finish_frame().unwrap();
        let fresh = build(&ctx, options, &tris, at);
        assert_eq!(
            clipmap.read_voxels(&ctx).unwrap(),
            fresh.read_voxels(&ctx).unwrap(),
            "incremental filtered clipmap differs from a rebuild"
        );
        assert_eq!(
            clipmap.read_aniso(&ctx).unwrap(),
            fresh.read_aniso(&ctx).unwrap(),
            "incremental directional values differ from a rebuild"
        );
        check(&clipmap);
    }
    // A moving object: revoxelising its boxes keeps the filtered levels consistent.
    let mut moved = tris.clone();
    for t in moved.iter_mut().take(3) {
        for p in t.positions.iter_mut() {
            *p += Vec3::new(0.04, 0.01, -0.03);
        }
    }
    let mut boxes = Vec::new();
    for t in tris.iter().take(3).chain(moved.iter().take(3)) {
        let lo = t.positions[0].min(t.positions[1]).min(t.positions[2]);
        let hi = t.positions[0].max(t.positions[1]).max(t.positions[2]);
        boxes.extend(clipmap.boxes_touching(lo, hi));
    }
    clipmap
        .revoxelise(&ctx, &mut timer, &moved, &boxes)
        .unwrap();
    timer.finish_frame().unwrap();
    let at = start + Vec3::new(11.0, 0.0, -9.0) * SETTINGS.voxel_size;
    let fresh = build(&ctx, options, &moved, at);
    assert_eq!(
        clipmap.read_voxels(&ctx).unwrap(),
        fresh.read_voxels(&ctx).unwrap()
    );
    assert_eq!(
        clipmap.read_aniso(&ctx).unwrap(),
        fresh.read_aniso(&ctx).unwrap()
    );
    // The directional values cost 24 bytes per voxel of levels 1 and up, in the ledger.
    let bytes = clipmap.aniso.as_ref().unwrap().size();
    assert_eq!(bytes, 2 * 16 * 16 * 16 * 24);
    let plain = Clipmap::new(&ctx, SETTINGS).unwrap();
    assert_eq!(clipmap.bytes() - plain.bytes(), bytes);
    assert!(plain.aniso.is_none() && plain.read_aniso(&ctx).unwrap().is_empty());
}

#[test]
fn distance_blend_is_smooth_matches_gpu_and_reads_only_containing_levels() {
    let ctx = context();
    let tris = scene();
    let clipmap = build(
        &ctx,
        ClipmapOptions {
            filtered: true,
            anisotropic: false,
        },
        &tris,
        Vec3::splat(0.45),
    );
    let info = ClipInfo::new(&clipmap.settings, &clipmap.origins);
    let voxels = clipmap.read_voxels(&ctx).unwrap();
    let mut rng = Rng(99);
    let points: Vec<Vec4> = (0..500)
        .map(|i| {
            rng.vec(-0.1, 1.1)
                .extend([0.01, 1.0 / 32.0, 0.05, 1.0 / 16.0, 0.2][i % 5])
        })
        .collect();
    let gpu = probe_blend(&ctx, &clipmap, &points, None).unwrap();
    let mut nonzero = 0;
    let mut partial = 0;
    let o = origins(&clipmap);
    for (p, g) in points.iter().zip(&gpu) {
        let c = clip_sample_blend(&info, &voxels, p.truncate(), p.w);
        assert!(
            (*g - c).abs().max_element() < 1e-4,
            "at {p}: GPU {g} CPU {c}"
        );
        nonzero += (c.w > 0.0) as u32;
        if let Some((_, w)) = blend_choice(&info, p.truncate(), p.w) {
            partial += (w > 0.0 && w < 1.0) as u32;
        }
        // Every voxel read lies inside its level.
        clip_sample_blend_with(&info, p.truncate(), p.w, |l, g| {
            let lo = o[l as usize];
            assert!(
                g.cmpge(lo).all() && g.cmplt(lo + IVec3::splat(16)).all(),
                "level {l} read outside its extent at {g} for {p}"
            );
            Vec4::ONE
        });
    }
    assert!(nonzero > 50, "only {nonzero} non-empty samples");
    assert!(partial > 10, "only {partial} samples in a blend band");
    // Walking out of level 0 with a fine footprint: the weight of level 1 rises smoothly from
    // 0 to 1 and reaches 1 on the border, so the value is continuous where level 0 ends.
    let hi0 = (o[0].x + 16) as f32 * SETTINGS.voxel_size - 0.5 * SETTINGS.voxel_size;
    let mut last = 0.0f32;
    let mut x = hi0 - 4.0 * SETTINGS.voxel_size;
    while x < hi0 - 1e-4 {
        let p = Vec3::new(x, 0.45, 0.45);
        let (l, w) = blend_choice(&info, p, 0.001).unwrap();
        assert_eq!(l, 0);
        assert!(
            w >= last - 1e-6 && w - last < 0.2,
            "weight jumps to {w} at {x}"
        );
        last = w;
        x += 0.05 * SETTINGS.voxel_size;
    }
    assert!(last > 0.98, "weight {last} at the border");
    let inside = Vec3::new(hi0 - 0.501 * SETTINGS.voxel_size, 0.45, 0.45);
    let outside = inside + Vec3::X * 0.002 * SETTINGS.voxel_size;
    let a = clip_sample_blend(&info, &voxels, inside, 0.001);
    let b = clip_sample_blend(&info, &voxels, outside, 0.001);
    assert!(
        (a - b).abs().max_element() < 0.02,
        "{a} vs {b} across the border"
    );
}

/// A thin red wall in front of a green one, one finest voxel apart, inside one level-1 voxel.
fn walls() -> Vec<VoxelTriangle> {
    let v = SETTINGS.voxel_size;
    let wall = |x: f32, albedo: [u8; 3]| {
        let (lo, hi) = (0.3, 0.7);
        let a = Vec3::new(x, lo, lo);
        let b = Vec3::new(x, hi, lo);
        let c = Vec3::new(x, hi, hi);
        let d = Vec3::new(x, lo, hi);
        vec![tri(a, b, c, albedo), tri(a, c, d, albedo)]
    };
    let mut tris = wall(16.5 * v, [255, 0, 0]);
    tris.extend(wall(17.5 * v, [0, 255, 0]));
    tris
}

#[test]
fn anisotropic_voxels_keep_the_front_colour() {
    let ctx = context();
    let tris = walls();
    let clipmap = build(
        &ctx,
        ClipmapOptions {
            filtered: false,
            anisotropic: true,
        },
        &tris,
        Vec3::splat(0.5),
    );
    let info = ClipInfo::new(&clipmap.settings, &clipmap.origins);
    let voxels = clipmap.read_voxels(&ctx).unwrap();
    let aniso = clipmap.read_aniso(&ctx).unwrap();
    // The centre of level-1 voxel (8, 8, 8), which holds both walls; footprint = its size.
    let p = Vec3::splat(8.5 / 16.0);
    let f = 1.0 / 16.0;
    let red = Vec4::new(1.0, 0.0, 0.0, 1.0);
    let green = Vec4::new(0.0, 1.0, 0.0, 1.0);
    let dirs = [Vec3::X, Vec3::NEG_X, Vec3::new(1.0, 0.3, -0.2), Vec3::Y];
    let cpu: Vec<Vec4> = dirs
        .iter()
        .map(|&d| clip_sample_aniso(&info, &voxels, &aniso, p, f, d))
        .collect();
    let gpu = probe_blend(&ctx, &clipmap, &[p.extend(f); 4], Some(&dirs)).unwrap();
    for (g, c) in gpu.iter().zip(&cpu) {
        assert!((*g - *c).abs().max_element() < 1e-4, "GPU {g} CPU {c}");
    }
    assert!(
        (cpu[0] - red).abs().max_element() < 0.01,
        "from -x: {}",
        cpu[0]
    );
    assert!(
        (cpu[1] - green).abs().max_element() < 0.01,
        "from +x: {}",
        cpu[1]
    );
    // Mostly along +x: mostly red; along y the walls are side by side: half coverage each.
    assert!(cpu[2].x > 0.6 && cpu[2].y < 0.3, "oblique: {}", cpu[2]);
    assert!((cpu[3] - Vec4::new(0.5, 0.5, 0.0, 1.0)).abs().max_element() < 0.01);
    // The isotropic average mixes the two whichever side it is seen from.
    let iso = clip_sample_blend(&info, &voxels, p, f);
    assert!(
        (iso - Vec4::new(0.5, 0.5, 0.0, 1.0)).abs().max_element() < 0.01,
        "{iso}"
    );
}
