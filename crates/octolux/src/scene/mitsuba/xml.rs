//! The XML side of the Mitsuba importer: files are read into an owned element tree with
//! `<include>`s spliced in, `<default>`s applied and `$name` references substituted, and the
//! typed values of Mitsuba's parameter elements (numbers, colours, spectra, points and
//! transforms) are parsed from it. Every error names the file and the element's line and
//! column.

use super::numbers;
use crate::limits::{Account, Resource};
use crate::{Error, Result};
use glam::{Mat3, Mat4, Vec3};
use std::path::{Path, PathBuf};

/// How deep `<include>`s may nest (a loop of includes stops here).
const MAX_INCLUDE_DEPTH: usize = 16;
/// How deep elements may nest, includes counted (real scenes nest fewer than ten: scene,
/// shape, bsdf, texture, transform). Every step below is a recursion, so a file nested
/// thousands deep would otherwise overflow the stack.
pub(super) const MAX_ELEMENT_DEPTH: usize = 64;

/// One XML element with its attributes (substituted) and element children.
#[derive(Clone, Debug)]
pub(super) struct Element {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    /// Index into [`Document::files`].
    pub file: usize,
    pub line: u32,
    pub column: u32,
}

impl Element {
    /// The value of attribute `name`.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// The `type` attribute, or "" when absent.
    pub fn kind(&self) -> &str {
        self.attr("type").unwrap_or("")
    }

    /// The child parameter named `name` (any tag).
    pub fn param(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.attr("name") == Some(name))
    }

    /// Children with tag `tag`.
    pub fn children_tagged<'a>(&'a self, tag: &'a str) -> impl Iterator<Item = &'a Element> {
        self.children.iter().filter(move |c| c.tag == tag)
    }

    /// "tag 'id' (type)" for messages.
    pub fn describe(&self) -> String {
        let mut s = format!("<{}", self.tag);
        if let Some(t) = self.attr("type") {
            s.push_str(&format!(" type=\"{t}\""));
        }
        if let Some(id) = self.attr("id") {
            s.push_str(&format!(" id=\"{id}\""));
        }
        if let Some(n) = self.attr("name") {
            s.push_str(&format!(" name=\"{n}\""));
        }
        s.push('>');
        s
    }
}

/// A Mitsuba scene read into memory: the root `<scene>` and the files it came from.
pub(super) struct Document {
    pub root: Element,
    pub files: Vec<PathBuf>,
}

impl Document {
    /// Reads `path` and everything it includes, charging the files and includes to
    /// `account`.
    pub fn read(path: &Path, account: &Account) -> Result<Document> {
        let mut doc = Document {
            root: Element {
                tag: String::new(),
                attrs: Vec::new(),
                children: Vec::new(),
                file: 0,
                line: 1,
                column: 1,
            },
            files: Vec::new(),
        };
        let mut params = Vec::new();
        doc.root = doc.read_file(path, &mut params, 0, 0, account)?;
        Ok(doc)
    }

    /// An error at element `el`: "file: line L, column C: message".
    pub fn error(&self, el: &Element, message: impl std::fmt::Display) -> Error {
        Error::parse(
            &self.files[el.file],
            format!("line {}, column {}: {message}", el.line, el.column),
        )
    }

    /// "file:line:column" of an element, for warnings.
    pub fn at(&self, el: &Element) -> String {
        format!(
            "{}:{}:{}",
            self.files[el.file].display(),
            el.line,
            el.column
        )
    }

    /// A file named in element `el`: relative to `el`'s own file, or else (as Mitsuba resolves
    /// names) to the main scene file. When neither exists, the first.
    pub fn resolve_file(&self, el: &Element, name: &str) -> PathBuf {
        let dir = |file: usize| self.files[file].parent().unwrap_or(Path::new("."));
        let own = dir(el.file).join(name);
        if own.exists() {
            return own;
        }
        let main = dir(0).join(name);
        if main.exists() {
            main
        } else {
            own
        }
    }

