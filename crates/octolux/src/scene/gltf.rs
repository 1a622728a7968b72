//! glTF 2.0 loader (`.gltf` with external or embedded buffers, and `.glb`).
//!
//! - The default scene (or the first one) is walked with its node transforms; each node that
//!   carries a mesh becomes an [`Object`] with the node's world transform. Each triangle
//!   primitive becomes a [`Mesh`]; a mesh used by several nodes is converted once. Primitives in
//!   other modes (points, lines, strips, fans) are skipped with a warning.
//! - Materials: base colour factor (linear RGB; its alpha is ignored) and base colour texture
//!   (sRGB, converted to RGBA8 whatever its pixel format, read with the texture's UV set);
//!   alpha mode MASK keeps its cutoff, BLEND is treated as a 0.5 mask, OPAQUE ignores alpha;
//!   emission = emissive factor x `KHR_materials_emissive_strength`, taken as radiance in
//!   W/(m^2 sr). Other textures are ignored. A texture that cannot be read is a warning and
//!   the factor is used alone.
//! - `KHR_lights_punctual`: glTF gives point and spot intensity in candela (lm/sr) and
//!   directional intensity in lux (lm/m^2). They are converted to radiometric units with the
//!   luminous efficacy of 683 lm/W: W/sr = cd / 683 and W/m^2 = lx / 683. The colour is kept
//!   as given. Spot cone angles are kept as half-angles; spot and directional lights shine
//!   along the node's -Z axis. `range` is ignored (lights fall off with 1/d^2).
//! - Perspective cameras: `yfov`, `znear`, `zfar` (an infinite projection gets a far plane of
//!   10^5 x `znear`), placed at the node's world position looking along its -Z axis with its
//!   +Y axis as up. Orthographic cameras are skipped with a warning.

use super::{AlphaMode, Camera, Light, LightKind, Material, Mesh, Object, Scene, Texture};
use crate::limits::Account;
use crate::{Error, Result};
use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};
use std::collections::HashMap;
use std::path::Path;

/// Luminous efficacy used to turn photometric glTF light units into radiometric ones (lm/W).
pub const LUMENS_PER_WATT: f32 = 683.0;

/// Loads a `.gltf` or `.glb` file.
pub fn load(path: &Path) -> Result<Scene> {
    load_within(path, &Account::default())
}

/// [`load`], charging the files it reads (the document, buffers and images) to `account`.
pub fn load_within(path: &Path, account: &Account) -> Result<Scene> {
    let bytes = account.read_file(path)?;
    let gltf = parse_document(&bytes).map_err(|e| Error::parse(path, e))?;
    drop(bytes);
    let base = path.parent().unwrap_or(Path::new("."));
    // Accessors are checked before they are read (`check_accessor`); should the glTF crate
    // still panic on data it assumes well-formed, that is reported as a parse error.
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        convert(path, base, gltf, account)
    }))
    .unwrap_or_else(|_| {
        Err(Error::parse(
            path,
            "malformed glTF (inconsistent buffers, accessors or references)",
        ))
    })
}

/// Parses and validates a glTF or GLB document, after the checks the glTF crate's own
/// validation assumes (it indexes without checking in a few places).
fn parse_document(bytes: &[u8]) -> std::result::Result<gltf::Gltf, String> {
    if bytes.starts_with(b"glTF") {
        let length = bytes
            .get(8..12)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        match length {
            Some(n) if n >= 12 => {}
            Some(n) => {
                return Err(format!(
                    "GLB header: length {n} is less than the header's 12 bytes"
                ))
            }
            None => return Err("GLB header is truncated".into()),
        }
    }
    let unchecked = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| format!("malformed glTF: {e}"))?;
    let json = unchecked.document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            for (semantic, accessor) in &primitive.attributes {
                if accessor.value() >= json.accessors.len() {
                    return Err(format!(
                        "mesh {m} primitive {p}: {} accessor {} does not exist ({} accessors)",
                        semantic.to_string(),
                        accessor.value(),
                        json.accessors.len()
                    ));
                }
            }
        }
    }
    for (i, image) in json.images.iter().enumerate() {
        let ok = match &image.buffer_view {
            Some(_) => image.mime_type.is_some(),
            None => image.uri.is_some(),
        };
        if !ok {
            return Err(format!(
                "image {i}: needs a uri, or a bufferView with a mimeType"
            ));
        }
    }
    drop(unchecked);
    gltf::Gltf::from_slice(bytes).map_err(|e| format!("malformed glTF: {e}"))
}

