//! `vct-svo`: voxel cone tracing on the sparse voxel octree (`003` §3.1-3.2): the octree of
//! the scene's static geometry is built once; per frame its dynamic part is rebuilt from the
//! animated objects, direct light (plus, with multiple bounces, the irradiance every voxel
//! gathered last frame) is injected into its leaves from the renderer's shadow maps and
//! filtered up the levels (and, with `anisotropic`, composited per direction), the voxels
//! gather the next bounce, and every traced pixel gathers through the diffuse cones.

use super::bounce_list::{bounce_settle_frames, bounce_spread, BounceList};
use super::cone::ConeParams;
use super::tracer::{ConeTracer, TraceStructure};
use super::{VctSettings, VctStructure};
use crate::gi::{GiFrame, GiTechnique};
use crate::gpu::pass::KeptBindGroup;
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::Scene;
use crate::voxel::svo::aniso_radiance::SvoAnisoRadiance;
use crate::voxel::svo::dynamic::DynamicReserve;
use crate::voxel::svo::inject::{SvoBounce, SvoBounceTable};
use crate::voxel::svo::sample::{
    svo_bindings, svo_facing_bindings, svo_radiance_bindings, SvoInfo, SVO_ANISO_RADIANCE_BINDING,
};
use crate::voxel::svo::{Svo, SvoBuilder};
use crate::voxel::{objects_triangles, VoxelGrid};
use crate::{Error, Result};

const OWNER: &str = "vct-svo";

/// Storage buffers the light injection binds with `facing` (`voxel/svo/inject.wgsl`: the
/// octree, its radiance and facing pools, the bounce buffers and the lights), two more than
/// [`crate::embed::required_limits`] asks of every device.
pub const FACING_STORAGE_BUFFERS: u32 = 22;

/// Voxel cone tracing on the sparse voxel octree.
pub struct VctSvo {
    builder: SvoBuilder,
    svo: Svo,
    /// Whether the scene has animated objects (the dynamic part is rebuilt every frame).
    animated: bool,
    tracer: ConeTracer,
    info: wgpu::Buffer,
    /// What the tracer's anisotropic radiance binding holds.
    aniso: AnisoBinding,
    /// Multiple bounces.
    bounce: Option<Bounce>,
}

/// The anisotropic radiance (`anisotropic`), or a placeholder word for its binding (the
/// tracer's WGSL declares it either way).
enum AnisoBinding {
    Values(SvoAnisoRadiance),
    Placeholder(wgpu::Buffer),
}

/// Multiple bounces: the buffers the injection and the bounce gathers share, the gathers and
/// their parameters.
struct Bounce {
    buffers: SvoBounce,
    /// The static leaf voxels' gather (one invocation per listed voxel).
    pipeline: wgpu::ComputePipeline,
    /// The static slots whose voxel gathers this frame.
    list: BounceList,
    /// With animated objects: the dynamic leaf voxels' gather into the bounce table.
    dynamic: Option<wgpu::ComputePipeline>,
    /// The [`BounceParams`] block, written every frame from `block`.
    params: wgpu::Buffer,
    block: BounceParams,
    /// The frames one round of the static voxels' gather is spread over (`bounce_frames`).
    bounce_frames: u32,
    /// The static gather's bind group and the dynamic one's per table written (the tables
    /// alternate), kept while their resources are.
    groups: [KeptBindGroup; 3],
}

/// Parameter block `BounceParams` of `svo_bounce.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct BounceParams {
    /// Static leaf voxel slots (the dynamic leaves' slots follow).
    static_slots: u32,
    /// Entries of the dynamic voxels' table (a power of two).
    table_capacity: u32,
    /// The leaf level, whose dynamic nodes the dynamic gather reads.
    leaf_level: u32,
    /// This frame's set of static voxels ([`bounce_spread`]).
    spread: u32,
}

/// Entries of a dynamic bounce table for a reserve of `nodes`: room for every voxel the
/// reserve can hold, rounded up to a power of two (the probe limit drops what does not fit
/// in a table that full).
fn bounce_table_entries(nodes: u32) -> u64 {
    (nodes as u64 * 8).next_power_of_two()
}

