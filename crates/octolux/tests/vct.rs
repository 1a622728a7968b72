//! `vct-svo` (also with anisotropic radiance) and `vct-clipmap` on the Cornell box against the
//! one-bounce reference: each
//! lights the ceiling, which the spot light does not reach (within a factor 2 of the
//! reference), and its image is closer to the reference than no GI at all in relMSE and FLIP.
//! Their ambient occlusion closes in corners; the specular cone sees the lit walls. Bad
//! settings are clear errors.

use glam::Vec3;
use octolux::gi::GiSettings;
use octolux::gpu::{GpuContext, GpuOptions};
use octolux::image_io::HdrImage;
use octolux::metrics::{flip, rel_mse, MetricOptions};
use octolux::reference::ReferenceSettings;
use octolux::render::{Output, RenderSettings, Renderer};
use octolux::transport::Bounces;

const SIZE: u32 = 48;

fn settings(gi: &str, vct: octolux::gi::vct::VctSettings) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        gi: gi.into(),
        gi_settings: GiSettings {
            vct,
            ..GiSettings::default()
        },
        ..RenderSettings::default()
    }
}

/// The pixels of the ceiling (surfaces facing down), which only the bounce lights.
fn ceiling_mask(r: &Renderer) -> Vec<bool> {
    let g = r.read_gbuffer().unwrap();
    g.normal
        .iter()
        .zip(&g.depth)
        .map(|(n, &d)| d < 1.0 && n.dot(Vec3::NEG_Y) > 0.9)
        .collect()
}

fn mean_over(image: &HdrImage, mask: &[bool]) -> f32 {
    let (sum, n) = image
        .pixels
        .iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .fold((0.0, 0), |(s, n), (p, _)| {
            (s + p.element_sum() / 3.0, n + 1)
        });
    sum / n.max(1) as f32
}

#[test]
fn cornell_box_ceiling_is_lit_and_the_image_beats_no_gi() {
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let scene = octolux::scene::cornell::scene();
    // Smaller than the defaults (clipmap 64^3 x 4 levels, octree 128^3), which lavapipe
    // injects slowly.
    let vct = small();
    // The octree also with its anisotropic radiance (not its default).
    let anisotropic = octolux::gi::vct::VctSettings {
        anisotropic: true,
        ..small()
    };
    let variants = [
        ("none", &vct),
        ("vct-svo", &vct),
        ("vct-clipmap", &vct),
        ("vct-svo", &anisotropic),
    ];
    let techniques = ["none", "vct-svo", "vct-clipmap", "vct-svo (anisotropic)"];
    let mut images = Vec::new();
    let mut mask = Vec::new();
    for (technique, vct) in variants {
        let mut r = Renderer::new(&ctx, &scene, settings(technique, vct.clone())).unwrap();
        r.render(&scene, 0.0).unwrap();
        mask = ceiling_mask(&r);
        images.push(r.read_hdr().unwrap());
    }
    let reference = octolux::reference::render(
        &scene,
        &scene.frame(0.0, 0),
        SIZE,
        SIZE,
        &ReferenceSettings {
            spp: 256,
            bounces: Bounces::Indirect(1),
            ..ReferenceSettings::default()
        },
        &|_, _| {},
    )
    .unwrap()
    .total;
    let expected = mean_over(&reference, &mask);
    assert_eq!(
        mean_over(&images[0], &mask),
        0.0,
        "no direct light on the ceiling"
    );
    let options = MetricOptions::default();
    let none_rel = rel_mse(&images[0], &reference, None).unwrap();
    let none_flip = flip(&images[0], &reference, None, &options).unwrap();
    for (technique, image) in techniques.iter().zip(&images).skip(1) {
        let got = mean_over(image, &mask);
        let rel = rel_mse(image, &reference, None).unwrap();
        let fl = flip(image, &reference, None, &options).unwrap();
        println!(
            "{technique}: ceiling radiance {got} (reference {expected}); relMSE {rel:.4} \
             (none {none_rel:.4}), FLIP {fl:.4} (none {none_flip:.4})"
        );
        assert!(
            (0.5..2.0).contains(&(got / expected)),
            "ceiling: {technique} {got}, reference {expected}"
        );
        assert!(
            rel < 0.8 * none_rel,
            "{technique}: relMSE {rel} vs none {none_rel}"
        );
        assert!(fl < none_flip, "{technique}: FLIP {fl} vs none {none_flip}");
    }
}