fn convert(path: &Path, base: &Path, gltf: gltf::Gltf, account: &Account) -> Result<Scene> {
    let gltf::Gltf { document, blob } = gltf;
    let buffers = load_buffers(path, base, &document, blob, account)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "gltf".into());
    let mut scene = Scene {
        name,
        ..Scene::default()
    };

    // Images are decoded lazily, only for base colour textures.
    let mut image_textures: HashMap<usize, Option<u32>> = HashMap::new();
    let mut texture_sets: Vec<u32> = Vec::new();
    for material in document.materials() {
        let pbr = material.pbr_metallic_roughness();
        let [r, g, b, a] = pbr.base_color_factor();
        // Transmission is not modelled: a transmissive surface counts as clear where it
        // transmits at least half (see `Material::opacity`).
        let transmission = material
            .transmission()
            .map_or(0.0, |t| t.transmission_factor());
        let mut texture = None;
        let mut set = 0;
        if let Some(info) = pbr.base_color_texture() {
            set = info.tex_coord();
            let image = info.texture().source();
            texture = *image_textures.entry(image.index()).or_insert_with(|| {
                match load_image(path, base, &image, &buffers, account) {
                    Some(t) => {
                        scene.textures.push(t);
                        Some(scene.textures.len() as u32 - 1)
                    }
                    None => None,
                }
            });
        }
        texture_sets.push(set);
        let strength = material.emissive_strength().unwrap_or(1.0);
        scene.materials.push(Material {
            name: material
                .name()
                .map(str::to_string)
                .unwrap_or_else(|| format!("material{}", scene.materials.len())),
            base_color: Vec3::new(r, g, b),
            base_color_texture: texture,
            emission: Vec3::from(material.emissive_factor()) * strength,
            emission_two_sided: false,
            opacity: match material.alpha_mode() {
                gltf::material::AlphaMode::Opaque => 1.0 - transmission,
                _ => a * (1.0 - transmission),
            },
            alpha_mode: match material.alpha_mode() {
                gltf::material::AlphaMode::Mask => {
                    AlphaMode::Mask(material.alpha_cutoff().unwrap_or(0.5))
                }
                gltf::material::AlphaMode::Blend => AlphaMode::Mask(0.5),
                gltf::material::AlphaMode::Opaque if transmission > 0.0 => AlphaMode::Mask(0.5),
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            },
        });
    }
    let mut default_material = None;

    let Some(root) = document
        .default_scene()
        .or_else(|| document.scenes().next())
    else {
        return Err(Error::parse(path, "the glTF file has no scene"));
    };
    let mut converted: HashMap<usize, Vec<u32>> = HashMap::new();
    let mut visited = vec![false; document.nodes().len()];
    let mut stack: Vec<(gltf::Node, Mat4)> = root.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut visited[node.index()], true) {
            log::warn!(
                "{}: node {} is reachable twice (cycle or shared child); visited once",
                path.display(),
                node.index()
            );
            continue;
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let node_name = node
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("node{}", node.index()));
        if let Some(mesh) = node.mesh() {
            let ids = match converted.get(&mesh.index()) {
                Some(ids) => ids.clone(),
                None => {
                    let mut ids = Vec::new();
                    for (p, primitive) in mesh.primitives().enumerate() {
                        let mesh_name = format!(
                            "{}/{p}",
                            mesh.name()
                                .map(str::to_string)
                                .unwrap_or_else(|| format!("mesh{}", mesh.index()))
                        );
                        if primitive.mode() != gltf::mesh::Mode::Triangles {
                            log::warn!(
                                "{}: primitive {mesh_name} is not a triangle list ({:?}); skipped",
                                path.display(),
                                primitive.mode()
                            );
                            continue;
                        }
                        let material = match primitive.material().index() {
                            Some(i) if i < scene.materials.len() => i as u32,
                            _ => *default_material.get_or_insert_with(|| {
                                scene.materials.push(Material::default());
                                scene.materials.len() as u32 - 1
                            }),
                        };
                        let set = texture_sets.get(material as usize).copied().unwrap_or(0);
                        for (semantic, accessor) in primitive.attributes() {
                            let want = match semantic {
                                gltf::Semantic::Positions | gltf::Semantic::Normals => {
                                    Want::Vec3F32
                                }
                                gltf::Semantic::TexCoords(s) if s == set => Want::TexCoord,
                                _ => continue,
                            };
                            check_accessor(&accessor, &buffers, want).map_err(|e| {
                                Error::parse(
                                    path,
                                    format!(
                                        "primitive {mesh_name}: {:?} accessor {}: {e}",
                                        semantic,
                                        accessor.index()
                                    ),
                                )
                            })?;
                        }
                        if let Some(accessor) = primitive.indices() {
                            check_accessor(&accessor, &buffers, Want::Index).map_err(|e| {
                                Error::parse(
                                    path,
                                    format!(
                                        "primitive {mesh_name}: index accessor {}: {e}",
                                        accessor.index()
                                    ),
                                )
                            })?;
                        }
                        let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                        if primitive.get(&gltf::Semantic::Positions).is_none() {
                            log::warn!(
                                "{}: primitive {mesh_name} has no positions; skipped",
                                path.display()
                            );
                            continue;
                        }
                        let Some(positions) = reader.read_positions() else {
                            return Err(Error::parse(
                                path,
                                format!("primitive {mesh_name}: POSITION accessor lies outside its buffer"),
                            ));
                        };
                        let positions: Vec<Vec3> = positions.map(Vec3::from).collect();
                        let n = positions.len();
                        let normals: Vec<Vec3> = reader
                            .read_normals()
                            .map(|it| it.map(|v| Vec3::from(v).normalize_or(Vec3::Y)).collect())
                            .unwrap_or_default();
                        let uvs: Vec<Vec2> = reader
                            .read_tex_coords(set)
                            .map(|it| it.into_f32().map(Vec2::from).collect())
                            .unwrap_or_default();
                        let indices: Vec<u32> = match reader.read_indices() {
                            Some(it) => it.into_u32().collect(),
                            None if primitive.indices().is_some() => {
                                return Err(Error::parse(
                                    path,
                                    format!("primitive {mesh_name}: index accessor lies outside its buffer"),
                                ));
                            }
                            None => (0..n as u32).collect(),
                        };
                        let mut out = Mesh {
                            name: mesh_name,
                            normals: if normals.len() == n {
                                normals
                            } else {
                                Vec::new()
                            },
                            uvs: if uvs.len() == n {
                                uvs
                            } else {
                                vec![Vec2::ZERO; n]
                            },
                            positions,
                            indices,
                            material,
                        };
                        if out.normals.is_empty() {
                            // A bad index is reported by validation, which names the file.
                            out.compute_normals().ok();
                        }
                        scene.meshes.push(out);
                        ids.push(scene.meshes.len() as u32 - 1);
                    }
                    converted.insert(mesh.index(), ids.clone());
                    ids
                }
            };
            if !ids.is_empty() {
                scene.objects.push(Object {
                    name: node_name.clone(),
                    meshes: ids,
                    transform: world,
                    animation: None,
                });
            }
        }
        let position = world.w_axis.xyz();
        let forward = world
            .transform_vector3(Vec3::NEG_Z)
            .normalize_or(Vec3::NEG_Z);
        if let Some(light) = node.light() {
            let (kind, intensity) = match light.kind() {
                gltf::khr_lights_punctual::Kind::Point => (LightKind::Point, light.intensity()),
                gltf::khr_lights_punctual::Kind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => (
                    LightKind::Spot {
                        inner_angle: inner_cone_angle,
                        outer_angle: outer_cone_angle,
                    },
                    light.intensity(),
                ),
                gltf::khr_lights_punctual::Kind::Directional => {
                    (LightKind::Directional, light.intensity())
                }
            };
            scene.lights.push(Light {
                name: light
                    .name()
                    .map(str::to_string)
                    .unwrap_or_else(|| node_name.clone()),
                kind,
                color: Vec3::from(light.color()),
                intensity: intensity / LUMENS_PER_WATT,
                position,
                direction: forward,
                animation: None,
            });
        }
        if let Some(camera) = node.camera() {
            match camera.projection() {
                gltf::camera::Projection::Perspective(p) => {
                    let near = p.znear();
                    scene.cameras.push(Camera {
                        name: camera
                            .name()
                            .map(str::to_string)
                            .unwrap_or_else(|| node_name.clone()),
                        position,
                        target: position + forward,
                        up: world.transform_vector3(Vec3::Y).normalize_or(Vec3::Y),
                        vfov: p.yfov(),
                        hfov: None,
                        near,
                        far: p.zfar().unwrap_or(near * 1e5),
                        animation: None,
                    });
                }
                gltf::camera::Projection::Orthographic(_) => {
                    log::warn!(
                        "{}: orthographic camera on node {node_name} skipped",
                        path.display()
                    );
                }
            }
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, world));
        }
    }
    Ok(scene)
}