/// A clear error where a bounce buffer of `bytes` would not fit one storage binding.
fn check_binding(ctx: &GpuContext, what: &str, bytes: u64) -> Result<()> {
    ctx.check_storage_binding(
        &format!("vct-svo: the {what}"),
        bytes,
        "lower `dynamic_reserve` or `octree_resolution`, or turn `multi_bounce` off",
    )
}

impl VctSvo {
    /// The technique for `scene` at `width` x `height`: builds the octree of the static
    /// geometry (once, here; it waits for the GPU to size its buffers).
    pub fn new(
        ctx: &GpuContext,
        settings: &VctSettings,
        scene: &Scene,
        width: u32,
        height: u32,
    ) -> Result<VctSvo> {
        settings.validate()?;
        let limit = ctx.device.limits().max_storage_buffers_per_shader_stage;
        if settings.facing && limit < FACING_STORAGE_BUFFERS {
            return Err(Error::InvalidArgument(format!(
                "vct-svo with `facing` binds {FACING_STORAGE_BUFFERS} storage buffers in its light \
                 injection, this device allows {limit} per shader stage \
                 (max_storage_buffers_per_shader_stage): create it with the adapter's limits, \
                 or turn `facing` off"
            )));
        }
        let (lo, hi) = scene.gi_bounds_over_animation();
        let extent = (hi - lo).max_element();
        if !extent.is_finite() || extent <= 0.0 {
            return Err(Error::InvalidArgument(format!(
                "vct-svo needs a scene with extent; its bounds are {lo} to {hi}"
            )));
        }
        let grid = VoxelGrid::enclosing((lo, hi), settings.octree_resolution)?;
        let animated = scene.objects.iter().any(|o| o.animation.is_some());
        let reserve = if animated {
            DynamicReserve::new(settings.dynamic_reserve)
        } else {
            DynamicReserve::NONE
        };
        if settings.multi_bounce && animated {
            // Checked before the octree is built: the bounce table follows from the reserve.
            check_binding(ctx, "bounce table", bounce_table_entries(reserve.nodes) * 8)?;
        }
        let builder = SvoBuilder::new(ctx).with_facing(settings.facing);
        let still = objects_triangles(scene, &scene.frame(0.0, 0), false);
        let (svo, _) = builder.build_with_reserve(ctx, &grid, &still, reserve)?;
        let tracer = ConeTracer::new(
            ctx,
            OWNER,
            TraceStructure {
                trace: "gi/vct/svo_trace",
                bounce: "gi/vct/svo_bounce",
                features: vec![
                    ("anisotropic", settings.anisotropic),
                    ("facing", settings.facing),
                ],
                bounce_features: vec![
                    ("anisotropic", settings.anisotropic_radiance_in_bounce()),
                    ("facing", settings.facing),
                ],
                octree: true,
            },
            settings,
            settings.diffuse_cones(VctStructure::Octree),
            settings.bounce_cones(VctStructure::Octree),
            width,
            height,
        );
        let span = grid.voxel_size * grid.resolution as f32;
        // Cones end where they leave the grid at the latest (its diagonal).
        tracer.set_cone(
            ctx,
            |cones| {
                ConeParams::for_settings(
                    settings,
                    cones,
                    grid.voxel_size,
                    0.5 * span,
                    3f32.sqrt() * span,
                )
            },
            settings,
        );
        let info = ctx.create_buffer_init(
            OWNER,
            "octree info",
            bytemuck::bytes_of(&SvoInfo::new(&grid, svo.pool_bricks())),
            wgpu::BufferUsages::STORAGE,
        );
        let aniso = if settings.anisotropic || settings.anisotropic_bounce {
            AnisoBinding::Values(SvoAnisoRadiance::new(ctx, &svo)?)
        } else {
            AnisoBinding::Placeholder(ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some("anisotropic radiance (placeholder)"),
                    size: 16,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                },
            ))
        };
        let bounce = if settings.multi_bounce {
            Some(Bounce::new(
                ctx,
                &tracer,
                &svo,
                animated.then_some(reserve.nodes),
                settings.bounce_frames,
            )?)
        } else {
            None
        };
        Ok(VctSvo {
            builder,
            svo,
            animated,
            tracer,
            info,
            aniso,
            bounce,
        })
    }

    /// The octree (for tests and tools).
    pub fn octree(&self) -> &Svo {
        &self.svo
    }
}

