//! How the octree's kernels are recorded: a pass is a list of steps (entry point, parameter
//! slot, [`Dispatch`]) recorded as one timed pass, or one timed pass per step when the timer
//! profiles steps; [`filter_steps`] lists the neighbour transfers and mips that filter a brick
//! pool up the levels (the build's bricks and the injected radiance alike).

use crate::gpu::pass::dispatch_size;
use crate::gpu::pass::SLOT;
use crate::gpu::PassTimer;
use crate::voxel::svo::bindings::Pipelines;
use crate::voxel::svo::control::{args_offset, ARGS_DYN_NODES, NODE_ARGS};
use crate::voxel::svo::SvoBuilder;

/// How many invocations a step runs.
pub(super) enum Dispatch {
    /// One invocation per fragment.
    Fragments,
    /// `n` invocations.
    Capacity(u32),
    /// Indirect, from this slot of the dispatch arguments: one invocation per entry.
    Indirect(u32),
    /// Indirect, one workgroup per entry of this slot (kernels that spread a node over a
    /// workgroup).
    PerNode(u32),
    /// One workgroup.
    One,
}

/// Levels `0..=COARSE_LEVEL` (at most 8^2 = 64 nodes on the last) are filtered by one
/// dispatch of one workgroup, `mip_coarse` in `svo/build.wgsl`, instead of four dispatches
/// each.
const COARSE_LEVEL: u32 = 2;

/// The neighbour transfers and mips after the leaves are filled, from the leaf level up: each
/// level's static nodes, then (with `dynamic`) its dynamic ones (parameter slot depth + d;
/// their ranges are read on the GPU, empty before the first update). The coarsest levels in
/// one step unless `fuse` is false.
pub(super) fn filter_steps(
    depth: u32,
    dynamic: bool,
    fuse: bool,
) -> Vec<(&'static str, u32, Dispatch)> {
    let ranges = |d: u32| {
        [(d, d)]
            .into_iter()
            .chain(dynamic.then_some((depth + d, ARGS_DYN_NODES + d)))
    };
    let leaf = depth.saturating_sub(1);
    // The leaf level has no mip, so it is never fused.
    let coarse = (fuse && depth >= 2).then(|| COARSE_LEVEL.min(depth - 2));
    let mut steps = Vec::new();
    for d in (0..depth).rev() {
        if Some(d) == coarse {
            steps.push(("mip_coarse", d, Dispatch::One));
            break;
        }
        if d != leaf {
            steps.extend(ranges(d).map(|(slot, args)| ("mip", slot, Dispatch::PerNode(args))));
        }
        for t in ["transfer_x", "transfer_y", "transfer_z"] {
            steps.extend(ranges(d).map(|(slot, args)| (t, slot, Dispatch::Indirect(args))));
        }
    }
    steps
}

impl SvoBuilder {
    /// Records `steps` (entry point, parameter slot, dispatch) as one timed pass; kernels that
    /// write dispatch arguments get `args_group` (group 1, over `args`), those of the dynamic
    /// part `dynamic` (group 2).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn record(
        &self,
        timer: &mut PassTimer,
        name: &str,
        group: &wgpu::BindGroup,
        groups: (&wgpu::BindGroup, Option<&wgpu::BindGroup>),
        args: &wgpu::Buffer,
        fragments: u32,
        steps: &[(&'static str, u32, Dispatch)],
    ) {
        let pipelines = &self.pipelines;
        record_steps(
            pipelines, timer, name, group, groups, args, fragments, steps,
        );
    }
}

/// [`SvoBuilder::record`] with the kernels of `pipelines`.
#[allow(clippy::too_many_arguments)]
pub(super) fn record_steps(
    pipelines: &Pipelines,
    timer: &mut PassTimer,
    name: &str,
    group: &wgpu::BindGroup,
    (args_group, dynamic): (&wgpu::BindGroup, Option<&wgpu::BindGroup>),
    args: &wgpu::Buffer,
    fragments: u32,
    steps: &[(&'static str, u32, Dispatch)],
) {
    let record_step = |encoder: &mut wgpu::CommandEncoder,
                       timestamps: Option<wgpu::ComputePassTimestampWrites>,
                       (entry, d, dispatch): &(&'static str, u32, Dispatch)| {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(entry),
            timestamp_writes: timestamps,
        });
        let (pipeline, groups) = &pipelines[entry];
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[*d * SLOT as u32]);
        if groups.args {
            pass.set_bind_group(1, args_group, &[]);
        }
        if let (true, Some(dynamic)) = (groups.dynamic, dynamic) {
            pass.set_bind_group(2, dynamic, &[]);
        }
        match dispatch {
            Dispatch::Fragments => {
                let (x, y) = dispatch_size(fragments);
                pass.dispatch_workgroups(x, y, 1);
            }
            Dispatch::Capacity(n) => {
                let (x, y) = dispatch_size(*n);
                pass.dispatch_workgroups(x, y, 1);
            }
            Dispatch::Indirect(slot) => {
                pass.dispatch_workgroups_indirect(args, args_offset(*slot));
            }
            Dispatch::PerNode(slot) => {
                pass.dispatch_workgroups_indirect(args, args_offset(*slot + NODE_ARGS));
            }
            Dispatch::One => {
                pass.dispatch_workgroups(1, 1, 1);
            }
        }
    };
    if timer.profile_steps() {
        for step in steps {
            let label = format!("{name}: {} {}", step.0, step.1);
            timer.pass(&label, |encoder, stamps| {
                record_step(encoder, stamps.compute(), step)
            });
        }
        return;
    }
    timer.pass(name, |encoder, stamps| {
        let last = steps.len().saturating_sub(1);
        for (i, step) in steps.iter().enumerate() {
            record_step(encoder, stamps.compute_part(i == 0, i == last), step);
        }
    });
}
