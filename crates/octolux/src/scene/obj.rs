//! Wavefront OBJ + MTL loader (via `tobj`).
//!
//! - Polygons are triangulated; points and lines are ignored.
//! - One [`Mesh`] per (group/object, material) and one [`Object`] per `o`/`g` name (in the
//!   order the names first appear; a name used twice is one object), all with the identity
//!   transform, so that scene files can select or drop parts by name. A file with no names or
//!   a single name is one object named after the file; faces before the first name belong to
//!   an object named after the file too. Units are whatever the file uses (no scaling).
//! - Normals come from the file when every vertex has one, otherwise they are computed.
//! - OBJ puts v = 0 at the bottom of a texture; our convention (glTF, wgpu) puts it at the
//!   top, so v is flipped.
//! - MTL: `Kd` -> base colour (linear), `Ke` -> emitted radiance, `map_Kd` -> base colour
//!   texture, `map_d` -> alpha mask merged into the texture's alpha channel (resized to the
//!   colour texture if the sizes differ) with [`AlphaMode::Mask`]`(0.5)`. Texture paths are
//!   relative to the MTL file; Windows backslashes and case mismatches are tolerated. A
//!   texture used by several materials is loaded once.
//! - A missing MTL file or texture is a warning: the material falls back to its factor (or
//!   the default material).

use super::{AlphaMode, Material, Mesh, Object, Scene, Texture};
use crate::limits::Account;
use crate::{Error, Result};
use glam::{Mat4, Vec2, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Loads an OBJ file (and the MTL files it references): one object per `o`/`g` name.
pub fn load(path: &Path) -> Result<Scene> {
    load_within(path, &Account::default())
}

/// [`load`], charging the files it reads to `account`.
pub fn load_within(path: &Path, account: &Account) -> Result<Scene> {
    let bytes = account.read_file(path)?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let warnings = Mutex::new(Vec::<String>::new());
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // `tobj` resolves a relative index that reaches before the first element, or a huge one,
    // with arithmetic that overflows (a panic in a debug build, a wrapped index otherwise).
    if let Some((line, text)) = index_out_of_reach(&String::from_utf8_lossy(&bytes)) {
        return Err(Error::parse(
            path,
            format!(
                "malformed OBJ (a face index before the first vertex, texture coordinate or \
                 normal, or beyond any file's) at line {line}: '{text}'"
            ),
        ));
    }
    let loaded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        tobj::load_obj_buf(&mut &bytes[..], &options, |mtl| {
            load_mtl(&dir, mtl, &warnings, account)
        })
    }))
    .map_err(|_| Error::parse(path, "malformed OBJ (the OBJ parser failed)"))?;
    let (models, materials) = loaded.map_err(|e| {
        let place = bad_line(&String::from_utf8_lossy(&bytes), &e)
            .map(|(line, text)| format!(" at line {line}: '{text}'"))
            .unwrap_or_default();
        Error::parse(path, format!("malformed OBJ ({e}){place}"))
    })?;
    for w in warnings.into_inner().unwrap_or_default() {
        log::warn!("{}: {w}", path.display());
    }
    let mtl_materials = match materials {
        Ok(m) => m,
        Err(e) => {
            log::warn!(
                "{}: material library not usable ({e}); using the default material",
                path.display()
            );
            Vec::new()
        }
    };

    let (materials, textures) = convert_materials(&mtl_materials, account);
    let mut scene = Scene {
        name: path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "obj".into()),
        materials,
        textures,
        ..Scene::default()
    };

    let mut default_material = None;
    let mut by_key: HashMap<(String, u32), usize> = HashMap::new();
    let mut dropped_uvs = 0usize;
    for model in models {
        let m = model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let material = match m.material_id {
            Some(id) if id < scene.materials.len() => id as u32,
            _ => *default_material.get_or_insert_with(|| {
                scene.materials.push(Material::default());
                scene.materials.len() as u32 - 1
            }),
        };
        let n = m.positions.len() / 3;
        let positions: Vec<Vec3> = m
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        let normals: Vec<Vec3> = if m.normals.len() == n * 3 {
            m.normals
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2]).normalize_or(Vec3::Y))
                .collect()
        } else {
            Vec::new()
        };
        let uvs: Vec<Vec2> = if m.texcoords.len() == n * 2 {
            m.texcoords
                .chunks_exact(2)
                .map(|t| Vec2::new(t[0], 1.0 - t[1]))
                .collect()
        } else {
            if !m.texcoords.is_empty() {
                dropped_uvs += 1;
            }
            vec![Vec2::ZERO; n]
        };
        let key = (model.name.clone(), material);
        match by_key.get(&key) {
            Some(&i) => {
                let mesh = &mut scene.meshes[i];
                let base = mesh.positions.len() as u32;
                // Merged parts must agree on having file normals or both get computed ones.
                if mesh.normals.len() != mesh.positions.len() || normals.len() != n {
                    mesh.normals.clear();
                } else {
                    mesh.normals.extend(normals);
                }
                mesh.positions.extend(positions);
                mesh.uvs.extend(uvs);
                mesh.indices.extend(m.indices.iter().map(|&i| i + base));
            }
            None => {
                by_key.insert(key, scene.meshes.len());
                scene.meshes.push(Mesh {
                    name: model.name,
                    positions,
                    normals,
                    uvs,
                    indices: m.indices,
                    material,
                });
            }
        }
    }
    if dropped_uvs > 0 {
        log::warn!(
            "{}: {dropped_uvs} meshes have texture coordinates on only some vertices; ignored",
            path.display()
        );
    }
    for mesh in &mut scene.meshes {
        if mesh.normals.len() != mesh.positions.len() {
            // A bad index is reported by validation, which names the file.
            mesh.compute_normals().ok();
        }
    }
    scene.objects = group_objects(&scene.meshes, &scene.name);
    Ok(scene)
}

