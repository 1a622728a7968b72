//! A scene's fingerprint: one 64-bit hash of everything a render of it depends on (geometry,
//! materials, textures' texels, objects and their tracks, lights, cameras, exposure and sky),
//! so that results computed from a scene (a reference render) can be cached and found again.
//! The name and the file requests are left out: a scene renamed or loaded from another file
//! renders the same.
//!
//! Bulk data (vertices, indices, texels, sky maps) is hashed as bytes; the small parts
//! through their `Debug` text, streamed into the hasher, which prints floats exactly
//! (shortest round-trip), so two scenes hash alike only if they are equal bit for bit (up to
//! collisions). The hash is std's SipHash with fixed keys: stable between runs of one build;
//! across Rust versions it may change, which only costs a cache miss.

use super::{Scene, SkyRadiance};
use std::fmt::Write as _;
use std::hash::{DefaultHasher, Hasher};

/// A [`Hasher`] that `write!` can stream text into.
struct TextHasher(DefaultHasher);

impl std::fmt::Write for TextHasher {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.0.write(s.as_bytes());
        Ok(())
    }
}

impl Scene {
    /// A hash of everything a render of the scene depends on (see the module docs): equal
    /// scenes give equal fingerprints in one build; any changed vertex, texel, light or
    /// track changes it (up to 64-bit collisions).
    pub fn fingerprint(&self) -> u64 {
        let mut h = TextHasher(DefaultHasher::new());
        for mesh in &self.meshes {
            h.0.write_usize(mesh.positions.len());
            h.0.write(bytemuck::cast_slice(&mesh.positions));
            h.0.write_usize(mesh.normals.len());
            h.0.write(bytemuck::cast_slice(&mesh.normals));
            h.0.write_usize(mesh.uvs.len());
            h.0.write(bytemuck::cast_slice(&mesh.uvs));
            h.0.write_usize(mesh.indices.len());
            h.0.write(bytemuck::cast_slice(&mesh.indices));
            h.0.write_u32(mesh.material);
        }
        for texture in &self.textures {
            h.0.write_u32(texture.width);
            h.0.write_u32(texture.height);
            h.0.write_usize(texture.rgba.len());
            h.0.write(&texture.rgba);
        }
        // Writing into a hasher cannot fail.
        let _ = write!(
            h,
            "{:?}{:?}{:?}{:?}{:?}",
            self.materials, self.objects, self.lights, self.cameras, self.exposure
        );
        match &self.sky {
            None => h.0.write_u8(0),
            Some(sky) => {
                h.0.write_u8(1);
                let _ = write!(h, "{:?}{:?}", sky.intensity, sky.to_world);
                match &sky.radiance {
                    SkyRadiance::Constant(c) => {
                        let _ = write!(h, "{c:?}");
                    }
                    SkyRadiance::Map(map) => {
                        h.0.write_u32(map.image.width);
                        h.0.write_u32(map.image.height);
                        h.0.write(bytemuck::cast_slice(&map.image.pixels));
                    }
                }
            }
        }
        h.0.finish()
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::cornell;

    #[test]
    fn equal_scenes_agree_and_any_change_shows() {
        let scene = cornell::scene();
        let print = scene.fingerprint();
        let mut renamed = scene.clone();
        renamed.name = "another name".into();
        assert_eq!(renamed.fingerprint(), print, "the name is not rendered");

        let mut moved = scene.clone();
        moved.meshes[0].positions[0].x += 1e-6;
        assert_ne!(moved.fingerprint(), print, "a vertex moved");

        let mut dimmer = scene.clone();
        dimmer.lights[0].intensity *= 0.5;
        assert_ne!(dimmer.fingerprint(), print, "a light changed");

        let mut exposed = scene.clone();
        exposed.exposure += 1.0;
        assert_ne!(exposed.fingerprint(), print, "the exposure changed");
    }
}
