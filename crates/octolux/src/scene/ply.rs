//! PLY loader: ASCII, binary little-endian and binary big-endian, optionally gzipped
//! (`.ply.gz`).
//!
//! Reads the `vertex` element (`x y z`, optional `nx ny nz`, texture coordinates as `u v`,
//! `s t` or `texture_u texture_v`, and `red green blue`) and the `face` element
//! (`vertex_indices` or `vertex_index` lists of any length, fan-triangulated). Other elements
//! and properties are parsed and skipped. Vertex colours are averaged (in linear space) into
//! the colour of the single material; without colours the material is a neutral 0.8 grey.
//! PLY texture coordinates have v = 0 at the bottom, so v is flipped to our top-left origin.
//!
//! The parser is written for hostile input: element counts are checked against the size of
//! the data before anything is allocated, truncated files and malformed values are errors that
//! name the file and the element, and nothing panics.

use super::texture::srgb_to_linear;
use super::{Material, Mesh, Object, Scene};
use crate::{Error, Result};
use glam::{Mat4, Vec2, Vec3};
use std::path::Path;

/// Loads a PLY or gzipped PLY file as a one-object scene.
pub fn load(path: &Path) -> Result<Scene> {
    load_within(path, &crate::limits::Account::default())
}

/// [`load`], charging the file to `account`.
pub fn load_within(path: &Path, account: &crate::limits::Account) -> Result<Scene> {
    let raw = account.read_file(path)?;
    let data = if raw.starts_with(&[0x1f, 0x8b]) {
        crate::limits::gunzip(path, &raw)?
    } else {
        raw
    };
    let mesh = parse(&data).map_err(|message| Error::parse(path, message))?;
    if mesh.skipped_faces > 0 {
        log::warn!(
            "{}: skipped {} faces with fewer than 3 vertices",
            path.display(),
            mesh.skipped_faces
        );
    }
    if mesh.trailing_bytes > 0 {
        log::warn!(
            "{}: {} bytes of data after the last element; ignored",
            path.display(),
            mesh.trailing_bytes
        );
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "ply".into());
    let material = Material {
        name: "ply".into(),
        base_color: mesh.color.unwrap_or(Vec3::splat(0.8)),
        ..Material::default()
    };
    let mut out = Mesh {
        name: name.clone(),
        positions: mesh.positions,
        normals: mesh.normals,
        uvs: mesh.uvs,
        indices: mesh.indices,
        material: 0,
    };
    if out.normals.len() != out.positions.len() {
        // A bad index is reported by validation, which names the file.
        out.compute_normals().ok();
    }
    Ok(Scene {
        name: name.clone(),
        meshes: vec![out],
        materials: vec![material],
        objects: vec![Object {
            name,
            meshes: vec![0],
            transform: Mat4::IDENTITY,
            animation: None,
        }],
        ..Scene::default()
    })
}

/// What the PLY file yields.
struct PlyMesh {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    indices: Vec<u32>,
    color: Option<Vec3>,
    /// Faces with fewer than three vertices, skipped.
    skipped_faces: usize,
    /// Bytes after the last element (whitespace excluded in ASCII files), ignored.
    trailing_bytes: usize,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Clone, Debug)]
enum PropertyType {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    ty: PropertyType,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<Property>,
}

impl Element {
    /// Fewest bytes one row can take, to bound `count` by the data size.
    fn min_row_bytes(&self, format: Format) -> u64 {
        self.properties
            .iter()
            .map(|p| match (format, &p.ty) {
                // A value and its separator.
                (Format::Ascii, _) => 2,
                (_, PropertyType::Scalar(s)) => s.size() as u64,
                (_, PropertyType::List { count, .. }) => count.size() as u64,
            })
            .sum::<u64>()
            .max(1)
    }
}