/// Cone-tracing settings small enough for lavapipe: clipmap 32^3 x 3 levels, octree 64^3.
fn small() -> octolux::gi::vct::VctSettings {
    octolux::gi::vct::VctSettings {
        resolution: 32,
        levels: 3,
        octree_resolution: 64,
        ..Default::default()
    }
}

#[test]
fn ambient_occlusion_sees_the_closed_box_and_the_specular_cone_sees_the_walls() {
    // AO (the indirect image's alpha) is 1 - the cosine-weighted opacity the six cones gather:
    // in [0, 1] everywhere, and neither open nor closed in the box (below). The specular cone (every pixel, full resolution) reflects the
    // lit walls: the floor's mirror image of the red left wall is red.
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let scene = octolux::scene::cornell::scene();
    for technique in ["vct-svo", "vct-clipmap"] {
        let vct = octolux::gi::vct::VctSettings {
            sparse: 1,
            specular: true,
            roughness: 0.2,
            ..small()
        };
        let mut r = Renderer::new(&ctx, &scene, settings(technique, vct)).unwrap();
        r.set_output(Output::AmbientOcclusion);
        r.render(&scene, 0.0).unwrap();
        let ao = r.read_hdr().unwrap();
        let g = r.read_gbuffer().unwrap();
        r.set_output(Output::Specular);
        r.render(&scene, 0.0).unwrap();
        let specular = r.read_hdr().unwrap();
        let at = |x: u32, y: u32| (y * SIZE + x) as usize;
        let floor: Vec<(u32, u32)> = (0..SIZE * SIZE)
            .filter(|&i| g.depth[i as usize] < 1.0 && g.normal[i as usize].y > 0.9)
            .map(|i| (i % SIZE, i / SIZE))
            .collect();
        let mean_ao = |facing: Vec3| {
            let v: Vec<f32> = (0..(SIZE * SIZE) as usize)
                .filter(|&i| g.depth[i] < 1.0 && g.normal[i].dot(facing) > 0.9)
                .map(|i| ao.pixels[i].x)
                .collect();
            v.iter().sum::<f32>() / v.len().max(1) as f32
        };
        // The box is closed on five sides: from the back wall's middle the open side
        // subtends a cosine-weighted fraction of about 0.2 of the hemisphere, from the floor
        // and the side walls less. So AO is well below 1 (a technique that wrote no occlusion
        // gives 1) and above 0 (cones that all stopped on the surface's own voxels give 0).
        // The upper bound is 0.6: the default 16 cones of 36 degrees, started 2 voxels out,
        // see more of the open side through the small clipmap's coarse voxels than the six
        // of 60 (back wall measured 0.52 against 0.44; octree 0.40 against 0.27).
        let (back, floor_ao) = (mean_ao(Vec3::NEG_Z), mean_ao(Vec3::Y));
        println!("{technique}: AO back wall {back}, floor {floor_ao}");
        for v in [back, floor_ao] {
            assert!(
                (0.05..0.6).contains(&v),
                "{technique}: AO {back}, {floor_ao}"
            );
        }
        assert!(ao
            .pixels
            .iter()
            .zip(&g.depth)
            .all(|(p, &d)| d >= 1.0 || (p.x >= 0.0 && p.x <= 1.0)));
        let row = floor.iter().map(|p| p.1).max().unwrap();
        let xs: Vec<u32> = floor.iter().filter(|p| p.1 == row).map(|p| p.0).collect();
        let (left, right) = (*xs.iter().min().unwrap(), *xs.iter().max().unwrap());
        // Left half of the floor: its mirror direction (towards the camera's far side)
        // meets the red wall more than the green one.
        let reflected = floor
            .iter()
            .filter(|p| p.0 < (left + right) / 2 && p.1 + 4 > row)
            .fold(Vec3::ZERO, |s, p| s + specular.pixels[at(p.0, p.1)]);
        println!("{technique}: specular on the floor's left {reflected}");
        assert!(reflected.x > 1.5 * reflected.y, "{technique}: {reflected}");
    }
}

