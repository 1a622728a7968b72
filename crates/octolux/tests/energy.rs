//! The closed-box energy test: inside a closed box whose walls all emit radiance L (both sides)
//! and reflect with albedo rho, the radiance everywhere is L / (1 - rho) once every bounce is
//! counted (L + rho L + rho^2 L + ...). A technique whose multiple bounces feed back with a
//! loop gain of one or more (or that adds light where there is none) goes above it and keeps
//! growing; one that loses light per bounce stays below it. Every technique that computes
//! multiple bounces is run until its image stops changing.

use crate::common;

use glam::{Mat4, Vec3};
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::{Camera, Material, Mesh, Object, Scene};

const L: f32 = 1.0;
const RHO: f32 = 0.5;

/// A closed cube of side 2 around the origin, flat normals pointing in, every wall emitting
/// `L` from both sides with albedo `RHO`; the camera at the centre.
fn furnace() -> Scene {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut indices = Vec::new();
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let n = -side * Vec3::AXES[axis];
            let (u, v) = (Vec3::AXES[(axis + 1) % 3], Vec3::AXES[(axis + 2) % 3]);
            let base = positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                positions.push(side * Vec3::AXES[axis] + a * u + b * v);
                normals.push(n);
            }
            indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    Scene {
        name: "furnace".into(),
        meshes: vec![Mesh {
            name: "walls".into(),
            positions,
            normals,
            uvs: Vec::new(),
            indices,
            material: 0,
        }],
        materials: vec![Material {
            name: "walls".into(),
            base_color: Vec3::splat(RHO),
            emission: Vec3::splat(L),
            emission_two_sided: true,
            ..Material::default()
        }],
        objects: vec![Object {
            name: "box".into(),
            meshes: vec![0],
            transform: Mat4::IDENTITY,
            animation: None,
        }],
        cameras: vec![Camera {
            name: "inside".into(),
            position: Vec3::new(0.1, 0.05, 0.2),
            target: Vec3::new(0.1, 0.05, -1.0),
            up: Vec3::Y,
            vfov: 1.4,
            hfov: None,
            near: 0.01,
            far: 10.0,
            animation: None,
        }],
        ..Scene::default()
    }
}

/// The mean radiance of the frame after it stops changing (by less than 1e-3 over 4 frames, at
/// most `max_frames`).
fn settled_radiance(technique: &str, max_frames: u32) -> (f32, u32) {
    let ctx = common::context();
    let scene = furnace();
    let mut settings = RenderSettings {
        width: 32,
        height: 32,
        gi: technique.into(),
        ..RenderSettings::default()
    };
    // A 64^3 octree for `vct-svo` (128 by default): the box is six plain walls, and its
    // bounce settles the same (1.837 against 1.822) at a quarter of the voxels to gather.
    settings.gi_settings.vct.octree_resolution = 64;
    let mut renderer = Renderer::new(&ctx, &scene, settings).expect("renderer");
    let mut history = Vec::new();
    for frame in 0..max_frames {
        renderer.render(&scene, 0.0).expect("frame");
        let hdr = renderer.read_hdr().expect("hdr");
        let mean = hdr
            .pixels
            .iter()
            .map(|p| p.element_sum() / 3.0)
            .sum::<f32>()
            / hdr.pixels.len() as f32;
        history.push(mean);
        if std::env::var("ENERGY_TRACE").is_ok() {
            println!("{technique} frame {frame}: {mean:.4}");
        }
        if frame >= 4 && (history[history.len() - 5] - mean).abs() < 1e-3 {
            return (mean, frame + 1);
        }
    }
    (*history.last().expect("frames"), max_frames)
}

/// Measured (lavapipe, 32 x 32, defaults; docs/vct.md and docs/probes.md "Closed-box energy"):
/// vct-svo 1.822 with the radiance's facing, its default (1.970 without; one bounce on its
/// first frame: 1.487, the exact one-bounce value is 1.5), 1.837 with the 64^3 octree the
/// test runs it with (after 16 frames),
/// vct-clipmap 1.353 (1.089 before its coarse levels were read as a medium and it kept the
/// facing), probes-grid 1.123, probes-octree 1.435 (with its history and bounces),
/// against 2.0: the structures of the last three lose light per bounce in a small closed
/// room, none gains. The bounds: not
/// above the exact value (2 % for the techniques' rounding and half-float storage; a loop gain
/// of one or more grows without bound), and some bounce light (at least 5 % above the emission
/// alone); `vct-svo`, whose voxels gather as its pixels do, within 10 % of the exact value
/// (its voxels' normals turned to their walls' outside took 17.6 % off; the facing drops the
/// share of a coarse texel's light that faces away from a cone, 9 % here).
///
/// Runs `technique` in the closed box until it settles and checks its radiance against the
/// bounds above.
fn check_no_gain(technique: &str) {
    let exact = L / (1.0 - RHO);
    let (radiance, frames) = settled_radiance(technique, 60);
    println!(
        "{technique}: {radiance:.4} after {frames} frames (exact {exact}, {:+.1} %)",
        (radiance / exact - 1.0) * 100.0
    );
    assert!(
        radiance <= exact * 1.02,
        "{technique}: {radiance} in a box whose exact radiance is {exact}: it gains energy"
    );
    assert!(
        radiance >= L * 1.05,
        "{technique}: {radiance}: no bounce light over the walls' own emission {L}"
    );
    if technique == "vct-svo" {
        assert!(
            radiance >= exact * 0.9,
            "vct-svo: {radiance} against the exact {exact}: its bounce loses light"
        );
    }
}

// One test per technique, so that the harness runs them side by side.
#[test]
fn vct_svo_gains_no_energy_in_a_closed_emitting_box() {
    check_no_gain("vct-svo");
}

#[test]
fn vct_clipmap_gains_no_energy_in_a_closed_emitting_box() {
    check_no_gain("vct-clipmap");
}

#[test]
fn probes_grid_gains_no_energy_in_a_closed_emitting_box() {
    check_no_gain("probes-grid");
}

#[test]
fn probes_octree_gains_no_energy_in_a_closed_emitting_box() {
    check_no_gain("probes-octree");
}
