//! Mitsuba 3 XML scenes (`.xml`): the subset research scenes use, turned into our model.
//! `docs/scene-format.md` ("Mitsuba 3 XML") has the user's view of it.
//!
//! - Document: `<scene>` root; `<default name value>` and `$name` in attribute values;
//!   `<include filename>` (relative to the including file); `<ref id>` to any element declared
//!   with an `id`, wherever it is (forward references too). Files older than version 2 have
//!   their camelCase parameter names upgraded, as Mitsuba 3 does.
//! - Shapes, one [`Object`] each (named by `id`, else `shape{i}`), `to_world` as the object
//!   transform: `obj` and `ply` (through our loaders; the file's own materials are replaced by
//!   the shape's bsdf), `rectangle`, `cube`, `sphere` (`center`, `radius`), `disk`,
//!   `cylinder` (`p0`, `p1`, `radius`), tessellated; `flip_normals`, `face_normals` and the
//!   OBJ `flip_tex_coords` are honoured. A nested or referenced `emitter type="area"` makes the
//!   shape's material emit its `radiance` from the front face.
//! - BSDFs become Lambertian materials: `diffuse` (`reflectance`: colour or bitmap texture),
//!   `twosided`, `bumpmap` and `normalmap` (their inner bsdf), `mask` (`opacity` as coverage),
//!   `plastic`/`roughplastic` (`diffuse_reflectance`), `principled` (`base_color`); the
//!   dielectrics become clear surfaces (opacity 0) and every other type grey 0.5, each with a
//!   warning naming the bsdf.
//! - Emitters: `point`, `spot`, `directional` (lights), `envmap` and `constant` (the sky),
//!   `area` (in shapes).
//! - Sensors: `perspective` (and `thinlens`, without depth of field) with `fov`/`focal_length`,
//!   `fov_axis`, `near_clip`, `far_clip`, `to_world` and the film's size for the axis.
//! - Everything else (integrator, sampler, media, other plugin types) is skipped with a log
//!   message naming the element; nothing is dropped silently. Malformed XML, undefined
//!   parameters, bad values and missing files are errors naming the file, line and column.
//!
//! Colours: `rgb` is linear, `srgb` is sRGB-encoded, `spectrum` is one value or
//! wavelength:value pairs (converted to RGB approximately).

mod bsdf;
mod emitters;
mod sensor;
mod shapes;
mod spectrum;
mod xml;

use super::{obj, ply, AlphaMode, Asked, FileRequest, Material, Mesh, Object, Scene};
use crate::limits::{Account, Resource};
use crate::Result;
use glam::{Mat4, Vec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use xml::{Document, Element};

/// Mitsuba's default film size.
const FILM: (i64, i64) = (768, 576);
/// Warnings of one kind given one by one; the rest are counted.
const WARNINGS_PER_KIND: usize = 3;

/// Loads a Mitsuba 3 XML scene.
pub fn load(path: &Path) -> Result<Scene> {
    load_within(path, &Account::default())
}

/// [`load`], charging the files it reads, the includes it follows and the shapes it places
/// to `account`.
pub fn load_within(path: &Path, account: &Account) -> Result<Scene> {
    let doc = Document::read(path, account)?;
    let mut ids = HashMap::new();
    collect_ids(&doc, &doc.root, &mut ids)?;
    let mut loader = Loader {
        doc: &doc,
        account,
        files: HashMap::new(),
        placed: HashMap::new(),
        ids,
        scene: Scene {
            name: path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "mitsuba".into()),
            ..Scene::default()
        },
        surfaces: HashMap::new(),
        converting: Vec::new(),
        materials: HashMap::new(),
        textures: HashMap::new(),
        shapes: 0,
        skipped: Vec::new(),
    };
    for el in &doc.root.children {
        loader.top_level(el)?;
    }
    for (kind, count) in &loader.skipped {
        if *count > WARNINGS_PER_KIND {
            log::warn!(
                "{}: {} more {kind} elements skipped",
                path.display(),
                count - WARNINGS_PER_KIND
            );
        }
    }
    Ok(loader.scene)
}