#[test]
fn a_denser_cone_set_gathers_what_the_six_cones_gather() {
    // 16 cosine-distributed cones of 36 degrees against 003's six of 60 on the octree, both
    // started 2 voxels out (the octree's default): both light the ceiling alike (measured
    // 0.240 and 0.198) and the images differ by relMSE 0.0077, a tenth of the default's
    // error against the reference (0.080, the test above): the set changes the quadrature,
    // not the light.
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let scene = octolux::scene::cornell::scene();
    let mut images = Vec::new();
    let mut mask = Vec::new();
    for (cones, aperture) in [(6, 60.0), (16, 36.0)] {
        let vct = octolux::gi::vct::VctSettings {
            cones: Some(cones),
            aperture: Some(aperture),
            ..small()
        };
        let mut r = Renderer::new(&ctx, &scene, settings("vct-svo", vct)).unwrap();
        r.render(&scene, 0.0).unwrap();
        mask = ceiling_mask(&r);
        images.push(r.read_hdr().unwrap());
    }
    let between = rel_mse(&images[1], &images[0], None).unwrap();
    let (six, dense) = (mean_over(&images[0], &mask), mean_over(&images[1], &mask));
    println!("ceiling: 6 cones {six}, 16 cones {dense}; relMSE between {between:.4}");
    assert!(dense > 0.5 * six && dense < 2.0 * six, "{six} vs {dense}");
    assert!(between < 0.03, "{between}");
}

#[test]
fn multiple_bounces_converge_to_the_unlimited_reference() {
    // With multi_bounce the voxels (the octree's static leaves, every clipmap voxel) gather
    // indirect irradiance every frame and add it to their direct light at the next injection:
    // frame 1 is one bounce, frame k holds k bounces. After 10 frames on the Cornell box
    // (48x48, octree 64^3; without multiple bounces its first frame, the same picture) against
    // the unlimited reference, the ceiling's radiance and FLIP with and without: see
    // `BounceBounds`.
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let scene = octolux::scene::cornell::scene();
    let reference = octolux::reference::render(
        &scene,
        &scene.frame(0.0, 0),
        SIZE,
        SIZE,
        &ReferenceSettings {
            spp: 256,
            bounces: Bounces::Unlimited,
            ..ReferenceSettings::default()
        },
        &|_, _| {},
    )
    .unwrap()
    .total;
    for (technique, bounds) in [
        ("vct-svo", BounceBounds::SVO),
        ("vct-clipmap", BounceBounds::CLIPMAP),
    ] {
        let mut results = Vec::new();
        for multi_bounce in [false, true] {
            let vct = octolux::gi::vct::VctSettings {
                multi_bounce,
                ..small()
            };
            let mut r = Renderer::new(&ctx, &scene, settings(technique, vct)).unwrap();
            let expected = if multi_bounce {
                Bounces::Unlimited
            } else {
                Bounces::Indirect(1)
            };
            assert_eq!(r.technique().reference_transport().bounces, expected);
            // One bounce is whole in the first frame (its settling count is 0); multiple
            // bounces get 10.
            let frames = if multi_bounce { 10 } else { 1 };
            assert_eq!(r.technique().settle_frames() == 0, !multi_bounce);
            for _ in 0..frames {
                r.render(&scene, 0.0).unwrap();
            }
            let mask = ceiling_mask(&r);
            let image = r.read_hdr().unwrap();
            let fl = flip(&image, &reference, None, &MetricOptions::default()).unwrap();
            let rel = rel_mse(&image, &reference, None).unwrap();
            let ceiling = mean_over(&image, &mask) / mean_over(&reference, &mask);
            println!(
                "{technique} multi_bounce {multi_bounce}: ceiling / reference {ceiling:.3}, \
                 FLIP {fl:.4}, relMSE {rel:.4}"
            );
            results.push((ceiling, fl));
        }
        let (one, multi) = (results[0], results[1]);
        assert!(
            bounds.ceiling.contains(&multi.0),
            "{technique}: ceiling {}",
            multi.0
        );
        assert!(
            one.0 < bounds.one_bounce_below * multi.0,
            "{technique}: one bounce lights the ceiling {} (multiple {})",
            one.0,
            multi.0
        );
        assert!(
            multi.1 < bounds.flip_ratio * one.1,
            "{technique}: FLIP {} vs one bounce {}",
            multi.1,
            one.1
        );
    }
}