    fn read_file(
        &mut self,
        path: &Path,
        params: &mut Vec<(String, String)>,
        depth: usize,
        element_depth: usize,
        account: &Account,
    ) -> Result<Element> {
        let text = account.read_text(path)?;
        let file = self.files.len();
        self.files.push(path.to_path_buf());
        let xml = roxmltree::Document::parse(&text).map_err(|e| {
            let pos = e.pos();
            Error::parse(
                path,
                format!("line {}, column {}: malformed XML: {e}", pos.row, pos.col),
            )
        })?;
        let root = xml.root_element();
        let pos = xml.text_pos_at(root.range().start);
        if root.tag_name().name() != "scene" {
            return Err(Error::parse(
                path,
                format!(
                    "line {}, column {}: expected a Mitsuba <scene> root element, found <{}>",
                    pos.row,
                    pos.col,
                    root.tag_name().name()
                ),
            ));
        }
        // Files older than Mitsuba 2 name parameters in camelCase; Mitsuba 3 upgrades them the
        // same way.
        let version = root.attribute("version").unwrap_or("3.0.0");
        let major: u32 = version
            .split('.')
            .next()
            .and_then(|m| m.trim().parse().ok())
            .unwrap_or(3);
        let context = Context {
            file,
            old: major < 2,
            depth,
            account,
        };
        self.convert(&xml, root, &context, params, element_depth)
    }

    fn convert(
        &mut self,
        xml: &roxmltree::Document,
        node: roxmltree::Node,
        context: &Context,
        params: &mut Vec<(String, String)>,
        element_depth: usize,
    ) -> Result<Element> {
        let pos = xml.text_pos_at(node.range().start);
        if element_depth >= MAX_ELEMENT_DEPTH {
            return Err(Error::parse(
                &self.files[context.file],
                format!(
                    "line {}, column {}: <{}> is nested {MAX_ELEMENT_DEPTH} elements deep; \
                     octolux reads at most {MAX_ELEMENT_DEPTH} levels",
                    pos.row,
                    pos.col,
                    node.tag_name().name()
                ),
            ));
        }
        let mut tag = node.tag_name().name().to_string();
        if context.old && tag == "lookAt" {
            tag = "lookat".into();
        }
        let mut el = Element {
            tag,
            attrs: Vec::new(),
            children: Vec::new(),
            file: context.file,
            line: pos.row,
            column: pos.col,
        };
        for attr in node.attributes() {
            let mut value = substitute(attr.value(), params)
                .map_err(|m| self.error(&el, format!("attribute {}: {m}", attr.name())))?;
            if context.old && attr.name() == "name" {
                value = snake_case(&value);
            }
            el.attrs.push((attr.name().to_string(), value));
        }
        for child in node.children().filter(|c| c.is_element()) {
            let name = child.tag_name().name();
            if name == "default" {
                let pos = xml.text_pos_at(child.range().start);
                let (Some(key), Some(value)) = (child.attribute("name"), child.attribute("value"))
                else {
                    return Err(Error::parse(
                        &self.files[context.file],
                        format!(
                            "line {}, column {}: <default> needs name and value attributes",
                            pos.row, pos.col
                        ),
                    ));
                };
                // A value given earlier (an including file's default) wins, as in Mitsuba.
                if !params.iter().any(|(k, _)| k == key) {
                    params.push((key.to_string(), value.to_string()));
                }
            } else if name == "include" {
                let included = self.convert(xml, child, context, params, element_depth + 1)?;
                let Some(file) = included.attr("filename") else {
                    return Err(self.error(&included, "<include> needs a filename attribute"));
                };
                if context.depth >= MAX_INCLUDE_DEPTH {
                    return Err(self.error(
                        &included,
                        format!("includes nest deeper than {MAX_INCLUDE_DEPTH} (a loop?)"),
                    ));
                }
                let target = self.resolve_file(&included, file);
                if !target.is_file() {
                    return Err(self.error(
                        &included,
                        format!("included file '{file}' not found ({})", target.display()),
                    ));
                }
                context.account.charge(Resource::Includes, 1, || {
                    format!("{}: <include filename=\"{file}\">", self.at(&included))
                })?;
                let scene = self.read_file(
                    &target,
                    params,
                    context.depth + 1,
                    element_depth,
                    context.account,
                )?;
                el.children.extend(scene.children);
            } else {
                el.children
                    .push(self.convert(xml, child, context, params, element_depth + 1)?);
            }
        }
        Ok(el)
    }
}

