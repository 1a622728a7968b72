//! Sensors of the Mitsuba importer: perspective cameras.

use super::xml::Element;
use super::{Loader, FILM};
use crate::scene::{Asked, Camera, FileRequest};
use crate::Result;
use glam::{Mat3, Vec3};

impl<'a> Loader<'a> {
    pub(super) fn sensor(&mut self, el: &'a Element) -> Result<()> {
        let doc = self.doc;
        match el.kind() {
            "perspective" => {}
            "thinlens" => log::warn!(
                "{}: {}: depth of field is not modelled; a pinhole camera is used",
                doc.at(el),
                el.describe()
            ),
            _ => {
                self.skip(el, "is not a supported sensor type");
                return Ok(());
            }
        }
        if let Some(sampler) = el.children_tagged("sampler").next() {
            // Mitsuba's default sample count is 4.
            let spp = doc.integer(sampler, "sample_count", 4)?;
            let spp = u32::try_from(spp)
                .ok()
                .filter(|&n| n > 0)
                .ok_or_else(|| doc.error(sampler, "sample_count must be a positive integer"))?;
            self.scene.requests.push(FileRequest {
                at: format!("{}: {}", doc.at(sampler), sampler.describe()),
                asked: Asked::Spp(spp),
            });
        }
        let film = el.children_tagged("film").next();
        let (width, height) = match film {
            Some(f) => (
                doc.integer(f, "width", FILM.0)?,
                doc.integer(f, "height", FILM.1)?,
            ),
            None => FILM,
        };
        if width <= 0 || height <= 0 {
            return Err(doc.error(
                film.unwrap_or(el),
                "film: width and height must be positive",
            ));
        }
        log::info!(
            "{}: sensor film {width}x{height} (the render size is chosen when rendering)",
            doc.at(el)
        );
        let (w, h) = (width as f32, height as f32);
        let fov = match (el.param("fov"), doc.string(el, "focal_length")) {
            (Some(_), Some(_)) => {
                return Err(doc.error(el, "give fov or focal_length, not both"));
            }
            (Some(_), None) => doc.float(el, "fov", 0.0)?,
            (None, focal) => {
                let text = focal.unwrap_or("50mm");
                let mm: f32 = text
                    .trim()
                    .trim_end_matches("mm")
                    .trim()
                    .parse()
                    .ok()
                    .filter(|f: &f32| *f > 0.0 && f.is_finite())
                    .ok_or_else(|| {
                        doc.error(el, format!("focal_length '{text}' is not like '50mm'"))
                    })?;
                // Of a 36 mm wide film, as the x axis.
                (2.0 * (18.0 / mm).atan()).to_degrees()
            }
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(doc.error(el, format!("fov {fov} must lie in (0, 180) degrees")));
        }
        let half = (fov.to_radians() * 0.5).tan();
        let axis = doc.string(el, "fov_axis").unwrap_or("x");
        let axis = match axis {
            "smaller" if w > h => "y",
            "smaller" => "x",
            "larger" if w > h => "x",
            "larger" => "y",
            other => other,
        };
        // Mitsuba keeps the horizontal angle; the vertical one follows from the film's aspect.
        let aspect = w / h;
        let (vfov, hfov) = match axis {
            "x" => (2.0 * (half / aspect).atan(), Some(fov.to_radians())),
            "y" => (fov.to_radians(), None),
            "diagonal" => {
                let diagonal = (w * w + h * h).sqrt();
                let h_fov = 2.0 * (half * w / diagonal).atan();
                (2.0 * (half * h / diagonal).atan(), Some(h_fov))
            }
            other => {
                return Err(doc.error(
                    el,
                    format!("fov_axis '{other}' (expected x, y, diagonal, smaller or larger)"),
                ))
            }
        };
        let near = doc.float(el, "near_clip", 0.01)?;
        let far = doc.float(el, "far_clip", 10000.0)?;
        if !(near > 0.0 && far > near) {
            return Err(doc.error(el, "need 0 < near_clip < far_clip"));
        }
        let m = self.to_world(el)?;
        let position = m.transform_point3(Vec3::ZERO);
        let basis = Mat3::from_mat4(m);
        let (Some(forward), Some(up)) =
            (basis.z_axis.try_normalize(), basis.y_axis.try_normalize())
        else {
            return Err(doc.error(el, "sensor: to_world is singular"));
        };
        // Mitsuba refuses scale in a camera's to_world; here it is dropped with a warning.
        self.rotation_of(el, m);
        let index = self.scene.cameras.len();
        self.scene.cameras.push(Camera {
            name: el
                .attr("id")
                .map_or_else(|| format!("camera-{index}"), str::to_string),
            position,
            target: position + forward,
            up,
            vfov,
            hfov,
            near,
            far,
            animation: None,
        });
        Ok(())
    }
}