/// Name tobj gives to faces that come before any `o` or `g` statement.
const UNNAMED: &str = "unnamed_object";

/// One object per distinct mesh name (`o`/`g` name), in order of first appearance; a single
/// name (or none) gives one object named `file_name`.
fn group_objects(meshes: &[Mesh], file_name: &str) -> Vec<Object> {
    let mut objects: Vec<Object> = Vec::new();
    let mut by_name: HashMap<&str, usize> = HashMap::new();
    for (i, mesh) in meshes.iter().enumerate() {
        let name = if mesh.name == UNNAMED {
            file_name
        } else {
            mesh.name.as_str()
        };
        let slot = *by_name.entry(name).or_insert_with(|| {
            objects.push(Object {
                name: name.to_string(),
                meshes: Vec::new(),
                transform: Mat4::IDENTITY,
                animation: None,
            });
            objects.len() - 1
        });
        objects[slot].meshes.push(i as u32);
    }
    if objects.len() == 1 {
        objects[0].name = file_name.to_string();
    }
    objects
}

/// The first line (1-based, with its text) that explains an error of `tobj`, which reports
/// none: an element whose numbers do not parse, or a face whose index is zero, unparsable or
/// beyond the elements defined before it.
fn bad_line(text: &str, error: &tobj::LoadError) -> Option<(usize, String)> {
    use tobj::LoadError as E;
    let mut counts = [0i64; 3]; // v, vt, vn defined so far
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or("");
        let numbers = || words.clone().take_while(|w| !w.starts_with('#'));
        let parses =
            |min: usize| numbers().count() >= min && numbers().all(|w| w.parse::<f32>().is_ok());
        let bad = match key {
            "v" => {
                counts[0] += 1;
                matches!(error, E::PositionParseError | E::ScalingByZeroError) && !parses(3)
            }
            "vt" => {
                counts[1] += 1;
                matches!(error, E::TexcoordParseError) && !parses(1)
            }
            "vn" => {
                counts[2] += 1;
                matches!(error, E::NormalParseError) && !parses(3)
            }
            "f" | "l" | "p"
                if matches!(
                    error,
                    E::FaceParseError
                        | E::InvalidPolygon
                        | E::FaceVertexOutOfBounds
                        | E::FaceTexCoordOutOfBounds
                        | E::FaceNormalOutOfBounds
                ) =>
            {
                numbers().any(|corner| {
                    corner.split('/').enumerate().any(|(k, index)| {
                        if index.is_empty() && k > 0 {
                            return false;
                        }
                        match index.parse::<i64>() {
                            Ok(0) | Err(_) => true,
                            Ok(n) if n > 0 => k < 3 && n > counts[k],
                            Ok(n) => k < 3 && -n > counts[k],
                        }
                    })
                })
            }
            _ => false,
        };
        if bad {
            return Some((i + 1, line.trim().to_string()));
        }
    }
    None
}