/// `bounce_frames`: the voxels' bounce gather spread over frames. After the first 3 frames
/// (every voxel gathers while the light starts from nothing), with N sets every N
/// consecutive frames gather exactly the voxels one frame gathers with N = 1 (each voxel
/// once: the counts sum to it, every frame a share near 1 / N, the same share again N frames
/// later), and the light converges to the same image, by the frame the technique says it
/// has settled.
#[test]
fn the_bounce_gather_spread_over_frames_visits_every_voxel_once_a_round_and_converges_alike() {
    let scene = octolux::scene::cornell::scene();
    // Frames run past the settling count, to see the picture hold: with 3 sets, 21 + 6 = 27
    // (eight rounds of the spread gather after the first 3 frames).
    const PAST_SETTLED: usize = 6;
    for technique in ["vct-svo", "vct-clipmap"] {
        // A counter per technique: both name their gather's counts `bounce`.
        let ctx = GpuContext::shared(&GpuOptions::default())
            .expect("a GPU adapter (install mesa-vulkan-drivers)")
            .with_work_counter();
        let mut gathered = Vec::new();
        let mut images = Vec::new();
        for sets in [1, 3] {
            let vct = octolux::gi::vct::VctSettings {
                bounce_frames: sets,
                ..small()
            };
            let mut r = Renderer::new(&ctx, &scene, settings(technique, vct)).unwrap();
            ctx.work().unwrap().take(&ctx).unwrap();
            let mut voxels = Vec::new();
            let settle = r.technique().settle_frames() as usize;
            let mut settled = None;
            for frame in 1..=settle + PAST_SETTLED {
                r.render(&scene, 0.0).unwrap();
                let counts = ctx.work().unwrap().take(&ctx).unwrap();
                let c = counts
                    .iter()
                    .find(|c| c.pass == "bounce" && c.quantity == "voxels")
                    .map_or(0, |c| c.count);
                voxels.push(c);
                if frame == settle + 1 {
                    settled = Some(r.read_hdr().unwrap());
                }
            }
            gathered.push(voxels);
            let last = r.read_hdr().unwrap();
            // What `octolux render` writes (the frame after `settle_frames`) is the picture
            // the bounces converge to: a hundredth of the least error the tables judge.
            let settled = settled.unwrap_or_else(|| panic!("{technique}: settles in {settle}"));
            let left = rel_mse(&settled, &last, None).unwrap();
            println!("{technique}, {sets} sets: settled after {settle} frames, {left:.1e} left");
            assert!(
                left < 1e-4,
                "{technique}, {sets} sets: {left} after {settle}"
            );
            images.push(last);
        }
        let all = gathered[0][0];
        assert!(all > 100, "{technique}: {all} voxels gather");
        assert!(gathered[0].iter().all(|&c| c == all), "{gathered:?}");
        let (start, spread) = gathered[1].split_at(3);
        assert!(start.iter().all(|&c| c == all), "{technique}: {start:?}");
        for (f, &c) in spread.iter().enumerate() {
            let share = c as f64 / all as f64;
            assert!(
                (0.25..0.42).contains(&share),
                "{technique} frame {f}: {spread:?}"
            );
            if f >= 3 {
                assert_eq!(c, spread[f - 3], "{technique} frame {f}: {spread:?}");
            }
        }
        for round in spread.chunks(3) {
            assert_eq!(round.iter().sum::<u64>(), all, "{technique}: {spread:?}");
        }
        let apart = rel_mse(&images[1], &images[0], None).unwrap();
        println!("{technique}: {all} voxels, per frame with 3 sets {spread:?}, relMSE {apart:.2e}");
        assert!(
            apart < 1e-3,
            "{technique}: relMSE {apart} between the converged images"
        );
    }
}