/// Parses the header; returns the format, the elements and the offset of the body.
fn parse_header(data: &[u8]) -> std::result::Result<(Format, Vec<Element>, usize), String> {
    if !data.starts_with(b"ply") {
        return Err("not a PLY file (missing 'ply' magic)".into());
    }
    let mut offset = 0;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut line_no = 0;
    loop {
        let Some(len) = data[offset..].iter().position(|&b| b == b'\n') else {
            return Err("header has no 'end_header' line".into());
        };
        let line = &data[offset..offset + len];
        offset += len + 1;
        line_no += 1;
        let line = String::from_utf8_lossy(line);
        let line = line.trim();
        let mut words = line.split_whitespace();
        let bad = |what: &str| format!("header line {line_no}: {what}: '{line}'");
        match words.next() {
            Some("ply") if line_no == 1 => {}
            Some("format") => {
                format = Some(match words.next() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::BinaryLe,
                    Some("binary_big_endian") => Format::BinaryBe,
                    _ => return Err(bad("unknown format")),
                });
            }
            Some("comment") | Some("obj_info") | None => {}
            Some("element") => {
                let name = words.next().ok_or_else(|| bad("element without name"))?;
                let count = words
                    .next()
                    .and_then(|c| c.parse::<u64>().ok())
                    .ok_or_else(|| bad("element without a valid count"))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            Some("property") => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?;
                let first = words.next().ok_or_else(|| bad("property without type"))?;
                let ty = if first == "list" {
                    let count = words
                        .next()
                        .and_then(Scalar::parse)
                        .ok_or_else(|| bad("bad list count type"))?;
                    let item = words
                        .next()
                        .and_then(Scalar::parse)
                        .ok_or_else(|| bad("bad list item type"))?;
                    if matches!(count, Scalar::F32 | Scalar::F64) {
                        return Err(bad("list count type must be an integer"));
                    }
                    PropertyType::List { count, item }
                } else {
                    PropertyType::Scalar(Scalar::parse(first).ok_or_else(|| bad("unknown type"))?)
                };
                let name = words.next().ok_or_else(|| bad("property without name"))?;
                element.properties.push(Property {
                    name: name.to_string(),
                    ty,
                });
            }
            Some("end_header") => break,
            Some(_) => return Err(bad("unknown header keyword")),
        }
    }
    let format = format.ok_or("header has no 'format' line")?;
    let body = (data.len() - offset) as u64;
    for e in &elements {
        let need = e.count.saturating_mul(e.min_row_bytes(format));
        if need > body {
            return Err(format!(
                "header declares {} '{}' elements, needing at least {need} bytes, but the data has only {body} bytes",
                e.count, e.name
            ));
        }
    }
    Ok((format, elements, offset))
}

/// Sequential reader over the body, ASCII or binary.
struct Body<'a> {
    data: &'a [u8],
    pos: usize,
    format: Format,
}

impl Body<'_> {
    fn scalar(&mut self, ty: Scalar) -> std::result::Result<f64, String> {
        match self.format {
            Format::Ascii => {
                while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
                    self.pos += 1;
                }
                let start = self.pos;
                while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
                    self.pos += 1;
                }
                if start == self.pos {
                    return Err("unexpected end of data".into());
                }
                let word = std::str::from_utf8(&self.data[start..self.pos])
                    .map_err(|_| "non-text data in an ASCII PLY".to_string())?;
                let value = if matches!(ty, Scalar::F32 | Scalar::F64) {
                    word.parse::<f64>().ok()
                } else {
                    word.parse::<i64>().ok().map(|v| v as f64)
                };
                value.ok_or_else(|| format!("'{word}' is not a valid {ty:?} value"))
            }
            Format::BinaryLe | Format::BinaryBe => {
                let size = ty.size();
                let Some(bytes) = self.data.get(self.pos..self.pos + size) else {
                    return Err("file is truncated".into());
                };
                self.pos += size;
                let mut b = [0u8; 8];
                b[..size].copy_from_slice(bytes);
                if self.format == Format::BinaryBe {
                    b[..size].reverse();
                }
                Ok(match ty {
                    Scalar::I8 => b[0] as i8 as f64,
                    Scalar::U8 => b[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F64 => f64::from_le_bytes(b),
                })
            }
        }
    }

    /// Reads a list length and checks that the list can fit in the remaining data.
    fn list_len(&mut self, count: Scalar, item: Scalar) -> std::result::Result<usize, String> {
        let n = self.scalar(count)?;
        if n < 0.0 || n.fract() != 0.0 {
            return Err(format!("invalid list length {n}"));
        }
        let min = if self.format == Format::Ascii {
            2.0
        } else {
            item.size() as f64
        };
        if n * min > (self.data.len() - self.pos + 1) as f64 {
            return Err(format!("list of {n} items runs past the end of the file"));
        }
        Ok(n as usize)
    }
}

