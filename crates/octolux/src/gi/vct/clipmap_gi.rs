//! `vct-clipmap`: voxel cone tracing on the clipmap (`003` §3.2, §4): per frame the clipmap
//! follows the camera, or the nearest point of the scene to a camera outside it (and
//! revoxelises around moving objects), direct light (plus, with
//! multiple bounces, the indirect light the voxels gathered last frame) is injected into its
//! voxels, and every pixel gathers through six cones.
//!
//! Everything is made in [`VctClipmap::new`] except the clipmap itself, which the first frame
//! makes with its scene ([`ClipmapVoxels::new`]): its voxel size follows from the camera's
//! place in the scene's bounds, which only a frame knows. From then on it exists.

use super::bounce_list::bounce_settle_frames;
use super::clipmap_bounce::ClipmapBounce;
use super::clipmap_tail::{tail_levels, ClipmapTail};
use super::cone::ConeParams;
use super::tracer::{ConeTracer, TraceStructure};
use super::{ClipmapInjection, VctSettings, VctStructure};
use crate::gi::{GiFrame, GiTechnique};
use crate::gpu::alloc::storage;
use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::clipmap::sample::{ClipInfo, CLIP_BINDINGS, CLIP_RADIANCE_BINDING};
use crate::voxel::clipmap::{Clipmap, ClipmapOptions, ClipmapSettings};
use crate::voxel::{objects_triangles, scene_triangles_split, VoxelTriangle};
use crate::{Error, Result};

const OWNER: &str = "vct-clipmap";

/// Voxel cone tracing on the clipmap.
pub struct VctClipmap {
    settings: VctSettings,
    /// The scene's bounds at time 0, which size the clipmap.
    bounds: (glam::Vec3, glam::Vec3),
    /// The clipmap and its scene, made at the first frame.
    voxels: Option<ClipmapVoxels>,
    tracer: ConeTracer,
    /// The clipmap's `ClipInfo` block, written every frame.
    info: wgpu::Buffer,
    /// Coarser copies of the coarsest level, for wide cones.
    tail: ClipmapTail,
    /// Multiple bounces (`multi_bounce`).
    bounce: Option<ClipmapBounce>,
}

/// The clipmap and where its scene's animated triangles start.
struct ClipmapVoxels {
    clipmap: Clipmap,
    /// Triangles of animated objects start here in the clipmap's scene.
    dynamic_from: usize,
}

impl ClipmapVoxels {
    /// The clipmap for the camera of `frame` (centred as [`clipmap_centre`] says, its voxel
    /// sized so that the levels reach the farthest corner of `bounds` from there), with `frame`'s scene: the static triangles, then the
    /// animated objects'. Sets the cone parameters of `tracer` that go with its voxel; with
    /// multiple bounces, the injection adds `bounce`.
    fn new(
        ctx: &GpuContext,
        s: &VctSettings,
        (lo, hi): (glam::Vec3, glam::Vec3),
        tracer: &ConeTracer,
        bounce: Option<&wgpu::Buffer>,
        frame: &GiFrame,
    ) -> Result<ClipmapVoxels> {
        let centre = clipmap_centre(frame.view.position, (lo, hi));
        let far = (0..8)
            .map(|k| {
                let corner = glam::Vec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                );
                (corner - centre).abs().max_element()
            })
            .fold(0.0f32, f32::max);
        let span = s.resolution as f32 * (1u32 << (s.levels - 1)) as f32;
        let voxel = 2.2 * far / span;
        // Footprints grow up to the tail's coarsest voxel; past it, steps stay that size.
        let coarsest = voxel * (1u32 << (s.levels - 1 + tail_levels(s.resolution))) as f32;
        if !voxel.is_finite() || voxel <= 0.0 {
            return Err(Error::InvalidArgument(format!(
                "vct-clipmap: no clipmap fits a camera at {} and scene bounds {lo} to {hi}",
                frame.view.position
            )));
        }
        let clip = ClipmapSettings {
            resolution: s.resolution,
            levels: s.levels,
            voxel_size: voxel,
        };
        tracer.set_cone(
            ctx,
            |cones| ConeParams::for_settings(s, cones, voxel, coarsest, 0.5 * span * voxel),
            s,
        );
        let options = ClipmapOptions {
            filtered: true,
            anisotropic: false,
        };
        let mut clipmap = Clipmap::with_owner(ctx, clip, options, OWNER)?;
        clipmap.set_bounce(bounce.cloned())?;
        let (still, moving) = scene_triangles_split(frame.scene, frame.instant);
        let mut all: Vec<VoxelTriangle> = still;
        let dynamic_from = all.len();
        all.extend(moving);
        clipmap.set_scene(ctx, &all);
        Ok(ClipmapVoxels {
            clipmap,
            dynamic_from,
        })
    }

    /// Replaces the animated objects' triangles with this frame's (their old and new regions
    /// are revoxelised at the next follow); nothing for a static scene.
    fn move_objects(&mut self, ctx: &GpuContext, frame: &GiFrame) -> Result<()> {
        if frame.scene.objects.iter().any(|o| o.animation.is_some()) {
            let moving = objects_triangles(frame.scene, frame.instant, true);
            self.clipmap
                .replace_triangles(ctx, self.dynamic_from, &moving)?;
        }
        Ok(())
    }
}