/// What multiple bounces must reach on the Cornell box (`multiple_bounces_converge_...`):
/// the ceiling's radiance over the unlimited reference's, the most one bounce may light it
/// relative to multiple bounces, and the most FLIP may be relative to one bounce.
struct BounceBounds {
    ceiling: std::ops::Range<f32>,
    one_bounce_below: f32,
    flip_ratio: f64,
}

impl BounceBounds {
    // Measured (default cones: 64 for the pixels, 16 for the voxels' bounce gather): ceiling
    // 1.082 against one bounce's 0.776 (the ratio, 0.72, is about what one bounce is of all
    // of them in the reference, where more bounces add about 37 %), FLIP 0.260 against 0.415.
    const SVO: BounceBounds = BounceBounds {
        ceiling: 0.85..1.15,
        one_bounce_below: 0.8,
        flip_ratio: 0.8,
    };
    // Measured (default cones: 16 with multiple bounces, six with one): ceiling 0.626 (one
    // bounce 0.476: the clipmap's one-bounce gather is short on the ceiling already, and
    // more bounces add what the reference adds, 32 % against 37 %), FLIP 0.367 against one
    // bounce's 0.448.
    const CLIPMAP: BounceBounds = BounceBounds {
        ceiling: 0.55..1.15,
        one_bounce_below: 0.85,
        flip_ratio: 0.85,
    };
}