/// Roles of vertex properties we use.
#[derive(Clone, Copy)]
enum Role {
    Position(usize),
    Normal(usize),
    Uv(usize),
    Color(usize, f64),
    Ignore,
}

fn parse(data: &[u8]) -> std::result::Result<PlyMesh, String> {
    let (format, elements, offset) = parse_header(data)?;
    let mut body = Body {
        data,
        pos: offset,
        format,
    };
    let mut mesh = PlyMesh {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        indices: Vec::new(),
        color: None,
        skipped_faces: 0,
        trailing_bytes: 0,
    };
    let mut seen_vertex = false;
    let mut seen_face = false;
    let mut bad_faces = 0usize;
    for element in &elements {
        let where_ = |i: u64, e: String| format!("{} {i}: {e}", element.name);
        if element.name == "vertex" && !seen_vertex {
            seen_vertex = true;
            let roles: Vec<Role> = element
                .properties
                .iter()
                .map(|p| {
                    let scale = match p.ty {
                        PropertyType::Scalar(Scalar::U8) => 1.0 / 255.0,
                        PropertyType::Scalar(Scalar::U16) => 1.0 / 65535.0,
                        _ => 1.0,
                    };
                    match p.name.as_str() {
                        "x" => Role::Position(0),
                        "y" => Role::Position(1),
                        "z" => Role::Position(2),
                        "nx" => Role::Normal(0),
                        "ny" => Role::Normal(1),
                        "nz" => Role::Normal(2),
                        "u" | "s" | "texture_u" | "texture_s" => Role::Uv(0),
                        "v" | "t" | "texture_v" | "texture_t" => Role::Uv(1),
                        "red" | "diffuse_red" => Role::Color(0, scale),
                        "green" | "diffuse_green" => Role::Color(1, scale),
                        "blue" | "diffuse_blue" => Role::Color(2, scale),
                        _ => Role::Ignore,
                    }
                })
                .collect();
            let has = |f: &dyn Fn(&Role) -> bool| roles.iter().filter(|r| f(r)).count();
            if has(&|r| matches!(r, Role::Position(_))) != 3 {
                return Err("vertex element lacks x, y, z properties".into());
            }
            let has_normals = has(&|r| matches!(r, Role::Normal(_))) == 3;
            let has_uvs = has(&|r| matches!(r, Role::Uv(_))) == 2;
            let has_colors = has(&|r| matches!(r, Role::Color(..))) == 3;
            // The header check bounded the count by the data size.
            let n = element.count as usize;
            mesh.positions.reserve(n);
            if has_normals {
                mesh.normals.reserve(n);
            }
            if has_uvs {
                mesh.uvs.reserve(n);
            }
            let mut color_sum = [0f64; 3];
            for i in 0..element.count {
                let mut p = [0f32; 3];
                let mut nrm = [0f32; 3];
                let mut uv = [0f32; 2];
                let mut c = [0f64; 3];
                for (prop, role) in element.properties.iter().zip(&roles) {
                    match prop.ty {
                        PropertyType::Scalar(ty) => {
                            let v = body.scalar(ty).map_err(|e| where_(i, e))?;
                            match *role {
                                Role::Position(k) => p[k] = v as f32,
                                Role::Normal(k) => nrm[k] = v as f32,
                                Role::Uv(k) => uv[k] = v as f32,
                                Role::Color(k, s) => c[k] = v * s,
                                Role::Ignore => {}
                            }
                        }
                        PropertyType::List { count, item } => {
                            let len = body.list_len(count, item).map_err(|e| where_(i, e))?;
                            for _ in 0..len {
                                body.scalar(item).map_err(|e| where_(i, e))?;
                            }
                        }
                    }
                }
                mesh.positions.push(Vec3::from(p));
                if has_normals {
                    mesh.normals.push(Vec3::from(nrm).normalize_or(Vec3::Y));
                }
                if has_uvs {
                    mesh.uvs.push(Vec2::new(uv[0], 1.0 - uv[1]));
                }
                if has_colors {
                    for k in 0..3 {
                        color_sum[k] += srgb_to_linear(c[k].clamp(0.0, 1.0) as f32) as f64;
                    }
                }
            }
            if has_colors && element.count > 0 {
                let n = element.count as f64;
                mesh.color = Some(Vec3::new(
                    (color_sum[0] / n) as f32,
                    (color_sum[1] / n) as f32,
                    (color_sum[2] / n) as f32,
                ));
            }
        } else if element.name == "face" && !seen_face {
            seen_face = true;
            let index_prop = element.properties.iter().position(|p| {
                matches!(p.ty, PropertyType::List { .. })
                    && (p.name == "vertex_indices" || p.name == "vertex_index")
            });
            if index_prop.is_none() && element.count > 0 {
                return Err("face element lacks a vertex_indices list".into());
            }
            mesh.indices.reserve(element.count as usize * 3);
            let mut polygon: Vec<u32> = Vec::new();
            for i in 0..element.count {
                for (k, prop) in element.properties.iter().enumerate() {
                    match prop.ty {
                        PropertyType::Scalar(ty) => {
                            body.scalar(ty).map_err(|e| where_(i, e))?;
                        }
                        PropertyType::List { count, item } => {
                            let len = body.list_len(count, item).map_err(|e| where_(i, e))?;
                            let wanted = Some(k) == index_prop;
                            polygon.clear();
                            for _ in 0..len {
                                let v = body.scalar(item).map_err(|e| where_(i, e))?;
                                if wanted {
                                    if v < 0.0 || v > u32::MAX as f64 || v.fract() != 0.0 {
                                        return Err(where_(
                                            i,
                                            format!("vertex index {v} out of range"),
                                        ));
                                    }
                                    polygon.push(v as u32);
                                }
                            }
                            if wanted {
                                if polygon.len() < 3 {
                                    bad_faces += 1;
                                }
                                for j in 1..polygon.len().saturating_sub(1) {
                                    mesh.indices.extend_from_slice(&[
                                        polygon[0],
                                        polygon[j],
                                        polygon[j + 1],
                                    ]);
                                }
                            }
                        }
                    }
                }
            }
        } else {
            for i in 0..element.count {
                for prop in &element.properties {
                    match prop.ty {
                        PropertyType::Scalar(ty) => {
                            body.scalar(ty).map_err(|e| where_(i, e))?;
                        }
                        PropertyType::List { count, item } => {
                            let len = body.list_len(count, item).map_err(|e| where_(i, e))?;
                            for _ in 0..len {
                                body.scalar(item).map_err(|e| where_(i, e))?;
                            }
                        }
                    }
                }
            }
        }
    }
    if !seen_vertex {
        return Err("no vertex element".into());
    }
    mesh.skipped_faces = bad_faces;
    let rest = &data[body.pos.min(data.len())..];
    mesh.trailing_bytes = match format {
        Format::Ascii => rest.iter().filter(|b| !b.is_ascii_whitespace()).count(),
        Format::BinaryLe | Format::BinaryBe => rest.len(),
    };
    Ok(mesh)
}