/// The first face, line or point element (1-based line number and text) with an index `tobj`
/// cannot resolve safely: a relative (negative) one reaching before the first vertex, texture
/// coordinate or normal defined so far, or one of more than 2^31 in magnitude. Indices past
/// the elements defined are left to `tobj`, which rejects them with an error.
fn index_out_of_reach(text: &str) -> Option<(usize, String)> {
    const MAX_INDEX: i64 = 1 << 31;
    let mut counts = [0i64; 3]; // v, vt, vn defined so far
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or("");
        match key {
            "v" => counts[0] += 1,
            "vt" => counts[1] += 1,
            "vn" => counts[2] += 1,
            "f" | "l" | "p" => {
                let out_of_reach = words.take_while(|w| !w.starts_with('#')).any(|corner| {
                    corner.split('/').take(3).enumerate().any(|(k, index)| {
                        index
                            .parse::<i64>()
                            .is_ok_and(|n| n.abs() > MAX_INDEX || (n < 0 && -n > counts[k]))
                    })
                });
                if out_of_reach {
                    return Some((i + 1, line.trim().to_string()));
                }
            }
            _ => {}
        }
    }
    None
}

/// Reads an MTL file, repairing what `tobj` would reject or choke on (colours with fewer than
/// three components, unparsable numbers) with a warning.
fn load_mtl(
    dir: &Path,
    mtl: &Path,
    warnings: &Mutex<Vec<String>>,
    account: &Account,
) -> tobj::MTLLoadResult {
    let warn = |w: String| {
        if let Ok(mut list) = warnings.lock() {
            list.push(w);
        }
    };
    let path = dir.join(normalize_separators(&mtl.to_string_lossy()));
    let path = find_file(&path).unwrap_or(path);
    let mtl_dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let text = match account.read_file_limited(&path, crate::limits::MAX_TEXT_BYTES) {
        Ok(bytes) => String::from_utf8_lossy(&bytes).into_owned(),
        Err(e) => {
            warn(format!(
                "cannot read material library {}: {e}; using the default material",
                path.display()
            ));
            return Err(tobj::LoadError::OpenFileFailed);
        }
    };
    let mut clean = String::with_capacity(text.len());
    for (line_no, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or("");
        let rest: Vec<&str> = words.collect();
        let numbers: Vec<f32> = rest.iter().map_while(|w| w.parse().ok()).collect();
        let bad = |what: &str| {
            format!(
                "{} line {}: {what} '{}'; line ignored",
                path.display(),
                line_no + 1,
                line.trim()
            )
        };
        match key {
            "Ka" | "Kd" | "Ks" | "Ke" => {
                if numbers.len() >= 3 {
                    clean.push_str(&format!(
                        "{key} {} {} {}\n",
                        numbers[0], numbers[1], numbers[2]
                    ));
                } else if numbers.len() == 1 {
                    let v = numbers[0];
                    clean.push_str(&format!("{key} {v} {v} {v}\n"));
                } else {
                    warn(bad("unsupported colour"));
                }
            }
            "Ns" | "Ni" | "d" | "Tr" => {
                if numbers.is_empty() {
                    warn(bad("not a number"));
                } else {
                    clean.push_str(&format!("{key} {}\n", numbers[0]));
                }
            }
            "illum" => {
                if rest.first().and_then(|w| w.parse::<u8>().ok()).is_some() {
                    clean.push_str(line.trim());
                    clean.push('\n');
                }
            }
            "map_Kd" | "map_d" => {
                let name = texture_name(line.trim()[key.len()..].trim());
                if name.is_empty() {
                    warn(bad("missing texture name"));
                } else {
                    let full = mtl_dir.join(&name);
                    clean.push_str(&format!("{key} {}\n", full.display()));
                }
            }
            "newmtl" | "map_Ka" | "map_Ks" | "map_Bump" | "map_bump" | "map_Ns" | "map_ns"
            | "map_NS" | "bump" => {
                if rest.is_empty() {
                    warn(bad("missing name"));
                } else {
                    clean.push_str(&format!("{key} {}\n", rest.join(" ")));
                }
            }
            _ => {
                clean.push_str(line.trim());
                clean.push('\n');
            }
        }
    }
    tobj::load_mtl_buf(&mut clean.as_bytes())
}