/// The clipmap's bounce store follows its scrolling: after the camera moves, the voxel slots
/// the clipmap revoxelised (wrapped to new voxels) hold exactly the direct light a renderer
/// without multiple bounces injects there, while voxels it kept carry bounce light.
#[test]
fn clipmap_bounce_light_is_dropped_where_the_clipmap_scrolled() {
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    // The camera inside the box, so that the finest levels hold geometry (the blocks, the
    // floor) where they scroll.
    let mut scene = octolux::scene::cornell::scene();
    let start = Vec3::new(0.278, 0.15, 0.3);
    scene.cameras[0].target = Vec3::new(0.278, 0.15, 0.56);
    let mut radiance = Vec::new();
    let mut boxes = Vec::new();
    let mut res = 0;
    for multi_bounce in [false, true] {
        let vct = octolux::gi::vct::VctSettings {
            multi_bounce,
            ..small()
        };
        scene.cameras[0].position = start;
        let mut r = Renderer::new(&ctx, &scene, settings("vct-clipmap", vct)).unwrap();
        for _ in 0..4 {
            r.render(&scene, 0.0).unwrap();
        }
        // Sideways by a seventh of the box: every level scrolls.
        scene.cameras[0].position = start + Vec3::new(0.08, 0.0, 0.0);
        r.render(&scene, 0.0).unwrap();
        let technique = r
            .technique()
            .as_any()
            .and_then(|a| a.downcast_ref::<octolux::gi::vct::VctClipmap>())
            .expect("vct-clipmap");
        let clipmap = technique.clipmap().expect("made at the first frame");
        radiance.push(clipmap.read_radiance(&ctx).unwrap());
        boxes = clipmap.last_revoxelised().to_vec();
        res = clipmap.settings.resolution as i32;
    }
    let slots = res.pow(3) as usize;
    let mut exposed = vec![false; radiance[0].len()];
    for b in &boxes {
        for z in b.lo.z..b.hi.z {
            for y in b.lo.y..b.hi.y {
                for x in b.lo.x..b.hi.x {
                    let m = glam::IVec3::new(x, y, z).rem_euclid(glam::IVec3::splat(res));
                    let slot = b.level as usize * slots + (m.x + res * (m.y + res * m.z)) as usize;
                    exposed[slot] = true;
                }
            }
        }
    }
    let (one, multi) = (&radiance[0], &radiance[1]);
    let (mut checked, mut brighter) = (0, 0);
    for i in 0..one.len() {
        if one[i].w == 0.0 {
            continue;
        }
        if exposed[i] {
            assert_eq!(one[i], multi[i], "revoxelised slot {i}");
            checked += 1;
        } else if multi[i].truncate().element_sum() > one[i].truncate().element_sum() + 1e-3 {
            brighter += 1;
        }
    }
    println!("{checked} occupied revoxelised slots equal, {brighter} kept slots brighter");
    assert!(boxes.len() >= 3, "{} boxes", boxes.len());
    assert!(checked > 50 && brighter > 1000, "{checked} / {brighter}");
}

#[test]
fn sparse_tracing_reconstructs_every_pixel_close_to_full_tracing() {
    // One traced pixel per 4 x 4 block, the rest from the traced neighbours by depth and
    // normal: every surface pixel gets light, and the image stays close to tracing every
    // pixel. At 48x48 only 12x12 pixels are traced, so the two differ (relMSE 0.010
    // measured with the default 16 cones, 0.021 with the six); the bound, 0.04, is a third of
    // full tracing's own error against the reference at this size (0.112, the test above), and a reconstruction that lost the
    // light (zeros) or misplaced it across the box's edges gives several times that.
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let scene = octolux::scene::cornell::scene();
    let mut images = Vec::new();
    let mut depth = Vec::new();
    for sparse in [1, 4] {
        let vct = octolux::gi::vct::VctSettings {
            resolution: 32,
            levels: 3,
            sparse,
            ..Default::default()
        };
        let mut r = Renderer::new(&ctx, &scene, settings("vct-clipmap", vct)).unwrap();
        r.render(&scene, 0.0).unwrap();
        depth = r.read_gbuffer().unwrap().depth;
        let hdr = r.read_hdr().unwrap();
        let direct = r.read_direct().unwrap();
        let mut indirect = hdr.clone();
        for (p, d) in indirect.pixels.iter_mut().zip(&direct.pixels) {
            *p -= *d;
        }
        images.push((hdr, indirect));
    }
    let unlit = images[1]
        .1
        .pixels
        .iter()
        .zip(&depth)
        .filter(|(p, &d)| d < 1.0 && p.max_element() <= 0.0)
        .count();
    let surfaces = depth.iter().filter(|&&d| d < 1.0).count();
    assert!(
        unlit * 50 < surfaces,
        "{unlit} of {surfaces} surface pixels got no indirect light"
    );
    let difference = rel_mse(&images[1].0, &images[0].0, None).unwrap();
    println!("relMSE of sparse 4 against full tracing: {difference:.5}");
    assert!(difference < 0.04, "{difference}");
}