/// Decodes one glTF image into an RGBA8 texture; `None` with a warning on failure.
fn load_image(
    path: &Path,
    base: &Path,
    image: &gltf::Image,
    buffers: &[gltf::buffer::Data],
    account: &Account,
) -> Option<Texture> {
    let label = match image.source() {
        gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => uri.to_string(),
        _ => image
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("image{}", image.index())),
    };
    let decoded = image_bytes(base, image, buffers, account).and_then(|(bytes, mime)| {
        let format = mime.and_then(image::ImageFormat::from_mime_type);
        crate::limits::decode_image(Path::new(&label), &bytes, format).map_err(|e| e.to_string())
    });
    let rgba = match decoded {
        Ok(d) => d.into_rgba8(),
        Err(e) => {
            log::warn!(
                "{}: image {label}: {e}; using the material colour",
                path.display()
            );
            return None;
        }
    };
    Some(Texture {
        name: label,
        width: rgba.width(),
        height: rgba.height(),
        rgba: rgba.into_raw(),
    })
}

/// The encoded bytes of a glTF image and its MIME type, from a buffer view, a data URI or a
/// file beside the glTF file (read with the size limit).
fn image_bytes<'a>(
    base: &Path,
    image: &'a gltf::Image,
    buffers: &[gltf::buffer::Data],
    account: &Account,
) -> std::result::Result<(Vec<u8>, Option<&'a str>), String> {
    match image.source() {
        gltf::image::Source::View { view, mime_type } => {
            let data = buffers
                .get(view.buffer().index())
                .ok_or("buffer out of range")?;
            let end = view.offset().checked_add(view.length());
            match end.and_then(|end| data.0.get(view.offset()..end)) {
                Some(bytes) => Ok((bytes.to_vec(), Some(mime_type))),
                None => Err("buffer view out of range".into()),
            }
        }
        gltf::image::Source::Uri { uri, mime_type } => {
            let bytes = uri_bytes(base, uri, account).map_err(|e| e.to_string())?;
            Ok((bytes, mime_type))
        }
    }
}