fn normalize_separators(name: &str) -> String {
    name.replace('\\', "/")
}

/// The file name in an MTL texture statement, without options such as `-bm 1` or `-s 1 1 1`
/// (the name is then the last word).
fn texture_name(statement: &str) -> String {
    let statement = statement.trim();
    let name = if statement.starts_with('-') {
        statement.split_whitespace().last().unwrap_or("")
    } else {
        statement
    };
    normalize_separators(name)
}

/// `path` if it exists, otherwise a file in the same folder whose name differs only in case.
fn find_file(path: &Path) -> Option<PathBuf> {
    if path.is_file() {
        return Some(path.to_path_buf());
    }
    let name = path.file_name()?.to_string_lossy().to_lowercase();
    let parent = path.parent()?;
    std::fs::read_dir(parent)
        .ok()?
        .filter_map(|e| e.ok())
        .find(|e| e.file_name().to_string_lossy().to_lowercase() == name)
        .map(|e| e.path())
}

/// A texture to build: an optional colour image and an optional coverage mask.
type TextureKey = (Option<PathBuf>, Option<PathBuf>);

/// Converts MTL materials, loading each distinct (colour, mask) texture once, in parallel.
fn convert_materials(mtl: &[tobj::Material], account: &Account) -> (Vec<Material>, Vec<Texture>) {
    // `load_mtl` already turned texture names into paths.
    let resolve = |name: &Option<String>| name.as_ref().map(PathBuf::from);
    let keys: Vec<TextureKey> = mtl
        .iter()
        .map(|m| (resolve(&m.diffuse_texture), resolve(&m.dissolve_texture)))
        .collect();
    let mut unique: Vec<TextureKey> = keys
        .iter()
        .filter(|k| k.0.is_some() || k.1.is_some())
        .cloned()
        .collect();
    unique.sort();
    unique.dedup();
    let built: Vec<(Option<Texture>, bool)> = unique
        .par_iter()
        .map(|(color, mask)| build_texture(color.as_deref(), mask.as_deref(), account))
        .collect();
    let mut textures = Vec::new();
    let mut index: HashMap<&TextureKey, (Option<u32>, bool)> = HashMap::new();
    for (key, (texture, masked)) in unique.iter().zip(built) {
        let id = texture.map(|t| {
            textures.push(t);
            textures.len() as u32 - 1
        });
        index.insert(key, (id, masked));
    }
    let materials = mtl
        .iter()
        .zip(&keys)
        .map(|(m, key)| {
            let (texture, masked) = index.get(key).copied().unwrap_or((None, false));
            // `d` (dissolve) or `Tr` (= 1 - d): transmissive surfaces are not modelled, so a
            // surface that lets through more than half is clear (see `Material::opacity`).
            let opacity = m.dissolve.or_else(|| {
                m.unknown_param
                    .get("Tr")
                    .and_then(|t| t.trim().parse::<f32>().ok())
                    .map(|t| 1.0 - t)
            });
            let opacity = opacity
                .filter(|o| o.is_finite())
                .map_or(1.0, |o| o.clamp(0.0, 1.0));
            Material {
                name: m.name.clone(),
                base_color: m.diffuse.map(Vec3::from).unwrap_or(Vec3::splat(0.8)),
                base_color_texture: texture,
                emission: m.emissive.map(Vec3::from).unwrap_or(Vec3::ZERO),
                emission_two_sided: false,
                opacity,
                alpha_mode: if masked || opacity < 1.0 {
                    AlphaMode::Mask(0.5)
                } else {
                    AlphaMode::Opaque
                },
            }
        })
        .collect();
    (materials, textures)
}