#[test]
fn bad_vct_settings_are_clear_errors() {
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let scene = octolux::scene::cornell::scene();
    let cases: Vec<(octolux::gi::vct::VctSettings, &str)> = vec![
        (
            octolux::gi::vct::VctSettings {
                resolution: 48,
                ..Default::default()
            },
            "vct resolution",
        ),
        (
            octolux::gi::vct::VctSettings {
                levels: 0,
                ..Default::default()
            },
            "vct levels",
        ),
        (
            octolux::gi::vct::VctSettings {
                aperture: Some(f32::NAN),
                ..Default::default()
            },
            "vct aperture",
        ),
        (
            octolux::gi::vct::VctSettings {
                step: 0.0,
                ..Default::default()
            },
            "vct step",
        ),
        (
            octolux::gi::vct::VctSettings {
                sparse: 17,
                ..Default::default()
            },
            "vct sparse",
        ),
        (
            octolux::gi::vct::VctSettings {
                octree_resolution: 1024,
                ..Default::default()
            },
            "vct octree_resolution",
        ),
        (
            octolux::gi::vct::VctSettings {
                cones: Some(7),
                ..Default::default()
            },
            "vct cones",
        ),
        (
            octolux::gi::vct::VctSettings {
                start: Some(-1.0),
                ..Default::default()
            },
            "vct start",
        ),
        (
            octolux::gi::vct::VctSettings {
                roughness: -0.5,
                ..Default::default()
            },
            "vct roughness",
        ),
        (
            octolux::gi::vct::VctSettings {
                dynamic_reserve: 0,
                ..Default::default()
            },
            "vct dynamic_reserve",
        ),
        (
            octolux::gi::vct::VctSettings {
                specular_steps: 64,
                ..Default::default()
            },
            "vct specular_steps",
        ),
        (
            octolux::gi::vct::VctSettings {
                specular: true,
                specular_steps: 5000,
                ..Default::default()
            },
            "vct specular_steps",
        ),
    ];
    for technique in ["vct-svo", "vct-clipmap"] {
        for (vct, what) in &cases {
            let err = Renderer::new(&ctx, &scene, settings(technique, vct.clone()))
                .err()
                .expect("must fail");
            assert!(err.to_string().contains(what), "{technique}: {err}");
        }
    }
    // Unknown keys in a scene file's [settings.vct] are errors that name the key.
    let table: toml::Table = toml::from_str("[vct]\ncone_count = 6\n").unwrap();
    let err =
        GiSettings::from_table(&table, std::path::Path::new("scene.toml")).expect_err("must fail");
    assert!(err.to_string().contains("cone_count"), "{err}");
    let table: toml::Table = toml::from_str("[vct]\ninjection = \"rays\"\n").unwrap();
    let err =
        GiSettings::from_table(&table, std::path::Path::new("scene.toml")).expect_err("must fail");
    assert!(err.to_string().contains("shadow-maps"), "{err}");
}