/// Where elements being converted come from.
struct Context<'a> {
    file: usize,
    /// A file older than Mitsuba 2 (camelCase parameter names).
    old: bool,
    /// How deep the includes nest here.
    depth: usize,
    account: &'a Account,
}

/// Replaces `$name` with the parameter's value. An unknown name is an error.
fn substitute(value: &str, params: &[(String, String)]) -> std::result::Result<String, String> {
    if !value.contains('$') {
        return Ok(value.to_string());
    }
    let mut out = String::with_capacity(value.len());
    let mut rest = value;
    while let Some(i) = rest.find('$') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        let len = after
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .unwrap_or(after.len());
        let key = &after[..len];
        if key.is_empty() {
            return Err(format!("'$' without a parameter name in '{value}'"));
        }
        match params.iter().find(|(k, _)| k == key) {
            Some((_, v)) => out.push_str(v),
            None => {
                return Err(format!(
                    "undefined parameter '${key}' (declare it with <default name=\"{key}\" value=\"...\"/>)"
                ))
            }
        }
        rest = &after[len..];
    }
    out.push_str(rest);
    Ok(out)
}

/// `toWorld` -> `to_world`.
fn snake_case(name: &str) -> String {
    let mut out = String::with_capacity(name.len() + 4);
    for c in name.chars() {
        if c.is_ascii_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

impl Document {
    /// The `value` attribute of `el` as one finite number.
    pub fn number(&self, el: &Element, attr: &str) -> Result<f32> {
        let text = el
            .attr(attr)
            .ok_or_else(|| self.error(el, format!("{} needs a {attr} attribute", el.describe())))?;
        match numbers(text).as_deref() {
            Some([x]) => Ok(*x),
            _ => Err(self.error(
                el,
                format!("{}: {attr}=\"{text}\" is not a number", el.describe()),
            )),
        }
    }

    /// Float parameter `name` of `el` (a `<float>` or `<integer>`), or `default`.
    pub fn float(&self, el: &Element, name: &str, default: f32) -> Result<f32> {
        match el.param(name) {
            None => Ok(default),
            Some(p) if p.tag == "float" || p.tag == "integer" => self.number(p, "value"),
            Some(p) => Err(self.error(
                p,
                format!("parameter '{name}' should be a <float>, found <{}>", p.tag),
            )),
        }
    }

    /// Integer parameter `name` of `el`, or `default`.
    pub fn integer(&self, el: &Element, name: &str, default: i64) -> Result<i64> {
        match el.param(name) {
            None => Ok(default),
            Some(p) => {
                let text = p.attr("value").unwrap_or("");
                text.trim().parse().map_err(|_| {
                    self.error(
                        p,
                        format!("parameter '{name}': value=\"{text}\" is not an integer"),
                    )
                })
            }
        }
    }

    /// Boolean parameter `name` of `el`, or `default`.
    pub fn boolean(&self, el: &Element, name: &str, default: bool) -> Result<bool> {
        match el.param(name) {
            None => Ok(default),
            Some(p) => match p.attr("value").map(|v| v.trim().to_lowercase()).as_deref() {
                Some("true") => Ok(true),
                Some("false") => Ok(false),
                _ => Err(self.error(
                    p,
                    format!("parameter '{name}': expected value=\"true\" or \"false\""),
                )),
            },
        }
    }

    /// String parameter `name` of `el`.
    pub fn string<'a>(&self, el: &'a Element, name: &str) -> Option<&'a str> {
        el.param(name).and_then(|p| p.attr("value"))
    }

    /// A `<point>` or `<vector>`: `value="x y z"` or `x`, `y`, `z` attributes (missing ones
    /// are `missing`).
    pub fn vector(&self, el: &Element, missing: f32) -> Result<Vec3> {
        if let Some(v) = el.attr("value") {
            return match numbers(v).as_deref() {
                Some([x]) => Ok(Vec3::splat(*x)),
                Some([x, y, z]) => Ok(Vec3::new(*x, *y, *z)),
                _ => Err(self.error(
                    el,
                    format!("{}: value=\"{v}\" is not three numbers", el.describe()),
                )),
            };
        }
        let mut out = Vec3::splat(missing);
        for (i, axis) in ["x", "y", "z"].iter().enumerate() {
            if el.attr(axis).is_some() {
                out[i] = self.number(el, axis)?;
            }
        }
        Ok(out)
    }

    /// Point or vector parameter `name` of `el`.
    pub fn point(&self, el: &Element, name: &str) -> Result<Option<Vec3>> {
        el.param(name).map(|p| self.vector(p, 0.0)).transpose()
    }

    /// Colour parameter `name`: `<rgb>` (linear), `<srgb>` (sRGB-encoded), `<float>`, or
    /// `<spectrum>` (one value, or wavelength:value pairs converted to RGB). `Ok(None)` when
    /// absent or given another way (a texture: the caller handles those).
    pub fn color(&self, el: &Element, name: &str) -> Result<Option<Vec3>> {
        let Some(p) = el.param(name) else {
            return Ok(None);
        };
        self.color_value(p)
    }

    /// The colour of a parameter element (see [`Document::color`]).
    pub fn color_value(&self, p: &Element) -> Result<Option<Vec3>> {
        let bad = |what: &str| self.error(p, format!("{}: {what}", p.describe()));
        let value = p.attr("value").unwrap_or("");
        match p.tag.as_str() {
            "rgb" | "srgb" => {
                let rgb = if value.trim_start().starts_with('#') {
                    hex_color(value.trim()).ok_or_else(|| bad("not a #rrggbb colour"))?
                } else {
                    match numbers(value).as_deref() {
                        Some([v]) => Vec3::splat(*v),
                        Some([r, g, b]) => Vec3::new(*r, *g, *b),
                        _ => return Err(bad("value is not one or three numbers")),
                    }
                };
                Ok(Some(
                    if p.tag == "srgb" || value.trim_start().starts_with('#') {
                        rgb.map(super::super::srgb_to_linear)
                    } else {
                        rgb
                    },
                ))
            }
            "float" | "integer" => Ok(Some(Vec3::splat(self.number(p, "value")?))),
            "spectrum" => {
                if p.attr("filename").is_some() || p.attr("value").is_none() {
                    return Err(bad(
                        "only spectra given inline (value=\"...\") are supported, not files",
                    ));
                }
                super::spectrum::to_rgb(value)
                    .map(Some)
                    .ok_or_else(|| bad("value is neither a number nor wavelength:value pairs"))
            }
            _ => Ok(None),
        }
    }

    /// A `to_world` (or other) `<transform>`: its children composed in order, each applied
    /// after the ones before (M = T_last * ... * T_first).
    pub fn transform(&self, t: &Element) -> Result<Mat4> {
        let mut m = Mat4::IDENTITY;
        for step in &t.children {
            let s = match step.tag.as_str() {
                "translate" => Mat4::from_translation(self.vector(step, 0.0)?),
                "scale" => {
                    let v = self.vector(step, 1.0)?;
                    Mat4::from_scale(v)
                }
                "rotate" => {
                    let axis = match step.attr("axis") {
                        Some(a) => match numbers(a).as_deref() {
                            Some([x, y, z]) => Vec3::new(*x, *y, *z),
                            _ => return Err(self.error(step, "rotate: axis is not three numbers")),
                        },
                        None => self.vector(step, 0.0)?,
                    };
                    let angle = self.number(step, "angle")?;
                    let Some(axis) = axis.try_normalize() else {
                        return Err(self.error(step, "rotate: the axis is zero"));
                    };
                    Mat4::from_axis_angle(axis, angle.to_radians())
                }
                "matrix" => {
                    let value = step.attr("value").unwrap_or("");
                    match numbers(value).as_deref() {
                        Some(v) if v.len() == 16 => {
                            Mat4::from_cols_array(&std::array::from_fn(|i| v[i])).transpose()
                        }
                        Some(v) if v.len() == 9 => Mat4::from_mat3(
                            Mat3::from_cols_array(&std::array::from_fn(|i| v[i])).transpose(),
                        ),
                        _ => {
                            return Err(self.error(
                                step,
                                "matrix: value must hold 16 (or 9) numbers, row by row",
                            ))
                        }
                    }
                }
                "lookat" => self.lookat(step)?,
                other => {
                    return Err(self.error(
                        step,
                        format!("<{other}> is not a transform step (translate, rotate, scale, matrix, lookat)"),
                    ))
                }
            };
            m = s * m;
        }
        if !m.is_finite() {
            return Err(self.error(t, "the transform is not finite"));
        }
        Ok(m)
    }

    /// Mitsuba's `lookat`: columns (left, up, forward, origin) with left = up x forward.
    fn lookat(&self, el: &Element) -> Result<Mat4> {
        let three = |attr: &str| -> Result<Option<Vec3>> {
            match el.attr(attr) {
                None => Ok(None),
                Some(v) => match numbers(v).as_deref() {
                    Some([x, y, z]) => Ok(Some(Vec3::new(*x, *y, *z))),
                    _ => {
                        Err(self.error(el, format!("lookat: {attr}=\"{v}\" is not three numbers")))
                    }
                },
            }
        };
        let origin = three("origin")?.unwrap_or(Vec3::ZERO);
        let target =
            three("target")?.ok_or_else(|| self.error(el, "lookat needs a target attribute"))?;
        let Some(dir) = (target - origin).try_normalize() else {
            return Err(self.error(el, "lookat: origin and target are the same point"));
        };
        let up = match three("up")? {
            Some(u) => u,
            None => dir.any_orthonormal_vector(),
        };
        let Some(left) = up.cross(dir).try_normalize() else {
            return Err(self.error(el, "lookat: up is parallel to the view direction"));
        };
        let new_up = dir.cross(left);
        Ok(Mat4::from_cols(
            left.extend(0.0),
            new_up.extend(0.0),
            dir.extend(0.0),
            origin.extend(1.0),
        ))
    }
}