fn collect_ids<'a>(
    doc: &Document,
    el: &'a Element,
    ids: &mut HashMap<&'a str, &'a Element>,
) -> Result<()> {
    for child in &el.children {
        if let Some(id) = child.attr("id").filter(|_| child.tag != "ref") {
            if let Some(first) = ids.insert(id, child) {
                return Err(doc.error(
                    child,
                    format!("id '{id}' is used twice (first at {})", doc.at(first)),
                ));
            }
        }
        collect_ids(doc, child, ids)?;
    }
    Ok(())
}

/// What a shape is made of.
enum Geometry {
    /// An OBJ or PLY file, with the flags that change its meshes.
    File {
        file: PathBuf,
        unflip_uv: bool,
        face_normals: bool,
    },
    /// A tessellated primitive.
    Meshes(Vec<Mesh>),
}

/// What a bsdf becomes.
#[derive(Clone)]
struct Surface {
    /// Cache key: the bsdf's id or its position.
    key: String,
    name: String,
    base_color: Vec3,
    texture: Option<u32>,
    opacity: f32,
    masked: bool,
}

impl Surface {
    fn grey(key: String, name: String) -> Surface {
        Surface {
            key,
            name,
            base_color: Vec3::splat(0.5),
            texture: None,
            opacity: 1.0,
            masked: false,
        }
    }
}

struct Loader<'a> {
    doc: &'a Document,
    account: &'a Account,
    /// The meshes of each model file, read once however many shapes name it.
    files: HashMap<PathBuf, Vec<Mesh>>,
    /// Mesh indices in the scene by what makes shapes share them (file, flags, material).
    placed: HashMap<String, Vec<u32>>,
    ids: HashMap<&'a str, &'a Element>,
    scene: Scene,
    /// Converted bsdfs by key.
    surfaces: HashMap<String, Surface>,
    /// Keys of the bsdfs being converted (a bsdf that contains itself is an error).
    converting: Vec<String>,
    /// Material index by (surface key, emission bits).
    materials: HashMap<(String, [u32; 3]), u32>,
    /// Texture index by (colour file, mask file, raw).
    textures: HashMap<(PathBuf, Option<PathBuf>, bool), u32>,
    shapes: usize,
    /// Skipped elements per kind, for capping the warnings.
    skipped: Vec<(String, usize)>,
}