#[test]
fn a_fixed_work_specular_cone_takes_its_steps_and_no_more() {
    // `specular_steps` = N: the cone takes exactly N samples and never stops early, so the
    // march of N samples is the start of the march of M > N (radiance only grows along a
    // cone: every pixel's radiance with 1 step <= with 8 <= with 512), and with enough steps
    // the floor's left half still reflects the red wall. The cones start 1.5 voxels out (the
    // start offset is the diffuse cones'): 2 voxels out, the clipmap's first sample already
    // lies where 512 steps take only 1.7 times as much, and the factor 2 below would not tell
    // one step from many.
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let scene = octolux::scene::cornell::scene();
    for technique in ["vct-svo", "vct-clipmap"] {
        let specular = |steps: u32| {
            let vct = octolux::gi::vct::VctSettings {
                sparse: 8,
                specular: true,
                roughness: 0.0,
                specular_steps: steps,
                start: Some(1.5),
                ..small()
            };
            let mut r = Renderer::new(&ctx, &scene, settings(technique, vct)).unwrap();
            r.set_output(Output::Specular);
            r.render(&scene, 0.0).unwrap();
            (r.read_hdr().unwrap(), r.read_gbuffer().unwrap())
        };
        let (one, g) = specular(1);
        let (eight, _) = specular(8);
        let (many, _) = specular(512);
        let sum = |img: &HdrImage| img.pixels.iter().map(|p| p.element_sum()).sum::<f32>();
        for i in 0..one.pixels.len() {
            let (a, b, c) = (one.pixels[i], eight.pixels[i], many.pixels[i]);
            assert!(
                a.cmple(b + 1e-3).all() && b.cmple(c + 1e-3).all(),
                "{technique}: pixel {i}: {a} / {b} / {c}"
            );
        }
        println!(
            "{technique}: specular sum 1 / 8 / 512 steps: {} / {} / {}",
            sum(&one),
            sum(&eight),
            sum(&many)
        );
        assert!(sum(&many) > 2.0 * sum(&one), "{technique}");
        // As in the test above: the floor's front rows, left half.
        let floor: Vec<(u32, u32)> = (0..SIZE * SIZE)
            .filter(|&i| g.depth[i as usize] < 1.0 && g.normal[i as usize].y > 0.9)
            .map(|i| (i % SIZE, i / SIZE))
            .collect();
        let row = floor.iter().map(|p| p.1).max().unwrap();
        let xs: Vec<u32> = floor.iter().filter(|p| p.1 == row).map(|p| p.0).collect();
        let mid = (xs.iter().min().unwrap() + xs.iter().max().unwrap()) / 2;
        let left_floor = floor
            .iter()
            .filter(|p| p.0 < mid && p.1 + 4 > row)
            .fold(Vec3::ZERO, |s, p| {
                s + many.pixels[(p.1 * SIZE + p.0) as usize]
            });
        assert!(
            left_floor.x > 1.5 * left_floor.y,
            "{technique}: {left_floor}"
        );
    }
}

#[test]
fn anisotropic_bounce_changes_only_the_voxels_bounce() {
    // `anisotropic_bounce` routes the anisotropic radiance to the voxels' bounce gather alone:
    // with one bounce (no voxel gathers) the image is the isotropic one bit for bit; with
    // multiple bounces it differs from the isotropic image (the voxels' bounce reads the
    // directional values) and from the fully anisotropic one (the pixels' cones do not).
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let scene = octolux::scene::cornell::scene();
    let image = |multi_bounce: bool, anisotropic: bool, anisotropic_bounce: bool| {
        let vct = octolux::gi::vct::VctSettings {
            multi_bounce,
            anisotropic,
            anisotropic_bounce,
            ..small()
        };
        let mut r = Renderer::new(&ctx, &scene, settings("vct-svo", vct)).unwrap();
        // The second frame's injection holds the first frame's voxel bounce.
        for _ in 0..2 {
            r.render(&scene, 0.0).unwrap();
        }
        r.read_hdr().unwrap().pixels
    };
    let table: toml::Table = toml::from_str("[vct]\nanisotropic_bounce = true\n").unwrap();
    let parsed = GiSettings::from_table(&table, std::path::Path::new("scene.toml")).unwrap();
    assert!(parsed.vct.anisotropic_bounce && !parsed.vct.anisotropic);
    assert_eq!(image(false, false, true), image(false, false, false));
    let iso = image(true, false, false);
    let bounce = image(true, false, true);
    let all = image(true, true, false);
    let differing = |a: &[Vec3], b: &[Vec3]| a.iter().zip(b).filter(|(x, y)| x != y).count();
    let (from_iso, from_all) = (differing(&bounce, &iso), differing(&bounce, &all));
    println!(
        "anisotropic bounce: {from_iso} pixels differ from isotropic, {from_all} from anisotropic"
    );
    assert!(bounce.iter().all(|p| p.is_finite()));
    assert!(from_iso * 4 > bounce.len() && from_all * 4 > bounce.len());
}