impl Bounce {
    /// The bounce buffers and gathers of `svo`; with `dynamic_reserve` (nodes, for animated
    /// scenes) also the dynamic voxels' tables and gather.
    fn new(
        ctx: &GpuContext,
        tracer: &ConeTracer,
        svo: &Svo,
        dynamic_reserve: Option<u32>,
        bounce_frames: u32,
    ) -> Result<Bounce> {
        let (first, end) = svo.levels().last().copied().unwrap_or((0, 0));
        let slots = (end - first) * 8;
        let dynamic_slots = dynamic_reserve.unwrap_or(0) as u64 * 8;
        let capacity = bounce_table_entries(dynamic_reserve.unwrap_or(0));
        let geometry_bytes = (slots as u64 + dynamic_slots) * 8;
        check_binding(ctx, "bounce geometry", geometry_bytes)?;
        check_binding(ctx, "bounce table", capacity * 8)?;
        let buffer = |label: &str, bytes: u64| {
            ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes.max(16),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                },
            )
        };
        // Two tables, each under its own ledger name.
        let tables = dynamic_reserve.map(|_| {
            ["a", "b"].map(|t| SvoBounceTable {
                keys: buffer(&format!("bounce table {t} keys"), capacity * 4),
                values: buffer(&format!("bounce table {t} values"), capacity * 8),
                capacity: capacity as u32,
            })
        });
        let module = tracer.bounce_module(ctx);
        let block = BounceParams {
            static_slots: slots,
            table_capacity: capacity as u32,
            leaf_level: svo.levels().len().saturating_sub(1) as u32,
            spread: 0,
        };
        let params = ctx.create_buffer_init(
            OWNER,
            "bounce params",
            bytemuck::bytes_of(&block),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        Ok(Bounce {
            buffers: SvoBounce {
                irradiance: buffer("bounce irradiance", slots as u64 * 8),
                geometry: buffer("bounce geometry", geometry_bytes),
                tables,
                frame: 0,
            },
            pipeline: ctx.compute_pipeline("bounce", &module, "bounce"),
            list: BounceList::new(ctx, OWNER, &module, slots),
            dynamic: dynamic_reserve
                .map(|_| ctx.compute_pipeline("bounce_dynamic", &module, "bounce_dynamic")),
            params,
            block,
            bounce_frames,
            groups: Default::default(),
        })
    }

    /// Records the gather of this frame's set of static voxels (every one once in
    /// `bounce_frames` frames) and, with a dynamic part, every dynamic voxel's gather into this
    /// frame's table; then flips the tables for the next frame.
    fn record(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        svo: &Svo,
        structure: &[(u32, wgpu::BindingResource<'_>)],
        tracer: &ConeTracer,
    ) -> Result<()> {
        let group = |kept: &KeptBindGroup,
                     pipeline: &wgpu::ComputePipeline,
                     extra: &[(u32, wgpu::BindingResource)],
                     pass: &str|
         -> Result<wgpu::BindGroup> {
            let mut entries = structure.to_vec();
            entries.extend(tracer.bounce_work(ctx, pass)?);
            entries.push((5, tracer.bounce_params().as_entire_binding()));
            entries.push((21, self.buffers.geometry.as_entire_binding()));
            entries.extend(extra.iter().cloned());
            Ok(kept.get(ctx, "vct bounce", pipeline, &entries))
        };
        let irradiance = (22, self.buffers.irradiance.as_entire_binding());
        let mut extra = vec![irradiance.clone()];
        extra.extend(self.list.gather_entries());
        let statics = group(&self.groups[0], &self.pipeline, &extra, "bounce")?;
        self.block.spread = bounce_spread(self.bounce_frames, self.buffers.frame);
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&self.block));
        let list_entries = [
            (20, self.params.as_entire_binding()),
            (21, self.buffers.geometry.as_entire_binding()),
            irradiance,
        ];
        self.list.record(
            ctx,
            timer,
            "bounce",
            &list_entries,
            &self.pipeline,
            &statics,
        );
        if let (Some(pipeline), Some(table)) = (&self.dynamic, self.buffers.write_table()) {
            let dynamics = group(
                &self.groups[1 + (self.buffers.frame & 1) as usize],
                pipeline,
                &[
                    (20, self.params.as_entire_binding()),
                    (23, svo.control().as_entire_binding()),
                    (24, table.keys.as_entire_binding()),
                    (25, table.values.as_entire_binding()),
                ],
                "bounce (dynamic)",
            )?;
            let (args, offset) = svo.dynamic_leaf_dispatch();
            timer.pass("bounce (dynamic)", |encoder, stamps| {
                encoder.clear_buffer(&table.keys, 0, None);
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("vct bounce (dynamic)"),
                    timestamp_writes: stamps.compute(),
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &dynamics, &[]);
                // One workgroup per dynamic leaf node.
                pass.dispatch_workgroups_indirect(args, offset);
            });
        }
        self.buffers.frame = self.buffers.frame.wrapping_add(1);
        Ok(())
    }
}