impl<'a> Loader<'a> {
    /// Warns that `el` is skipped (the first few of a kind; the rest are counted).
    fn skip(&mut self, el: &Element, why: &str) {
        let kind = format!("<{} type=\"{}\">", el.tag, el.kind());
        let count = match self.skipped.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, n)) => {
                *n += 1;
                *n
            }
            None => {
                self.skipped.push((kind, 1));
                1
            }
        };
        if count <= WARNINGS_PER_KIND {
            log::warn!("{}: {} {why}; skipped", self.doc.at(el), el.describe());
        }
    }

    fn top_level(&mut self, el: &'a Element) -> Result<()> {
        match el.tag.as_str() {
            "shape" => self.shape(el),
            "emitter" => self.emitter(el),
            "sensor" => self.sensor(el),
            "bsdf" | "texture" | "spectrum" | "rgb" if el.attr("id").is_some() => Ok(()),
            "bsdf" | "texture" => {
                self.skip(el, "has no id, so nothing can refer to it");
                Ok(())
            }
            "integrator" => self.integrator(el),
            "sampler" | "film" | "rfilter" => {
                log::info!(
                    "{}: {} not used (octolux renders with its own settings)",
                    self.doc.at(el),
                    el.describe()
                );
                Ok(())
            }
            _ => {
                self.skip(el, "is not supported");
                Ok(())
            }
        }
    }

    /// Records what an integrator asks for: octolux renders with its own settings, and the
    /// command line warns where they differ.
    fn integrator(&mut self, el: &Element) -> Result<()> {
        let asked = match el.kind() {
            "path" | "volpath" | "volpathmis" | "prb" | "prbvolpath" | "direct_projective"
            | "prb_projective" => {
                // Mitsuba counts path vertices: 1 = emitters seen, 2 = direct light.
                let depth = self.doc.integer(el, "max_depth", -1)?;
                let bounces = match depth {
                    -1 => Some(crate::transport::Bounces::Unlimited),
                    d if d < -1 => {
                        return Err(self.doc.error(el, "max_depth must be -1 or at least 0"))
                    }
                    d => crate::transport::Bounces::from_reflections(
                        (d as u64).saturating_sub(1).min(u32::MAX as u64) as u32,
                    ),
                };
                Asked::Bounces(bounces, format!("max_depth {depth}"))
            }
            "direct" => Asked::Bounces(
                Some(crate::transport::Bounces::DirectOnly),
                "the direct integrator".into(),
            ),
            kind => Asked::Integrator(kind.to_string()),
        };
        log::info!(
            "{}: {} asks for {asked:?} (octolux renders with its own settings)",
            self.doc.at(el),
            el.describe()
        );
        self.scene.requests.push(FileRequest {
            at: format!("{}: {}", self.doc.at(el), el.describe()),
            asked,
        });
        Ok(())
    }

    /// The element a `<ref id>` points to.
    fn resolve(&self, el: &'a Element) -> Result<&'a Element> {
        if el.tag != "ref" {
            return Ok(el);
        }
        let id = el
            .attr("id")
            .ok_or_else(|| self.doc.error(el, "<ref> needs an id attribute"))?;
        self.ids
            .get(id)
            .copied()
            .ok_or_else(|| self.doc.error(el, format!("no element has id '{id}'")))
    }

    /// The `<transform name="to_world">` of `el`, or the identity.
    fn to_world(&self, el: &Element) -> Result<Mat4> {
        match el.param("to_world") {
            Some(t) if t.tag == "transform" => self.doc.transform(t),
            Some(t) => Err(self.doc.error(t, "to_world must be a <transform>")),
            None => Ok(Mat4::IDENTITY),
        }
    }

    /// A file parameter of `el`, relative to `el`'s file; it must exist.
    fn file(&self, el: &Element, name: &str) -> Result<PathBuf> {
        let value = self.doc.string(el, name).ok_or_else(|| {
            self.doc
                .error(el, format!("{} needs a '{name}' parameter", el.describe()))
        })?;
        let path = self.doc.resolve_file(el, value);
        if !path.is_file() {
            return Err(self.doc.error(
                el,
                format!(
                    "{}: file '{value}' not found (looked for {})",
                    el.describe(),
                    path.display()
                ),
            ));
        }
        Ok(path)
    }

    // ----------------------------------------------------------------------------- shapes

    fn shape(&mut self, el: &'a Element) -> Result<()> {
        let index = self.shapes;
        self.shapes += 1;
        let name = el
            .attr("id")
            .map_or_else(|| format!("shape{index}"), str::to_string);
        let mut to_world = self.to_world(el)?;
        let doc = self.doc;
        let geometry = match el.kind() {
            "obj" | "ply" => {
                let file = self.file(el, "filename")?;
                let lower = file.to_string_lossy().to_lowercase();
                let is_ply = lower.ends_with(".ply") || lower.ends_with(".ply.gz");
                if is_ply != (el.kind() == "ply") || !(is_ply || lower.ends_with(".obj")) {
                    return Err(doc.error(
                        el,
                        format!(
                            "shape '{name}' of type \"{}\" names {}: expected a {} file",
                            el.kind(),
                            file.display(),
                            if el.kind() == "ply" {
                                ".ply or .ply.gz"
                            } else {
                                ".obj"
                            }
                        ),
                    ));
                }
                Geometry::File {
                    file,
                    // Our OBJ loader flips v as Mitsuba does by default.
                    unflip_uv: el.kind() == "obj" && !doc.boolean(el, "flip_tex_coords", true)?,
                    face_normals: doc.boolean(el, "face_normals", false)?,
                }
            }
            "rectangle" => Geometry::Meshes(vec![shapes::rectangle()]),
            "cube" => Geometry::Meshes(vec![shapes::cube()]),
            "disk" => Geometry::Meshes(vec![shapes::disk()]),
            "sphere" => {
                let center = doc.point(el, "center")?.unwrap_or(Vec3::ZERO);
                let radius = doc.float(el, "radius", 1.0)?;
                to_world = to_world
                    * Mat4::from_translation(center)
                    * Mat4::from_scale(Vec3::splat(radius));
                Geometry::Meshes(vec![shapes::sphere()])
            }
            "cylinder" => {
                let p0 = doc.point(el, "p0")?.unwrap_or(Vec3::ZERO);
                let p1 = doc.point(el, "p1")?.unwrap_or(Vec3::Z);
                let radius = doc.float(el, "radius", 1.0)?;
                let axis = p1 - p0;
                let Some(dir) = axis.try_normalize() else {
                    return Err(doc.error(el, "cylinder: p0 and p1 are the same point"));
                };
                let (x, y) = dir.any_orthonormal_pair();
                let frame = Mat4::from_cols(
                    (x * radius).extend(0.0),
                    (y * radius).extend(0.0),
                    axis.extend(0.0),
                    p0.extend(1.0),
                );
                to_world *= frame;
                Geometry::Meshes(vec![shapes::cylinder()])
            }
            _ => {
                self.skip(el, "is not a supported shape type");
                return Ok(());
            }
        };
        if to_world.determinant().abs() < 1e-20 {
            return Err(doc.error(el, format!("shape '{name}': to_world is singular")));
        }
        let flip_normals = doc.boolean(el, "flip_normals", false)?;

        // Material: the bsdf (nested or referenced) and the area emitter, if any.
        let mut bsdf = None;
        let mut emission = Vec3::ZERO;
        for child in &el.children {
            if !matches!(child.tag.as_str(), "bsdf" | "ref" | "emitter") {
                continue;
            }
            let target = self.resolve(child)?;
            match target.tag.as_str() {
                "bsdf" => {
                    if bsdf.is_some() {
                        log::warn!(
                            "{}: shape '{name}' has several bsdfs; the first is used",
                            doc.at(child)
                        );
                    } else {
                        bsdf = Some(target);
                    }
                }
                "emitter" if target.kind() == "area" => {
                    emission = self.emitted(target, "radiance", 1.0)?;
                }
                "emitter" => self.skip(target, "inside a shape is not supported (only area)"),
                _ => {
                    return Err(doc.error(
                        child,
                        format!(
                            "shape '{name}': the reference is to {}, not a bsdf or an emitter",
                            target.describe()
                        ),
                    ))
                }
            }
        }
        let surface = match bsdf {
            Some(b) => self.surface(b)?,
            None => Surface::grey("default".into(), "default".into()),
        };
        let material = self.material(&surface, emission);
        let meshes = self.place_meshes(el, &name, geometry, flip_normals, material)?;
        self.scene.objects.push(Object {
            name,
            meshes,
            transform: to_world,
            animation: None,
        });
        Ok(())
    }

    /// The scene's meshes for one shape, charged to the budget: a model file's meshes are
    /// added once for each set of flags and material, and every shape that agrees on them
    /// shares them (a file placed by thousands of shapes is read and stored once).
    fn place_meshes(
        &mut self,
        el: &Element,
        name: &str,
        geometry: Geometry,
        flip_normals: bool,
        material: u32,
    ) -> Result<Vec<u32>> {
        let doc = self.doc;
        let shared_key = match &geometry {
            Geometry::File {
                file,
                unflip_uv,
                face_normals,
            } => Some(format!(
                "{}|{unflip_uv}|{face_normals}|{flip_normals}|{material}",
                file.display()
            )),
            Geometry::Meshes(_) => None,
        };
        let what = || format!("{}: shape '{name}'", doc.at(el));
        if let Some(ids) = shared_key.as_ref().and_then(|k| self.placed.get(k)) {
            let triangles = ids
                .iter()
                .map(|&m| self.scene.meshes[m as usize].triangle_count() as u64)
                .sum();
            self.account.charge(Resource::Instances, 1, what)?;
            self.account.charge(Resource::Triangles, triangles, what)?;
            return Ok(ids.clone());
        }
        let mut meshes = match geometry {
            Geometry::Meshes(meshes) => meshes,
            Geometry::File {
                file,
                unflip_uv,
                face_normals,
            } => {
                let mut meshes = self.file_meshes(el, name, &file)?;
                if unflip_uv {
                    for uv in meshes.iter_mut().flat_map(|m| m.uvs.iter_mut()) {
                        uv.y = 1.0 - uv.y;
                    }
                }
                if face_normals {
                    meshes.iter_mut().for_each(shapes::face_normals);
                }
                meshes
            }
        };
        if flip_normals {
            meshes.iter_mut().for_each(shapes::flip);
        }
        let triangles = meshes.iter().map(|m| m.triangle_count() as u64).sum();
        self.account.charge(Resource::Instances, 1, what)?;
        self.account.charge(Resource::Triangles, triangles, what)?;
        let first = self.scene.meshes.len() as u32;
        let count = meshes.len() as u32;
        let primitive = shared_key.is_none();
        for mut mesh in meshes {
            mesh.material = material;
            if primitive {
                mesh.name = name.to_string();
            }
            self.scene.meshes.push(mesh);
        }
        let ids: Vec<u32> = (first..first + count).collect();
        if let Some(key) = shared_key {
            self.placed.insert(key, ids.clone());
        }
        Ok(ids)
    }

    /// The meshes of model file `file` (read on first use).
    fn file_meshes(&mut self, el: &Element, name: &str, file: &Path) -> Result<Vec<Mesh>> {
        if let Some(meshes) = self.files.get(file) {
            return Ok(meshes.clone());
        }
        let part = if el.kind() == "obj" {
            obj::load_within(file, self.account)
        } else {
            ply::load_within(file, self.account)
        }
        .map_err(|e| self.doc.error(el, format!("shape '{name}': {e}")))?;
        self.files.insert(file.to_path_buf(), part.meshes.clone());
        Ok(part.meshes)
    }

    /// The material for a surface with an emission (one material per distinct pair).
    fn material(&mut self, surface: &Surface, emission: Vec3) -> u32 {
        let key = (surface.key.clone(), emission.to_array().map(f32::to_bits));
        if let Some(&m) = self.materials.get(&key) {
            return m;
        }
        let name = if emission == Vec3::ZERO {
            surface.name.clone()
        } else {
            format!("{}+emitter", surface.name)
        };
        self.scene.materials.push(Material {
            name,
            base_color: surface.base_color,
            base_color_texture: surface.texture,
            emission,
            emission_two_sided: false,
            opacity: surface.opacity,
            alpha_mode: if surface.masked {
                AlphaMode::Mask(0.5)
            } else {
                AlphaMode::Opaque
            },
        });
        let index = self.scene.materials.len() as u32 - 1;
        self.materials.insert(key, index);
        index
    }
}

/// Numbers separated by commas and/or white space.
fn numbers(text: &str) -> Option<Vec<f32>> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|w| !w.is_empty())
        .map(|w| w.parse::<f32>().ok().filter(|x| x.is_finite()))
        .collect()
}
