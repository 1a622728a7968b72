//! Rooms the techniques were not tuned on (`scenes/meeting-room.toml`, `stone-church.toml`,
//! `living-room.toml`, built of boxes by `scripts/make-rooms.py`): a closed room full of
//! small furniture lit by downlights, a stone nave lit by the sun through its windows, a
//! furnished room lit through one window. In each, `probes-octree` and `vct-svo` (and in the
//! church the default technique, below) must end closer to the unlimited reference than GI off
//! (relMSE of the settled frame; the fourth frame's is printed beside it), and light every
//! pixel that the reference's indirect light reaches clearly.
//!
//! What this caught: `vct-svo` read the sunlit outside of the church and the living room
//! (roof, outer walls, the ground) through their walls with its coarse cones, many times
//! GI off's error, until the radiance's facing became its default; `probes-octree` left the
//! living room, lower than the cells of its complete levels, in those coarse cells and
//! gathered probes above its ceiling and beyond its walls (patches brighter and darker than
//! GI off), until a quarter of a probe's surfels in its cube split its leaf; with one bounce
//! it left the living room's sunlit floor unlit (only twice-bounced light reaches it), and
//! with multiple bounces over the complete levels of depth 2 (cells of metres over the
//! ground around the church) it lit the church brighter than GI off is wrong, until both
//! became its defaults with the levels complete down to depth 3.

use glam::Vec3;
use octolux::gpu::{GpuContext, GpuOptions};
use octolux::image_io::HdrImage;
use octolux::metrics::rel_mse;
use octolux::reference::{ReferenceImages, ReferenceSettings};
use octolux::render::{Output, RenderSettings, Renderer};
use octolux::scene::Scene;
use octolux::transport::Bounces;

const WIDTH: u32 = 64;
const HEIGHT: u32 = 36;
/// The early frame reported beside the settled one (the 160x90 table's fourth frame).
const EARLY_FRAME: u32 = 4;
const TECHNIQUES: [&str; 3] = ["probes-grid", "probes-octree", "vct-svo"];

fn scene(name: &str) -> Scene {
    let path = format!("{}/../../scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn reference(scene: &Scene) -> ReferenceImages {
    octolux::reference::render(
        scene,
        &scene.frame(0.0, 0),
        WIDTH,
        HEIGHT,
        &ReferenceSettings {
            spp: 512,
            bounces: Bounces::Unlimited,
            seed: 5,
            ..ReferenceSettings::default()
        },
        &|_, _| {},
    )
    .unwrap()
}

/// The technique's frame at [`EARLY_FRAME`], and its frame and indirect irradiance once
/// settled (after its own settling count, at least the early frame).
fn render(ctx: &GpuContext, scene: &Scene, gi: &str) -> (HdrImage, HdrImage, HdrImage) {
    let settings = RenderSettings {
        width: WIDTH,
        height: HEIGHT,
        gi: gi.into(),
        ..RenderSettings::default()
    };
    let mut r = Renderer::new(ctx, scene, settings).unwrap();
    for _ in 0..EARLY_FRAME {
        r.render(scene, 0.0).unwrap();
    }
    let early = r.read_hdr().unwrap();
    for _ in EARLY_FRAME..=r.technique().settle_frames() {
        r.render(scene, 0.0).unwrap();
    }
    let frame = r.read_hdr().unwrap();
    r.set_output(Output::IndirectIrradiance);
    r.render(scene, 0.0).unwrap();
    (early, frame, r.read_hdr().unwrap())
}

fn check_room(name: &str, techniques: &[&str]) {
    let ctx = GpuContext::shared(&GpuOptions::default()).unwrap();
    let scene = scene(name);
    let reference = reference(&scene);
    let (_, off, _) = render(&ctx, &scene, "none");
    let off_error = rel_mse(&off, &reference.total, None).unwrap();
    // Pixels the reference's indirect light clearly reaches: above a tenth of its mean
    // (its noise at 512 spp is far below that there).
    let e_ref = &reference.indirect_irradiance.pixels;
    let mean = e_ref.iter().map(|e| e.element_sum()).sum::<f32>() / e_ref.len() as f32;
    let reached: Vec<bool> = e_ref.iter().map(|e| e.element_sum() > 0.1 * mean).collect();
    let reached_count = reached.iter().filter(|&&r| r).count();
    assert!(
        reached_count * 4 > e_ref.len(),
        "{name}: the reference's indirect light reaches {reached_count} pixels"
    );
    let mut report = vec![format!("{name}: GI off relMSE {off_error:.4}")];
    let mut failures = Vec::new();
    for &gi in techniques {
        let (early, frame, indirect) = render(&ctx, &scene, gi);
        let error = rel_mse(&frame, &reference.total, None).unwrap();
        let early_error = rel_mse(&early, &reference.total, None).unwrap();
        let dark = indirect
            .pixels
            .iter()
            .zip(&reached)
            .filter(|(e, &r)| r && **e == Vec3::ZERO)
            .count();
        report.push(format!(
            "{gi} relMSE {error:.4} settled ({early_error:.4} at frame {EARLY_FRAME}), {dark} of \
             {reached_count} reached pixels unlit"
        ));
        if error >= off_error {
            failures.push(format!("{gi} is farther from the reference than GI off"));
        }
        // A technique may miss a pixel's light at an edge; not a room's.
        if dark * 50 > reached_count {
            failures.push(format!(
                "{gi} leaves {dark} pixels without light that the reference lights"
            ));
        }
    }
    println!("{}", report.join("; "));
    assert!(
        failures.is_empty(),
        "{}: {}",
        report.join("; "),
        failures.join("; ")
    );
}

/// The meeting room judges the two techniques that lost there; the default, 17 times closer
/// than GI off in it (relMSE 0.0036 against 0.0608), would cost this suite more than the rest
/// of the room (its 32-frame history tracing 280k triangles on lavapipe: 43 s).
#[test]
fn meeting_room() {
    check_room("meeting-room", &TECHNIQUES[1..]);
}

/// The default is judged here, where it gains least on GI off (relMSE 0.085 against 0.187).
#[test]
fn stone_church() {
    check_room("stone-church", &TECHNIQUES);
}

/// As the meeting room: the default, 25 times closer than GI off here (relMSE 0.0078 against
/// 0.1996) and judged in the church, costs more than the two techniques that lost here.
#[test]
fn living_room() {
    check_room("living-room", &TECHNIQUES[1..]);
}