/// `#rrggbb` as sRGB-encoded values in 0..1.
fn hex_color(text: &str) -> Option<Vec3> {
    let hex = text.strip_prefix('#')?;
    if hex.len() != 6 {
        return None;
    }
    let channel = |i: usize| u8::from_str_radix(hex.get(i..i + 2)?, 16).ok();
    Some(Vec3::new(
        channel(0)? as f32 / 255.0,
        channel(2)? as f32 / 255.0,
        channel(4)? as f32 / 255.0,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn substitution() {
        let params = vec![("res".to_string(), "256".to_string())];
        assert_eq!(substitute("$res", &params).unwrap(), "256");
        assert_eq!(substitute("a $res, $res!", &params).unwrap(), "a 256, 256!");
        assert!(substitute("$resolution", &params)
            .unwrap_err()
            .contains("resolution"));
        assert!(substitute("$", &params).is_err());
    }

    #[test]
    fn camel_case_names() {
        assert_eq!(snake_case("toWorld"), "to_world");
        assert_eq!(snake_case("diffuseReflectance"), "diffuse_reflectance");
    }

    #[test]
    fn hex_colours() {
        assert_eq!(hex_color("#ff0000"), Some(Vec3::X));
        assert_eq!(hex_color("#ff00"), None);
    }
}
