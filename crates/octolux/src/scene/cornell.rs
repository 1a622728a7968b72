//! The built-in Cornell box: the classic measured geometry (Cornell University Program of
//! Computer Graphics data, millimetres scaled to metres), white/red/green Lambertian walls with
//! the albedos of Mitsuba's RGB "cbox", a short and a tall block, and a spot light just under
//! the ceiling pointing down. It is the default scene.

use super::{Camera, Light, LightKind, Material, Mesh, Object, Scene};
use glam::{Mat4, Vec2, Vec3};

const MM: f32 = 0.001;

/// Albedo of the white surfaces.
pub const WHITE: Vec3 = Vec3::new(0.725, 0.71, 0.68);
/// Albedo of the red (left) wall.
pub const RED: Vec3 = Vec3::new(0.63, 0.065, 0.05);
/// Albedo of the green (right) wall.
pub const GREEN: Vec3 = Vec3::new(0.14, 0.45, 0.091);

/// Quads (corners in mm, counter-clockwise or clockwise; normals are oriented below).
type Quad = [[f32; 3]; 4];

const FLOOR: Quad = [
    [552.8, 0.0, 0.0],
    [0.0, 0.0, 0.0],
    [0.0, 0.0, 559.2],
    [549.6, 0.0, 559.2],
];
const CEILING: Quad = [
    [556.0, 548.8, 0.0],
    [556.0, 548.8, 559.2],
    [0.0, 548.8, 559.2],
    [0.0, 548.8, 0.0],
];
const BACK: Quad = [
    [549.6, 0.0, 559.2],
    [0.0, 0.0, 559.2],
    [0.0, 548.8, 559.2],
    [556.0, 548.8, 559.2],
];
const GREEN_WALL: Quad = [
    [0.0, 0.0, 559.2],
    [0.0, 0.0, 0.0],
    [0.0, 548.8, 0.0],
    [0.0, 548.8, 559.2],
];
const RED_WALL: Quad = [
    [552.8, 0.0, 0.0],
    [549.6, 0.0, 559.2],
    [556.0, 548.8, 559.2],
    [556.0, 548.8, 0.0],
];

const SHORT_BLOCK: [Quad; 5] = [
    [
        [130.0, 165.0, 65.0],
        [82.0, 165.0, 225.0],
        [240.0, 165.0, 272.0],
        [290.0, 165.0, 114.0],
    ],
    [
        [290.0, 0.0, 114.0],
        [290.0, 165.0, 114.0],
        [240.0, 165.0, 272.0],
        [240.0, 0.0, 272.0],
    ],
    [
        [130.0, 0.0, 65.0],
        [130.0, 165.0, 65.0],
        [290.0, 165.0, 114.0],
        [290.0, 0.0, 114.0],
    ],
    [
        [82.0, 0.0, 225.0],
        [82.0, 165.0, 225.0],
        [130.0, 165.0, 65.0],
        [130.0, 0.0, 65.0],
    ],
    [
        [240.0, 0.0, 272.0],
        [240.0, 165.0, 272.0],
        [82.0, 165.0, 225.0],
        [82.0, 0.0, 225.0],
    ],
];
const TALL_BLOCK: [Quad; 5] = [
    [
        [423.0, 330.0, 247.0],
        [265.0, 330.0, 296.0],
        [314.0, 330.0, 456.0],
        [472.0, 330.0, 406.0],
    ],
    [
        [423.0, 0.0, 247.0],
        [423.0, 330.0, 247.0],
        [472.0, 330.0, 406.0],
        [472.0, 0.0, 406.0],
    ],
    [
        [472.0, 0.0, 406.0],
        [472.0, 330.0, 406.0],
        [314.0, 330.0, 456.0],
        [314.0, 0.0, 456.0],
    ],
    [
        [314.0, 0.0, 456.0],
        [314.0, 330.0, 456.0],
        [265.0, 330.0, 296.0],
        [265.0, 0.0, 296.0],
    ],
    [
        [265.0, 0.0, 296.0],
        [265.0, 330.0, 296.0],
        [423.0, 330.0, 247.0],
        [423.0, 0.0, 247.0],
    ],
];

/// Builds a mesh of flat quads whose normals point towards `inside` (room walls) or away from
/// it (blocks), with `outward` choosing which.
fn quads_mesh(name: &str, quads: &[Quad], material: u32, reference: Vec3, outward: bool) -> Mesh {
    let mut mesh = Mesh {
        name: name.into(),
        material,
        ..Mesh::default()
    };
    for quad in quads {
        let p = quad.map(|c| Vec3::from(c) * MM);
        let centre = (p[0] + p[1] + p[2] + p[3]) * 0.25;
        let mut n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        let towards_reference = n.dot(reference - centre) > 0.0;
        if towards_reference == outward {
            n = -n;
        }
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(p);
        mesh.normals.extend([n; 4]);
        mesh.uvs.extend([Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]);
        // Wind triangles counter-clockwise around the normal.
        let ccw = (p[1] - p[0]).cross(p[2] - p[0]).dot(n) > 0.0;
        let tris = if ccw {
            [0, 1, 2, 0, 2, 3]
        } else {
            [0, 2, 1, 0, 3, 2]
        };
        mesh.indices.extend(tris.map(|i| base + i));
    }
    mesh
}

