//! References kept between bench runs (`--reference-cache DIR`): a converged reference at
//! 640x360 takes minutes to hours on a CPU, and the error tables judge many builds against the
//! same one. Each is a folder `DIR/<scene>-<key>/` with its images as 32-bit float EXRs and a
//! `reference.json` that says what it is; the key hashes everything the images depend on:
//! the scene's content ([`Scene::fingerprint`]), the frame (time, camera, animated lights and
//! objects), the size, the reference settings and the path tracer's own source
//! ([`reference::code_revision`]). A folder that does not read back whole is rendered again.

use anyhow::{Context, Result};
use octolux::image_io::HdrImage;
use octolux::reference::{self, ReferenceImages, ReferenceSettings};
use octolux::scene::{Scene, SceneFrame};
use std::fmt::Write as _;
use std::hash::{DefaultHasher, Hasher};
use std::path::{Path, PathBuf};

/// The images of a reference, by file name.
const IMAGES: [&str; 6] = [
    "direct",
    "indirect",
    "total",
    "indirect_irradiance",
    "emitter_irradiance",
    "albedo",
];

fn images_mut(images: &mut ReferenceImages) -> [&mut HdrImage; 6] {
    [
        &mut images.direct,
        &mut images.indirect,
        &mut images.total,
        &mut images.indirect_irradiance,
        &mut images.emitter_irradiance,
        &mut images.albedo,
    ]
}

/// Where references are kept.
pub struct ReferenceCache {
    dir: PathBuf,
}

/// What a cached reference is, beside its images.
#[derive(serde::Serialize, serde::Deserialize)]
struct Entry {
    scene: String,
    width: u32,
    height: u32,
    time: f32,
    settings: String,
    spp_done: u32,
    seconds: f64,
}

impl ReferenceCache {
    pub fn new(dir: &Path) -> ReferenceCache {
        ReferenceCache { dir: dir.into() }
    }

    /// The folder of the reference of `frame` of `scene` at `size` under `settings`.
    fn folder(
        &self,
        scene: &Scene,
        frame: &SceneFrame,
        size: (u32, u32),
        settings: &ReferenceSettings,
    ) -> PathBuf {
        let mut h = DefaultHasher::new();
        h.write_u64(scene.fingerprint());
        h.write_u64(reference::code_revision());
        let mut text = String::new();
        // Floats print exactly in Debug text.
        let _ = write!(text, "{frame:?}{size:?}{settings:?}");
        h.write(text.as_bytes());
        let name: String = scene
            .name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        self.dir.join(format!("{name}-{:016x}", h.finish()))
    }

    /// The cached reference, if there is one that reads back whole.
    pub fn find(
        &self,
        scene: &Scene,
        frame: &SceneFrame,
        size: (u32, u32),
        settings: &ReferenceSettings,
    ) -> Option<(PathBuf, ReferenceImages, f64)> {
        let folder = self.folder(scene, frame, size, settings);
        let text = std::fs::read_to_string(folder.join("reference.json")).ok()?;
        let entry: Entry = serde_json::from_str(&text).ok()?;
        let mut images = ReferenceImages {
            direct: HdrImage::new(0, 0),
            indirect: HdrImage::new(0, 0),
            total: HdrImage::new(0, 0),
            indirect_irradiance: HdrImage::new(0, 0),
            emitter_irradiance: HdrImage::new(0, 0),
            albedo: HdrImage::new(0, 0),
            spp_done: entry.spp_done,
        };
        for (name, image) in IMAGES.iter().zip(images_mut(&mut images)) {
            let read = HdrImage::read_exr(&folder.join(format!("{name}.exr"))).ok()?;
            if (read.width, read.height) != size {
                return None;
            }
            *image = read;
        }
        Some((folder, images, entry.seconds))
    }

    /// Keeps `images` (rendered in `seconds`) as the reference of `frame`; returns its folder.
    pub fn store(
        &self,
        scene: &Scene,
        frame: &SceneFrame,
        size: (u32, u32),
        settings: &ReferenceSettings,
        images: &ReferenceImages,
        seconds: f64,
    ) -> Result<PathBuf> {
        let folder = self.folder(scene, frame, size, settings);
        std::fs::create_dir_all(&folder)
            .with_context(|| format!("cannot create reference cache {}", folder.display()))?;
        let mut images = images.clone();
        for (name, image) in IMAGES.iter().zip(images_mut(&mut images)) {
            image.write_exr(&folder.join(format!("{name}.exr")))?;
        }
        let entry = Entry {
            scene: scene.name.clone(),
            width: size.0,
            height: size.1,
            time: frame.time,
            settings: format!("{settings:?}"),
            spp_done: images.spp_done,
            seconds,
        };
        // Written last: a folder without it is incomplete and is never read.
        let path = folder.join("reference.json");
        std::fs::write(&path, serde_json::to_string_pretty(&entry)?)
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(folder)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use octolux::scene::cornell;

    fn tiny(settings: &ReferenceSettings, scene: &Scene) -> ReferenceImages {
        reference::render(scene, &scene.frame(0.0, 0), 8, 6, settings, &|_, _| {}).unwrap()
    }

    #[test]
    fn a_stored_reference_is_found_again_and_only_for_its_inputs() {
        let dir = std::env::temp_dir().join(format!("octolux-refcache-{}", std::process::id()));
        let cache = ReferenceCache::new(&dir);
        let scene = cornell::scene();
        let frame = scene.frame(0.0, 0);
        let settings = ReferenceSettings {
            spp: 2,
            ..ReferenceSettings::default()
        };
        assert!(cache.find(&scene, &frame, (8, 6), &settings).is_none());
        let images = tiny(&settings, &scene);
        cache
            .store(&scene, &frame, (8, 6), &settings, &images, 0.1)
            .unwrap();
        let (_, found, _) = cache.find(&scene, &frame, (8, 6), &settings).unwrap();
        assert_eq!(found.total.pixels, images.total.pixels);
        assert_eq!(found.albedo.pixels, images.albedo.pixels);
        assert_eq!(found.spp_done, images.spp_done);
        // Another seed, size or scene is another reference.
        let reseeded = ReferenceSettings {
            seed: settings.seed + 1,
            ..settings.clone()
        };
        assert!(cache.find(&scene, &frame, (8, 6), &reseeded).is_none());
        assert!(cache.find(&scene, &frame, (16, 12), &settings).is_none());
        let mut dimmer = scene.clone();
        dimmer.lights[0].intensity *= 0.5;
        assert!(cache.find(&dimmer, &frame, (8, 6), &settings).is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
