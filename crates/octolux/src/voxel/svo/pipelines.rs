//! The octree builder's setup: [`SvoBuilder::new`] compiles every kernel of the build, the
//! dynamic update and the radiance mip once (`svo/build.wgsl` + `svo/dynamic.wgsl`,
//! `svo/accumulate.wgsl`) and makes the bind group layouts they share: group 0 (per-level
//! parameters, fragments, triangles and the node and brick buffers), group 1 (the indirect
//! dispatch arguments, bound only by the kernels that write them) and group 2 (the dynamic
//! part). The options (`with_*`) choose how octrees are built.

use super::bindings::{group0_with, layout0_with, Groups, Pipelines};
use crate::gpu::shader::library_shader;
use crate::gpu::storage_entry;
use crate::gpu::GpuContext;
use crate::voxel::svo::pack::PackBricks;
use crate::voxel::svo::OWNER;
use crate::voxel::voxelize::Voxelizer;

/// The octree build pipelines.
pub struct SvoBuilder {
    pub(super) voxelizer: Voxelizer,
    pub(super) layout0: wgpu::BindGroupLayout,
    layout1: wgpu::BindGroupLayout,
    /// Kernels by entry point, with the groups they bind beyond group 0.
    pub(super) pipelines: Pipelines,
    /// Converts the finished RGBA16F build pool to RGBA8.
    pub(super) pack: PackBricks,
    /// Most bricks per pool buffer ([`SvoBuilder::with_pool_limit`]).
    pub(super) pool_limit: Option<u32>,
    /// Filter the coarsest levels in one dispatch (`mip_coarse`).
    pub(super) fuse_coarse: bool,
    /// Octrees keep the facing of their radiance ([`SvoBuilder::with_facing`]).
    pub(super) facing: bool,
    /// The radiance mip's kernels that also filter the facing pool, compiled when first
    /// needed.
    facing_filter: std::cell::OnceCell<FacingFilter>,
    pub(super) light: crate::voxel::svo::inject::SvoLight,
    /// Stands in for the fragments and triangles the transfer and mip kernels do not read.
    pub(super) mip_placeholder: wgpu::Buffer,
}

/// The mip and transfer kernels compiled with the feature `facing` (`svo/build.wgsl`): group 0
/// of the build layout plus the facing pool's four buffers (bindings 12..15).
pub(super) struct FacingFilter {
    pub(super) layout0: wgpu::BindGroupLayout,
    pub(super) pipelines: Pipelines,
}

/// The entry points that filter a brick pool up the levels (`filter_steps`).
const FILTER_ENTRIES: [&str; 5] = [
    "mip",
    "mip_coarse",
    "transfer_x",
    "transfer_y",
    "transfer_z",
];