impl GiTechnique for VctSvo {
    fn name(&self) -> &str {
        "vct-svo"
    }

    fn update(&mut self, ctx: &GpuContext, frame: &GiFrame, timer: &mut PassTimer) -> Result<()> {
        // 1. Voxels: the animated objects' voxels replace the dynamic part (no readback: its
        //    sizes stay on the GPU).
        if self.animated {
            let moving = objects_triangles(frame.scene, frame.instant, true);
            self.builder
                .record_dynamic(ctx, timer, &mut self.svo, &moving)?;
        }
        // 2. Direct light (plus, with multiple bounces, the irradiance the voxels gathered
        //    last frame) into the leaves from the shadow maps, filtered up the levels.
        self.builder.inject_with_bounce(
            ctx,
            timer,
            &self.svo,
            frame.shadows.lookup(),
            frame.lights,
            frame.instant.lights.len() as u32,
            self.bounce.as_ref().map(|b| &b.buffers),
        )?;
        // 3. With `anisotropic`: the radiance per travel direction, composited up the levels.
        let svo = &self.svo;
        let aniso = match &self.aniso {
            AnisoBinding::Values(aniso) => {
                aniso.record(timer, svo);
                aniso.buffer()
            }
            AnisoBinding::Placeholder(placeholder) => placeholder,
        };
        let mut structure = svo_bindings(&self.info, svo).to_vec();
        structure.extend(svo_radiance_bindings(svo));
        structure.extend(svo_facing_bindings(svo).into_iter().flatten());
        structure.push((SVO_ANISO_RADIANCE_BINDING, aniso.as_entire_binding()));
        // 4. Multiple bounces: every voxel gathers irradiance for the next frame (static
        //    ones by slot, dynamic ones into the bounce table the next injection reads).
        if let Some(bounce) = &mut self.bounce {
            bounce.record(ctx, timer, svo, &structure, &self.tracer)?;
        }
        // 5. The diffuse cones per pixel through the injected radiance (sparse, then reconstructed;
        //    the specular cone where enabled).
        self.tracer.record(ctx, frame, timer, &structure)
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

    fn other_ledger_owners(&self) -> &[&'static str] {
        &[crate::voxel::svo::OWNER]
    }

    fn settle_frames(&self) -> u32 {
        // The bounces converge over frames; one pass of light is all without them.
        self.bounce
            .as_ref()
            .map_or(0, |b| bounce_settle_frames(b.bounce_frames))
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn bounce_params_mirror_the_wgsl_block() {
        assert_mirrors_wgsl!(
            BounceParams,
            "gi/vct/svo_bounce",
            "BounceParams",
            [static_slots, table_capacity, leaf_level, spread],
            &[("anisotropic", false), ("facing", false)]
        );
    }
}