/// The bytes a glTF URI names: a base64 data URI or a file relative to `base`.
fn uri_bytes(base: &Path, uri: &str, account: &Account) -> Result<Vec<u8>> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let data = rest.split_once(";base64,").map_or(rest, |(_, d)| d);
        return base64::decode(data)
            .map_err(|e| Error::parse(base, format!("data URI: invalid base64: {e}")));
    }
    let relative = if let Some(rest) = uri.strip_prefix("file://").or(uri.strip_prefix("file:")) {
        rest.to_string()
    } else if uri.contains(':') {
        return Err(Error::parse(
            base,
            format!("URI '{uri}': only relative paths, file: and data: URIs are supported"),
        ));
    } else {
        urlencoding::decode(uri)
            .map_err(|_| Error::parse(base, format!("URI '{uri}': invalid percent-encoding")))?
            .into_owned()
    };
    account.read_file(&base.join(relative))
}

/// Loads every buffer: the GLB binary chunk, data URIs and files (read with the size limit),
/// each at least as long as the glTF file says.
fn load_buffers(
    path: &Path,
    base: &Path,
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
    account: &Account,
) -> Result<Vec<gltf::buffer::Data>> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let mut data = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                Error::parse(path, format!("buffer {}: no binary chunk", buffer.index()))
            })?,
            gltf::buffer::Source::Uri(uri) => uri_bytes(base, uri, account)
                .map_err(|e| Error::parse(path, format!("buffer {}: {e}", buffer.index())))?,
        };
        if data.len() < buffer.length() {
            return Err(Error::parse(
                path,
                format!(
                    "buffer {} holds {} bytes, fewer than its byteLength {}",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        while data.len() % 4 != 0 {
            data.push(0);
        }
        out.push(gltf::buffer::Data(data));
    }
    Ok(out)
}

/// What an accessor must hold to be read as.
#[derive(Clone, Copy)]
enum Want {
    /// Three floats (positions, normals).
    Vec3F32,
    /// Two floats or normalized integers.
    TexCoord,
    /// Unsigned integer scalars.
    Index,
}

/// Checks an accessor's type and that every element lies inside its buffer view and the view
/// inside its buffer, so that reading it cannot fail; the message says what is wrong.
fn check_accessor(
    accessor: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
    want: Want,
) -> std::result::Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    let (ty, dims) = (accessor.data_type(), accessor.dimensions());
    let ok = match want {
        Want::Vec3F32 => ty == DataType::F32 && dims == Dimensions::Vec3,
        Want::TexCoord => {
            matches!(ty, DataType::F32 | DataType::U8 | DataType::U16) && dims == Dimensions::Vec2
        }
        Want::Index => {
            matches!(ty, DataType::U8 | DataType::U16 | DataType::U32) && dims == Dimensions::Scalar
        }
    };
    if !ok {
        return Err(format!("unsupported element type {dims:?} of {ty:?}"));
    }
    if accessor.sparse().is_some() {
        return Err("sparse accessors are not supported".into());
    }
    if accessor.count() == 0 {
        return Err("count 0: an accessor holds at least 1 element".into());
    }
    let Some(view) = accessor.view() else {
        return Ok(());
    };
    let element = accessor.size();
    let stride = view.stride().unwrap_or(element);
    if stride < element {
        return Err(format!(
            "byteStride {stride} is smaller than its element ({element} bytes)"
        ));
    }
    let buffer_len = buffers.get(view.buffer().index()).map_or(0, |b| b.0.len());
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|end| end > buffer_len) {
        return Err(format!(
            "buffer view {} (offset {}, length {}) lies outside its buffer ({buffer_len} bytes)",
            view.index(),
            view.offset(),
            view.length()
        ));
    }
    let end = (accessor.count() - 1)
        .checked_mul(stride)
        .and_then(|v| v.checked_add(accessor.offset()))
        .and_then(|v| v.checked_add(element));
    if end.is_none_or(|end| end > view.length()) {
        return Err(format!(
            "{} elements of {element} bytes (stride {stride}) from offset {} run past the \
             end of buffer view {} ({} bytes)",
            accessor.count(),
            accessor.offset(),
            view.index(),
            view.length()
        ));
    }
    Ok(())
}
