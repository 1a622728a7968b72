// Test kernel: traces segments given as lattice points and writes, per segment, 0 when nothing
// blocks it, else 1 + the first blocking voxel packed as x + 1024 (y + 1024 z). Composed with
// `count_work`, it counts the walks' cells and nodes (quantities 0 and 1).

import octolux::voxel::svo::walk::{count_walk_work, svo_first_hit};

@group(0) @binding(3) var<storage, read> segments: array<vec4<i32>>;
@group(0) @binding(4) var<storage, read_write> results: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&segments) / 2u {
        return;
    }
    let h = svo_first_hit(segments[2u * i].xyz, segments[2u * i + 1u].xyz);
    let v = vec3<u32>(h.xyz);
    results[i] = select(0u, 1u + v.x + 1024u * (v.y + 1024u * v.z), h.w != 0);
    count_walk_work(0u, 1u);
}
