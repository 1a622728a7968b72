//! BSDFs and textures of the Mitsuba importer: each bsdf becomes a Lambertian [`Surface`],
//! converted once however many shapes use it.

use super::xml::Element;
use super::{Loader, Surface};
use crate::scene::{obj, Texture};
use crate::Result;
use glam::Vec3;

impl<'a> Loader<'a> {
    /// The surface of bsdf `el` (converted once per bsdf).
    pub(super) fn surface(&mut self, el: &'a Element) -> Result<Surface> {
        let key = el
            .attr("id")
            .map_or_else(|| format!("@{}", self.doc.at(el)), |id| format!("#{id}"));
        if let Some(s) = self.surfaces.get(&key) {
            return Ok(s.clone());
        }
        if self.converting.contains(&key) {
            return Err(self
                .doc
                .error(el, format!("{} contains itself", el.describe())));
        }
        self.converting.push(key.clone());
        let surface = self.convert_surface(el, key.clone());
        self.converting.pop();
        let surface = surface?;
        self.surfaces.insert(key, surface.clone());
        Ok(surface)
    }

    fn convert_surface(&mut self, el: &'a Element, key: String) -> Result<Surface> {
        let name = el.attr("id").unwrap_or(el.kind()).to_string();
        let doc = self.doc;
        let what = el.describe();
        let at = doc.at(el);
        let inner = |this: &Self| -> Result<Option<&'a Element>> {
            let mut found = el
                .children
                .iter()
                .filter(|c| c.tag == "bsdf" || c.tag == "ref")
                .map(|c| this.resolve(c));
            let first = found.next().transpose()?;
            if found.next().is_some() {
                log::warn!("{at}: {what} has several inner bsdfs; the first is used");
            }
            Ok(first)
        };
        let mut surface = match el.kind() {
            "diffuse" => {
                let (color, texture) = self.color_or_texture(el, "reflectance", 0.5)?;
                Surface {
                    base_color: color,
                    texture,
                    ..Surface::grey(key.clone(), name.clone())
                }
            }
            "plastic" | "roughplastic" => {
                log::warn!(
                    "{at}: {what}: the specular coating is not modelled; \
                     diffuse_reflectance is kept"
                );
                let (color, texture) = self.color_or_texture(el, "diffuse_reflectance", 0.5)?;
                Surface {
                    base_color: color,
                    texture,
                    ..Surface::grey(key.clone(), name.clone())
                }
            }
            "principled" => {
                log::warn!(
                    "{at}: {what}: only base_color is used (a Lambertian surface of that colour)"
                );
                let (color, texture) = self.color_or_texture(el, "base_color", 0.5)?;
                Surface {
                    base_color: color,
                    texture,
                    ..Surface::grey(key.clone(), name.clone())
                }
            }
            "twosided" | "bumpmap" | "normalmap" | "mask" => {
                if el.kind() == "bumpmap" || el.kind() == "normalmap" {
                    log::warn!("{at}: {what}: the {} is ignored", el.kind());
                }
                let mut s = match inner(self)? {
                    Some(b) => self.surface(b)?,
                    None => {
                        log::warn!("{at}: {what} has no inner bsdf; diffuse grey 0.5 is used");
                        Surface::grey(key.clone(), name.clone())
                    }
                };
                if el.kind() == "mask" {
                    self.mask(el, &mut s)?;
                }
                Surface {
                    key: key.clone(),
                    name: el.attr("id").map_or(s.name.clone(), str::to_string),
                    ..s
                }
            }
            "dielectric" | "thindielectric" | "roughdielectric" => {
                log::warn!(
                    "{at}: {what}: transmissive surfaces are not modelled; it is clear \
                     (opacity 0) for every pass"
                );
                Surface {
                    opacity: 0.0,
                    masked: true,
                    ..Surface::grey(key.clone(), name.clone())
                }
            }
            other => {
                log::warn!(
                    "{at}: {what}: bsdf type '{other}' is not supported; \
                     replaced by a diffuse grey 0.5"
                );
                Surface::grey(key.clone(), name.clone())
            }
        };
        surface.key = key;
        Ok(surface)
    }

    /// A `mask` bsdf's `opacity`: a number becomes the coverage, a bitmap the texture's alpha.
    pub(super) fn mask(&mut self, el: &'a Element, surface: &mut Surface) -> Result<()> {
        surface.masked = true;
        let Some(p) = el.param("opacity") else {
            surface.opacity = 0.5;
            return Ok(());
        };
        let p = self.resolve(p)?;
        if let Some(c) = self.doc.color_value(p)? {
            surface.opacity = (c.x + c.y + c.z) / 3.0;
            return Ok(());
        }
        if p.tag == "texture" && p.kind() == "bitmap" {
            let mask = self.file(p, "filename")?;
            // The colour image of the inner surface, if it has one, gets the mask as alpha.
            let color = self
                .textures
                .iter()
                .find(|(_, &t)| Some(t) == surface.texture)
                .map(|(k, _)| k.0.clone());
            let key = (color.clone().unwrap_or_default(), Some(mask.clone()), false);
            let index = match self.textures.get(&key) {
                Some(&t) => t,
                None => {
                    let (texture, _) =
                        obj::build_texture(color.as_deref(), Some(&mask), self.account);
                    let texture = texture.ok_or_else(|| {
                        self.doc
                            .error(p, format!("cannot read the mask {}", mask.display()))
                    })?;
                    self.scene.textures.push(texture);
                    let t = self.scene.textures.len() as u32 - 1;
                    self.textures.insert(key, t);
                    t
                }
            };
            surface.texture = Some(index);
            return Ok(());
        }
        log::warn!(
            "{}: {}: an opacity given as {} is not supported; the surface is opaque",
            self.doc.at(p),
            el.describe(),
            p.describe()
        );
        surface.masked = false;
        Ok(())
    }

    /// A colour or texture parameter: (factor, texture).
    pub(super) fn color_or_texture(
        &mut self,
        el: &'a Element,
        name: &str,
        default: f32,
    ) -> Result<(Vec3, Option<u32>)> {
        let Some(p) = el.param(name) else {
            return Ok((Vec3::splat(default), None));
        };
        let p = self.resolve(p)?;
        if let Some(c) = self.doc.color_value(p)? {
            return Ok((c, None));
        }
        if p.tag != "texture" {
            return Err(self.doc.error(
                p,
                format!(
                    "parameter '{name}' should be a colour or a texture, found {}",
                    p.describe()
                ),
            ));
        }
        match p.kind() {
            "bitmap" => {
                let file = self.file(p, "filename")?;
                let raw = self.doc.boolean(p, "raw", false)?;
                if p.param("to_uv").is_some() {
                    log::warn!("{}: {}: to_uv is ignored", self.doc.at(p), p.describe());
                }
                if let Some(mode) = self.doc.string(p, "wrap_mode") {
                    if mode != "repeat" {
                        log::warn!(
                            "{}: {}: wrap_mode '{mode}' is replaced by repeat",
                            self.doc.at(p),
                            p.describe()
                        );
                    }
                }
                let key = (file.clone(), None, raw);
                if let Some(&t) = self.textures.get(&key) {
                    return Ok((Vec3::ONE, Some(t)));
                }
                let mut texture = Texture::load_within(&file, self.account)
                    .map_err(|e| self.doc.error(p, format!("{}: {e}", p.describe())))?;
                if raw {
                    // Linear texel values: store them sRGB-encoded as every texture is.
                    for texel in texture.rgba.chunks_exact_mut(4) {
                        for c in &mut texel[..3] {
                            *c = (linear_to_srgb(*c as f32 / 255.0) * 255.0).round() as u8;
                        }
                    }
                }
                self.scene.textures.push(texture);
                let t = self.scene.textures.len() as u32 - 1;
                self.textures.insert(key, t);
                Ok((Vec3::ONE, Some(t)))
            }
            "checkerboard" => {
                let c0 = self.doc.color(p, "color0")?.unwrap_or(Vec3::splat(0.4));
                let c1 = self.doc.color(p, "color1")?.unwrap_or(Vec3::splat(0.2));
                log::warn!(
                    "{}: {}: replaced by the mean of its two colours",
                    self.doc.at(p),
                    p.describe()
                );
                Ok(((c0 + c1) * 0.5, None))
            }
            other => {
                log::warn!(
                    "{}: {}: texture type '{other}' is not supported; replaced by grey {default}",
                    self.doc.at(p),
                    p.describe()
                );
                Ok((Vec3::splat(default), None))
            }
        }
    }
}

/// sRGB encoding of a linear value in 0..1.
fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}