/// Where the clipmap's levels are centred for a camera at `camera` in a scene of bounds
/// `(lo, hi)`: on the camera while it is inside them, else on the nearest point of them.
/// Following the camera everywhere puts the fine levels where the camera is; from outside the
/// scene (a room seen through its open side, a building from the street) they then held only
/// air, and the scene lay in the coarsest level: `two-rooms-leak`'s rooms in 19 cm voxels,
/// 5 across a room, which its cones could neither light nor keep apart (docs/vct.md, "The
/// clipmap's centre").
fn clipmap_centre(camera: glam::Vec3, (lo, hi): (glam::Vec3, glam::Vec3)) -> glam::Vec3 {
    camera.clamp(lo, hi.max(lo))
}

impl VctClipmap {
    /// The technique for `scene` at `width` x `height`.
    pub fn new(
        ctx: &GpuContext,
        settings: &VctSettings,
        scene: &crate::scene::Scene,
        width: u32,
        height: u32,
    ) -> Result<VctClipmap> {
        settings.validate()?;
        let (lo, hi) = scene.gi_bounds_at(0.0);
        let extent = (hi - lo).max_element();
        if !extent.is_finite() || extent <= 0.0 {
            return Err(Error::InvalidArgument(format!(
                "vct-clipmap needs a scene with extent; its bounds are {lo} to {hi}"
            )));
        }
        let tracer = ConeTracer::new(
            ctx,
            OWNER,
            TraceStructure {
                trace: "gi/vct/clipmap_trace",
                bounce: "gi/vct/clipmap_bounce",
                features: vec![("facing", settings.facing)],
                bounce_features: vec![("facing", settings.facing)],
                octree: false,
            },
            settings,
            settings.diffuse_cones(VctStructure::Clipmap),
            settings.bounce_cones(VctStructure::Clipmap),
            width,
            height,
        );
        let bounce = settings
            .multi_bounce
            .then(|| ClipmapBounce::new(ctx, settings, &tracer));
        Ok(VctClipmap {
            settings: settings.clone(),
            bounds: (lo, hi),
            voxels: None,
            info: storage(
                ctx,
                OWNER,
                "clipmap info",
                std::mem::size_of::<ClipInfo>() as u64,
            ),
            tail: ClipmapTail::new(ctx, OWNER, settings.resolution),
            tracer,
            bounce,
        })
    }

    /// The clipmap, once the first frame made it (for tests and tools).
    pub fn clipmap(&self) -> Option<&Clipmap> {
        self.voxels.as_ref().map(|v| &v.clipmap)
    }
}

impl GiTechnique for VctClipmap {
    fn name(&self) -> &str {
        "vct-clipmap"
    }

