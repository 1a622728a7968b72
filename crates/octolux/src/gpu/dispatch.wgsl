// Indirect dispatch arguments written on the GPU, for every kernel that sizes a later pass.

// Workgroups along x, y and z: wgpu's `DispatchIndirectArgs` (`gpu::pass::indirect_offset`
// gives the byte offset of an array's element).
struct DispatchArgs {
    x: u32,
    y: u32,
    z: u32,
};

// `groups` workgroups in rows of at most 65535 (as `gpu::pass::dispatch_size` on the CPU;
// the kernels' `linear_index` undoes the rows). Zero groups dispatch nothing.
fn dispatch_covering(groups: u32) -> DispatchArgs {
    return DispatchArgs(min(groups, 65535u), (groups + 65534u) / 65535u, 1u);
}