/// Loads a colour texture and/or a mask; returns the texture and whether it carries a mask.
/// Failures are warnings.
pub(crate) fn build_texture(
    color: Option<&Path>,
    mask: Option<&Path>,
    account: &Account,
) -> (Option<Texture>, bool) {
    let load = |p: &Path| -> Option<Texture> {
        let found = find_file(p).unwrap_or(p.to_path_buf());
        match Texture::load_within(&found, account) {
            Ok(t) => Some(t),
            Err(e) => {
                log::warn!("texture {}: {e}; using the material colour", p.display());
                None
            }
        }
    };
    let color_tex = color.and_then(load);
    let Some(mask_tex) = mask.and_then(load) else {
        return (color_tex, false);
    };
    let coverage: Vec<u8> = mask_tex
        .rgba
        .chunks_exact(4)
        .map(|t| ((t[0] as u32 + t[1] as u32 + t[2] as u32) * t[3] as u32 / (3 * 255)) as u8)
        .collect();
    let mut texture = match color_tex {
        Some(t) => t,
        None => Texture {
            name: mask_tex.name.clone(),
            width: mask_tex.width,
            height: mask_tex.height,
            rgba: vec![255; mask_tex.rgba.len()],
        },
    };
    let coverage = if (mask_tex.width, mask_tex.height) == (texture.width, texture.height) {
        coverage
    } else {
        match image::GrayImage::from_raw(mask_tex.width, mask_tex.height, coverage) {
            Some(img) => image::imageops::resize(
                &img,
                texture.width,
                texture.height,
                image::imageops::FilterType::Triangle,
            )
            .into_raw(),
            None => return (Some(texture), false),
        }
    };
    for (texel, c) in texture.rgba.chunks_exact_mut(4).zip(coverage) {
        texel[3] = ((texel[3] as u32 * c as u32 + 127) / 255) as u8;
    }
    texture.name = format!("{}+{}", texture.name, mask_tex.name);
    (Some(texture), true)
}

#[cfg(test)]
mod tests {
    use super::index_out_of_reach;

    #[test]
    fn relative_indices_before_the_first_element_and_huge_ones_are_out_of_reach() {
        let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\n";
        for (face, bad) in [
            ("f 1 2 3", false),
            ("f -3 -2 -1", false),
            ("f 1/1/1 2/2/1 3/-2/-1", false),
            // Past the elements defined: tobj's own error.
            ("f 1 2 9", false),
            ("f 1 2 -4", true),
            ("f 13//4 15/-4 16//4", true),
            ("f 1//-2 2//1 3//1", true),
            ("f 1 2 4294967296", true),
            ("l 1 -9", true),
        ] {
            let got = index_out_of_reach(&format!("{head}{face}\n"));
            assert_eq!(got.is_some(), bad, "{face}: {got:?}");
            if bad {
                assert_eq!(got, Some((7, face.to_string())));
            }
        }
    }
}
