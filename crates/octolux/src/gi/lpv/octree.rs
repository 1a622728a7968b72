//! Octree LPV passes (000 §3): downsample (eq. 2), occupancy and index volume levels, merge
//! (eq. 1). The levels live one after another in the shared light buffers; the geometry
//! volume of each level is injected directly (its level-0 part drives the occupancy).

use super::propagate::Volumes;
use super::{bind, groups, slot, storage, CELL_BYTES};
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};
use bytemuck::{Pod, Zeroable};

/// `OctreeParams` of `octree.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    n: u32,
    levels: u32,
    level: u32,
    _pad: u32,
    /// First cell of each level.
    offsets: [u32; 8],
}

/// Bytes of `Params`.
const PARAMS_BYTES: u64 = std::mem::size_of::<Params>() as u64;

/// GPU memory of the octree beyond the shared light buffers.
pub struct OctreeBuffers {
    /// Side of level 0.
    pub n: u32,
    /// Number of levels l.
    pub levels: u32,
    /// Occupancy per level (u32 per cell, same offsets as the light cells).
    pub occ: wgpu::Buffer,
    /// Index volume levels I_i (u32 per cell).
    pub index: wgpu::Buffer,
    /// The merged n^3 volume.
    pub merged: wgpu::Buffer,
    params: wgpu::Buffer,
}

impl OctreeBuffers {
    /// Allocates the buffers for an octree of side `n` whose levels hold `cells` cells.
    pub fn new(ctx: &GpuContext, owner: &str, n: u32, cells: u32) -> OctreeBuffers {
        let levels = n.trailing_zeros() + 1;
        let params = super::param_slots(ctx, owner, "octree params", levels as u64);
        let data: Vec<u8> = (0..levels)
            .flat_map(|level| {
                let mut slot = vec![0u8; super::SLOT as usize];
                let mut offsets = [0u32; 8];
                for i in 1..levels.min(8) as usize {
                    let m = n >> (i - 1);
                    offsets[i] = offsets[i - 1] + m * m * m;
                }
                let params = Params {
                    n,
                    levels,
                    level,
                    _pad: 0,
                    offsets,
                };
                slot[..std::mem::size_of::<Params>()].copy_from_slice(bytemuck::bytes_of(&params));
                slot
            })
            .collect();
        ctx.queue.write_buffer(&params, 0, &data);
        OctreeBuffers {
            n,
            levels,
            occ: storage(ctx, owner, "occupancy", cells as u64 * 4),
            index: storage(ctx, owner, "index volume", cells as u64 * 4),
            merged: storage(ctx, owner, "merged", (n * n * n) as u64 * CELL_BYTES),
            params,
        }
    }
}

/// WGSL source of the octree passes.
pub fn source() -> String {
    library_shader("gi/lpv/octree", &[])
}

/// The octree LPV's pipelines and per-level bind groups.
pub struct LpvOctree {
    n: u32,
    levels: u32,
    downsample: wgpu::ComputePipeline,
    occupancy: wgpu::ComputePipeline,
    index: wgpu::ComputePipeline,
    merge: wgpu::ComputePipeline,
    downsample_groups: Vec<wgpu::BindGroup>,
    occupancy_groups: Vec<wgpu::BindGroup>,
    index_groups: Vec<wgpu::BindGroup>,
    merge_group: wgpu::BindGroup,
}

impl LpvOctree {
    /// Builds the pipelines over `b` and the shared volumes.
    pub fn new(ctx: &GpuContext, b: &OctreeBuffers, v: &Volumes) -> LpvOctree {
        let module = ctx.shader("olpv", &source());
        let downsample = ctx.compute_pipeline("olpv downsample", &module, "downsample");
        let occupancy = ctx.compute_pipeline("olpv occupancy", &module, "occupancy");
        let index = ctx.compute_pipeline("olpv index", &module, "index_level");
        let merge = ctx.compute_pipeline("olpv merge", &module, "merge");
        let per_level = |pipeline: &wgpu::ComputePipeline, extra: &[(u32, &wgpu::Buffer)]| {
            (0..b.levels as u64)
                .map(|l| {
                    let mut entries = vec![(0, slot(&b.params, l, PARAMS_BYTES))];
                    entries.extend(extra.iter().map(|(i, buf)| (*i, buf.as_entire_binding())));
                    bind(ctx, pipeline, &entries)
                })
                .collect::<Vec<_>>()
        };
        let downsample_groups = per_level(&downsample, &[(1, &v.a)]);
        let occupancy_groups = per_level(&occupancy, &[(2, &v.gv), (3, &b.occ)]);
        let index_groups = per_level(&index, &[(3, &b.occ), (4, &b.index)]);
        let merge_group = bind(
            ctx,
            &merge,
            &[
                (0, slot(&b.params, 0, PARAMS_BYTES)),
                (4, b.index.as_entire_binding()),
                (5, v.acc.as_entire_binding()),
                (6, b.merged.as_entire_binding()),
            ],
        );
        LpvOctree {
            n: b.n,
            levels: b.levels,
            downsample,
            occupancy,
            index,
            merge,
            downsample_groups,
            occupancy_groups,
            index_groups,
            merge_group,
        }
    }

    fn dispatch_levels(
        &self,
        timer: &mut PassTimer,
        name: &str,
        steps: &[(&wgpu::ComputePipeline, &[wgpu::BindGroup], u32)],
    ) {
        timer.pass(name, |encoder, stamps| {
            let total: usize = steps
                .iter()
                .map(|(_, _, first)| (self.levels - first) as usize)
                .sum();
            let mut k = 0;
            for (pipeline, bind_groups, first) in steps {
                for level in *first..self.levels {
                    // One compute pass per level: each level reads the one before it.
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(name),
                        timestamp_writes: stamps.compute_part(k == 0, k + 1 == total),
                    });
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, &bind_groups[level as usize], &[]);
                    let d = groups(self.n >> level, 4);
                    pass.dispatch_workgroups(d, d, d);
                    k += 1;
                }
            }
        });
    }

    /// Eq. 2 on levels 1..l-1 of the injected light (buffer A).
    pub fn record_downsample(&self, timer: &mut PassTimer, _v: &Volumes) {
        if self.levels > 1 {
            self.dispatch_levels(
                timer,
                "olpv downsample",
                &[(&self.downsample, &self.downsample_groups, 1)],
            );
        }
    }

    /// Occupancy pyramid and index volume levels.
    pub fn record_index(&self, timer: &mut PassTimer) {
        self.dispatch_levels(
            timer,
            "olpv index",
            &[
                (&self.occupancy, &self.occupancy_groups, 0),
                (&self.index, &self.index_groups, 0),
            ],
        );
    }

    /// Merge into one n^3 volume.
    pub fn record_merge(&self, timer: &mut PassTimer) {
        timer.pass("olpv merge", |encoder, stamps| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("olpv merge"),
                timestamp_writes: stamps.compute(),
            });
            pass.set_pipeline(&self.merge);
            pass.set_bind_group(0, &self.merge_group, &[]);
            let d = groups(self.n, 4);
            pass.dispatch_workgroups(d, d, d);
        });
    }
}