impl SvoBuilder {
    /// Compiles the build kernels.
    pub fn new(ctx: &GpuContext) -> SvoBuilder {
        let device = &ctx.device;
        let layout0 = layout0_with(device, "svo", 11);
        let layout1 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("svo args"),
            entries: &[storage_entry(0, false)],
        });
        let dyn_layout = crate::voxel::svo::dynamic::bind_group_layout(device);
        // The build and the dynamic update: `dynamic` imports `build`, so it holds both.
        let module = ctx.shader(
            "svo",
            &library_shader("voxel/svo/dynamic", &[("facing", false)]),
        );
        let accumulate = ctx.shader(
            "svo accumulate",
            &library_shader("voxel/svo/accumulate", &[]),
        );
        let plain = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("svo"),
            bind_group_layouts: &[Some(&layout0)],
            immediate_size: 0,
        });
        let with_args = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("svo finish level"),
            bind_group_layouts: &[Some(&layout0), Some(&layout1)],
            immediate_size: 0,
        });
        let dynamic = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("svo dynamic"),
            bind_group_layouts: &[Some(&layout0), None, Some(&dyn_layout)],
            immediate_size: 0,
        });
        let dynamic_args = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("svo dynamic finish"),
            bind_group_layouts: &[Some(&layout0), Some(&layout1), Some(&dyn_layout)],
            immediate_size: 0,
        });
        let mut pipelines = std::collections::HashMap::new();
        for entry in crate::voxel::svo::dynamic::ENTRY_POINTS
            .iter()
            .copied()
            .chain([
                "flag_occupied",
                "flag_needed",
                "subdivide",
                "mark_occupied",
                "assign_bricks",
                "finish_level",
                "leaf_fill",
                "transfer_x",
                "transfer_y",
                "transfer_z",
                "mip",
                "mip_coarse",
            ])
        {
            let groups = Groups {
                args: entry.contains("finish") || entry == "dyn_begin",
                dynamic: entry.starts_with("dyn_"),
            };
            let layout = match (groups.args, groups.dynamic) {
                (true, true) => &dynamic_args,
                (true, false) => &with_args,
                (false, true) => &dynamic,
                (false, false) => &plain,
            };
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
            pipelines.insert(entry, (pipeline, groups));
        }
        let leaf_accumulate = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("leaf_accumulate"),
            layout: Some(&plain),
            module: &accumulate,
            entry_point: Some("leaf_accumulate"),
            compilation_options: Default::default(),
            cache: None,
        });
        let no_groups = Groups {
            args: false,
            dynamic: false,
        };
        pipelines.insert("leaf_accumulate", (leaf_accumulate, no_groups));
        SvoBuilder {
            pack: PackBricks::new(ctx),
            pool_limit: None,
            fuse_coarse: true,
            facing: false,
            facing_filter: std::cell::OnceCell::new(),
            light: crate::voxel::svo::inject::SvoLight::new(ctx),
            mip_placeholder: ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some("mip placeholder"),
                    size: 64,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                },
            ),
            voxelizer: Voxelizer::new(ctx),
            layout0,
            layout1,
            pipelines,
        }
    }

    /// Caps the bricks per pool buffer below what the device can bind (tests use this to
    /// exercise pools split over several buffers).
    pub fn with_pool_limit(mut self, bricks: u32) -> SvoBuilder {
        self.pool_limit = Some(bricks.max(1));
        self
    }

    /// Filters levels `0..=2` of the bricks and the radiance in one dispatch (`fused`, the
    /// default) or each level in its own four dispatches, as the finer levels are: the bricks
    /// are the same either way (tests compare the two).
    pub fn with_fused_coarse_levels(mut self, fused: bool) -> SvoBuilder {
        self.fuse_coarse = fused;
        self
    }

    /// Octrees built by this builder also keep, per radiance texel, the direction the radiance
    /// leaves in (the radiance-weighted mean facing of its surfaces; a wall thinner than a
    /// voxel faces the light that lights it): the facing pool, filtered like the radiance,
    /// 216 bytes per brick (default false; [`crate::gi::vct::VctSettings::facing`]).
    pub fn with_facing(mut self, facing: bool) -> SvoBuilder {
        self.facing = facing;
        self
    }

    /// Group 1 of the octree kernels: the dispatch arguments, written by the `finish` kernels.
    pub(super) fn args_group(&self, ctx: &GpuContext, args: &wgpu::Buffer) -> wgpu::BindGroup {
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("svo args"),
            layout: &self.layout1,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: args.as_entire_binding(),
            }],
        })
    }

    /// Group 0 of the octree kernels: `params` (per-level slots) and the 11 storage buffers
    /// of `svo/build.wgsl` (fragments, triangles, child, neighbours, coordinates, brick index
    /// + 1 (the flags during the structure pass), control, the 4 brick pool buffers).
    pub(super) fn group0(
        &self,
        ctx: &GpuContext,
        params: &wgpu::Buffer,
        buffers: [&wgpu::Buffer; 11],
    ) -> wgpu::BindGroup {
        group0_with(ctx, &self.layout0, params, &buffers)
    }

    /// The facing kernels, compiled on first use.
    pub(super) fn facing_filter(&self, ctx: &GpuContext) -> &FacingFilter {
        self.facing_filter.get_or_init(|| {
            let device = &ctx.device;
            // The facing pool's four buffers after the build's eleven.
            let layout0 = layout0_with(device, "svo (facing)", 15);
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("svo (facing)"),
                bind_group_layouts: &[Some(&layout0)],
                immediate_size: 0,
            });
            let source = library_shader("voxel/svo/build", &[("facing", true)]);
            let module = ctx.shader("svo radiance mip (facing)", &source);
            let pipelines = FILTER_ENTRIES
                .iter()
                .map(|&entry| {
                    let pipeline =
                        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                            label: Some(entry),
                            layout: Some(&layout),
                            module: &module,
                            entry_point: Some(entry),
                            compilation_options: Default::default(),
                            cache: None,
                        });
                    let groups = Groups {
                        args: false,
                        dynamic: false,
                    };
                    (entry, (pipeline, groups))
                })
                .collect();
            FacingFilter { layout0, pipelines }
        })
    }
}
