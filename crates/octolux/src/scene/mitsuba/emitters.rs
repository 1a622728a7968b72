//! Emitters of the Mitsuba importer: punctual lights, the sky, and the colour of area
//! emitters.

use super::xml::Element;
use super::Loader;
use crate::scene::{EnvironmentMap, Light, LightKind, Sky};
use crate::Result;
use glam::{Mat3, Mat4, Vec3};

impl<'a> Loader<'a> {
    /// An emitter's colour parameter (a texture is replaced by `default`, with a warning).
    pub(super) fn emitted(&self, el: &Element, name: &str, default: f32) -> Result<Vec3> {
        let Some(p) = el.param(name) else {
            return Ok(Vec3::splat(default));
        };
        let p = self.resolve(p)?;
        if let Some(c) = self.doc.color_value(p)? {
            if c.min_element() < 0.0 {
                return Err(self.doc.error(
                    p,
                    format!("{}: '{name}' must not be negative", el.describe()),
                ));
            }
            return Ok(c);
        }
        log::warn!(
            "{}: {}: '{name}' given as {} is not supported; replaced by {default}",
            self.doc.at(p),
            el.describe(),
            p.describe()
        );
        Ok(Vec3::splat(default))
    }

    pub(super) fn light_name(&self, el: &Element) -> String {
        el.attr("id").map_or_else(
            || format!("{}-{}", el.kind(), self.scene.lights.len()),
            str::to_string,
        )
    }

    pub(super) fn emitter(&mut self, el: &'a Element) -> Result<()> {
        let doc = self.doc;
        let light = |kind, color, position, direction| Light {
            name: self.light_name(el),
            kind,
            color,
            intensity: 1.0,
            position,
            direction,
            animation: None,
        };
        let to_world = self.to_world(el)?;
        let origin = to_world.transform_point3(Vec3::ZERO);
        let axis = to_world.transform_vector3(Vec3::Z).normalize_or_zero();
        let new = match el.kind() {
            "point" => {
                let position = doc.point(el, "position")?.unwrap_or(origin);
                light(
                    LightKind::Point,
                    self.emitted(el, "intensity", 1.0)?,
                    position,
                    Vec3::NEG_Y,
                )
            }
            "spot" => {
                let outer = doc.float(el, "cutoff_angle", 20.0)?;
                let inner = doc.float(el, "beam_width", outer * 0.75)?;
                if !(outer > 0.0 && outer < 180.0 && inner > 0.0 && inner <= outer) {
                    return Err(doc.error(
                        el,
                        format!(
                            "spot: need 0 < beam_width ({inner}) <= cutoff_angle ({outer}) < 180"
                        ),
                    ));
                }
                light(
                    LightKind::Spot {
                        inner_angle: inner.to_radians(),
                        outer_angle: outer.to_radians(),
                    },
                    self.emitted(el, "intensity", 1.0)?,
                    origin,
                    axis,
                )
            }
            "directional" => {
                let direction = match doc.point(el, "direction")? {
                    Some(d) => d.normalize_or_zero(),
                    None => axis,
                };
                if direction == Vec3::ZERO {
                    return Err(doc.error(el, "directional: zero direction"));
                }
                light(
                    LightKind::Directional,
                    self.emitted(el, "irradiance", 1.0)?,
                    Vec3::ZERO,
                    direction,
                )
            }
            "envmap" | "constant" => return self.sky(el, to_world),
            "area" if el.attr("id").is_some() => return Ok(()), // used by shapes
            "area" => {
                self.skip(el, "outside a shape emits nothing");
                return Ok(());
            }
            _ => {
                self.skip(el, "is not a supported emitter type");
                return Ok(());
            }
        };
        self.scene.lights.push(new);
        Ok(())
    }

    pub(super) fn sky(&mut self, el: &Element, to_world: Mat4) -> Result<()> {
        if self.scene.sky.is_some() {
            log::warn!(
                "{}: {}: the scene already has an environment emitter; skipped",
                self.doc.at(el),
                el.describe()
            );
            return Ok(());
        }
        let sky = if el.kind() == "constant" {
            Sky::constant(self.emitted(el, "radiance", 1.0)?)
        } else {
            let file = self.file(el, "filename")?;
            // Mitsuba places the map's rows differently (`EnvironmentMap::with_mitsuba_rows`).
            let map = EnvironmentMap::load(&file)
                .map_err(|e| self.doc.error(el, e))?
                .with_mitsuba_rows();
            let scale = self.doc.float(el, "scale", 1.0)?;
            if scale < 0.0 {
                return Err(self.doc.error(el, "envmap: scale must not be negative"));
            }
            let mut sky = Sky::map(map);
            sky.intensity = scale;
            sky.to_world = self.rotation_of(el, to_world);
            sky
        };
        self.scene.sky = Some(sky);
        Ok(())
    }

    /// The rotation part of `m` (Gram-Schmidt), with a warning when `m` scales, shears or
    /// mirrors.
    pub(super) fn rotation_of(&self, el: &Element, m: Mat4) -> Mat3 {
        let a = Mat3::from_mat4(m);
        let x = a.x_axis.normalize_or(Vec3::X);
        let y = (a.y_axis - x * x.dot(a.y_axis)).normalize_or(x.any_orthonormal_vector());
        let z = x.cross(y);
        let r = Mat3::from_cols(x, y, z);
        let mirrored = a.determinant() < 0.0;
        if mirrored || !(a - r).to_cols_array().iter().all(|v| v.abs() < 1e-3) {
            log::warn!(
                "{}: {}: to_world {}; only its rotation is used",
                self.doc.at(el),
                el.describe(),
                if mirrored {
                    "mirrors"
                } else {
                    "scales or shears"
                }
            );
        }
        r
    }
}