/// Centre of the room, used to orient wall normals inwards.
pub fn room_centre() -> Vec3 {
    Vec3::new(278.0, 274.4, 279.6) * MM
}

/// The spot light of the built-in box: 1 W/sr on its axis, pointing straight down from just
/// under the ceiling, with a 70-degree outer cone so the whole floor is lit and both blocks
/// cast shadows.
pub fn ceiling_spot() -> Light {
    Light {
        name: "ceiling-spot".into(),
        kind: LightKind::Spot {
            inner_angle: 55f32.to_radians(),
            outer_angle: 70f32.to_radians(),
        },
        color: Vec3::ONE,
        intensity: 1.0,
        position: Vec3::new(278.0, 538.0, 279.6) * MM,
        direction: Vec3::NEG_Y,
        animation: None,
    }
}

/// The classic camera: 39.3 degrees vertical field of view, from in front of the open side.
pub fn camera() -> Camera {
    Camera {
        name: "front".into(),
        position: Vec3::new(278.0, 273.0, -800.0) * MM,
        target: Vec3::new(278.0, 273.0, 0.0) * MM,
        up: Vec3::Y,
        vfov: 39.3f32.to_radians(),
        hfov: None,
        near: 0.05,
        far: 5.0,
        animation: None,
    }
}

/// The Cornell box geometry and materials without lights or cameras.
pub fn geometry() -> Scene {
    let c = room_centre();
    let materials = vec![
        Material {
            name: "white".into(),
            base_color: WHITE,
            ..Material::default()
        },
        Material {
            name: "red".into(),
            base_color: RED,
            ..Material::default()
        },
        Material {
            name: "green".into(),
            base_color: GREEN,
            ..Material::default()
        },
    ];
    let short_centre = Vec3::new(186.0, 82.5, 168.5) * MM;
    let tall_centre = Vec3::new(368.5, 165.0, 351.5) * MM;
    let meshes = vec![
        quads_mesh("walls", &[FLOOR, CEILING, BACK], 0, c, false),
        quads_mesh("red-wall", &[RED_WALL], 1, c, false),
        quads_mesh("green-wall", &[GREEN_WALL], 2, c, false),
        quads_mesh("short-block", &SHORT_BLOCK, 0, short_centre, true),
        quads_mesh("tall-block", &TALL_BLOCK, 0, tall_centre, true),
    ];
    let objects = vec![
        Object {
            name: "room".into(),
            meshes: vec![0, 1, 2],
            transform: Mat4::IDENTITY,
            animation: None,
        },
        Object {
            name: "short-block".into(),
            meshes: vec![3],
            transform: Mat4::IDENTITY,
            animation: None,
        },
        Object {
            name: "tall-block".into(),
            meshes: vec![4],
            transform: Mat4::IDENTITY,
            animation: None,
        },
    ];
    Scene {
        name: "cornell-box".into(),
        meshes,
        materials,
        textures: vec![],
        objects,
        lights: vec![],
        cameras: vec![],
        exposure: 0.0,
        sky: None,
        requests: vec![],
    }
}

/// The default scene: Cornell box geometry, the ceiling spot light and the classic camera.
pub fn scene() -> Scene {
    Scene {
        lights: vec![ceiling_spot()],
        cameras: vec![camera()],
        exposure: 0.0,
        ..geometry()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn walls_face_inwards_and_blocks_outwards() {
        let s = scene();
        let frame = s.frame(0.0, 0);
        for tri in s.world_triangles(&frame) {
            let centre = (tri.positions[0] + tri.positions[1] + tri.positions[2]) / 3.0;
            let geometric = (tri.positions[1] - tri.positions[0])
                .cross(tri.positions[2] - tri.positions[0])
                .normalize();
            assert!(
                geometric.dot(tri.normals[0]) > 0.99,
                "winding matches normal"
            );
            if tri.material != 0 || centre.y > 0.547 || centre.y < 1e-3 || centre.z > 0.55 {
                assert!(tri.normals[0].dot(room_centre() - centre) > 0.0);
            }
        }
        assert_eq!(s.triangle_count(), 2 * (3 + 1 + 1 + 5 + 5));
    }
}