    fn update(&mut self, ctx: &GpuContext, frame: &GiFrame, timer: &mut PassTimer) -> Result<()> {
        // 1. Voxels: the clipmap (made at the first frame) follows the camera (its nearest point
        //    in the scene from outside, `clipmap_centre`); moving objects
        //    are revoxelised.
        let voxels = match &mut self.voxels {
            Some(voxels) => {
                voxels.move_objects(ctx, frame)?;
                voxels
            }
            None => {
                let bounce = self.bounce.as_ref().map(|b| &b.irradiance);
                let made = ClipmapVoxels::new(
                    ctx,
                    &self.settings,
                    self.bounds,
                    &self.tracer,
                    bounce,
                    frame,
                )?;
                self.voxels.insert(made)
            }
        };
        let clipmap = &mut voxels.clipmap;
        clipmap.follow(ctx, timer, clipmap_centre(frame.view.position, self.bounds))?;
        let info = ClipInfo::new(&clipmap.settings, &clipmap.origins);
        ctx.queue
            .write_buffer(&self.info, 0, bytemuck::bytes_of(&info));
        // 2. Multiple bounces: the voxels the clipmap rewrote lose the bounce light they had.
        if let Some(bounce) = &mut self.bounce {
            bounce.clear_revoxelised(ctx, timer, &self.info, clipmap);
        }
        // 3. Direct light (plus, with multiple bounces, the indirect irradiance the voxels
        //    gathered last frame) into the voxels.
        match self.settings.injection {
            ClipmapInjection::ShadowMaps => clipmap.inject_shadow_maps(
                ctx,
                timer,
                frame.lights,
                frame.instant.lights.len() as u32,
                frame.shadows.lookup(),
            )?,
            ClipmapInjection::VoxelRays => clipmap.inject(
                ctx,
                timer,
                &frame.instant.lights,
                self.settings.inject_steps,
            )?,
        }
        let clipmap = &voxels.clipmap;
        let radiance = clipmap
            .radiance
            .as_ref()
            .ok_or_else(|| Error::Gpu("vct-clipmap: the injection left no radiance".into()))?;
        // 4. The tail: coarser copies of the coarsest level, for wide cones.
        self.tail.record(ctx, timer, &self.info, radiance);
        // 5. Multiple bounces: this frame's set of voxels gathers indirect irradiance for the
        //    next frame (every voxel once in `bounce_frames` frames).
        if let Some(bounce) = &mut self.bounce {
            let sources = (&self.info, clipmap, radiance);
            bounce.gather(ctx, timer, sources, &self.tail, &self.tracer)?;
        }
        // 6. Six cones per pixel through the injected radiance (sparse, then reconstructed;
        //    the specular cone where enabled).
        self.tracer.record(
            ctx,
            frame,
            timer,
            &[
                (CLIP_BINDINGS, self.info.as_entire_binding()),
                (CLIP_RADIANCE_BINDING, radiance.as_entire_binding()),
                (13, self.tail.buffer.as_entire_binding()),
            ],
        )
    }

    fn indirect_view(&self) -> &wgpu::TextureView {
        self.tracer.view()
    }

    fn specular_view(&self) -> Option<&wgpu::TextureView> {
        self.tracer.specular().map(|(_, view)| view)
    }

    fn reference_transport(&self) -> crate::transport::Transport {
        super::cone_transport(self.bounce.is_some())
    }

    fn settle_frames(&self) -> u32 {
        // The bounces converge over frames; one pass of light is all without them.
        self.bounce
            .as_ref()
            .map_or(0, |b| bounce_settle_frames(b.sets))
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_levels_follow_the_camera_inside_the_scene_and_its_nearest_point_outside() {
        let bounds = (glam::Vec3::ZERO, glam::Vec3::new(2.0, 2.0, 2.0));
        let inside = glam::Vec3::new(0.5, 1.5, 1.0);
        assert_eq!(clipmap_centre(inside, bounds), inside);
        let front = glam::Vec3::new(1.0, 1.0, -3.5);
        assert_eq!(
            clipmap_centre(front, bounds),
            glam::Vec3::new(1.0, 1.0, 0.0)
        );
        let corner = glam::Vec3::new(-1.0, 5.0, 9.0);
        assert_eq!(
            clipmap_centre(corner, bounds),
            glam::Vec3::new(0.0, 2.0, 2.0)
        );
        // A flat scene (no extent along y) keeps its plane.
        let flat = (glam::Vec3::ZERO, glam::Vec3::new(2.0, 0.0, 2.0));
        assert_eq!(clipmap_centre(front, flat), glam::Vec3::new(1.0, 0.0, 0.0));
    }
}
