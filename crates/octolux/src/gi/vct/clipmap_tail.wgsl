// The clipmap's tail: coarser copies of its coarsest level for cones wider than that level's
// voxel. Tail level k (1..=K) has res / 2^k voxels per side over the coarsest level's region
// (absolute indices from that level's origin, not toroidal); each voxel is the mean of the 8
// voxels of level k - 1 it covers (level 0: the coarsest clipmap level), premultiplied
// radiance and opacity alike, and its facing the mean of theirs weighted by their radiance's
// r + g + b (so that the facing sums add up as the radiance does). Stored as the clipmap's
// voxels are: 3 words, RGBA16F radiance and opacity, snorm8 x 3 facing. CPU twin:
// `clipmap_tail::tail_cpu`.

import octolux::voxel::clipmap::sample::{clip_info, clip_slot};
import octolux::voxel::clipmap::radiance_sample::{ClipRadianceFacing, clip_radiance_facing_voxel, clip_radiance_facing_words};

// `TailParams` in clipmap_tail.rs: one tail level.
struct TailParams {
    // k
    level: u32,
    // Voxels per side (res >> k).
    side: u32,
    // First slot of level k, and of level k - 1 which it averages.
    first: u32,
    source_first: u32,
}

@group(0) @binding(0) var<storage, read> tail_params: TailParams;
@group(0) @binding(1) var<storage, read_write> tail: array<u32>;

fn tail_source(j: vec3<u32>) -> ClipRadianceFacing {
    if tail_params.level == 1u {
        let l = clip_info.levels - 1u;
        return clip_radiance_facing_voxel(l, clip_info.origins[l].xyz + vec3<i32>(j));
    }
    let n = 2u * tail_params.side;
    let slot = tail_params.source_first + j.x + n * (j.y + n * j.z);
    return clip_radiance_facing_words(vec3<u32>(tail[3u * slot], tail[3u * slot + 1u], tail[3u * slot + 2u]));
}

@compute @workgroup_size(4, 4, 4)
fn build_tail(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = tail_params.side;
    if any(id >= vec3<u32>(n)) {
        return;
    }
    var sum = ClipRadianceFacing(vec4<f32>(0.0), vec3<f32>(0.0));
    for (var c = 0u; c < 8u; c++) {
        let o = vec3<u32>(c & 1u, (c >> 1u) & 1u, (c >> 2u) & 1u);
        let v = tail_source(2u * id + o);
        sum.radiance += v.radiance;
        sum.facing += v.facing;
    }
    let mean = sum.radiance * 0.125;
    let facing = sum.facing / max(sum.radiance.r + sum.radiance.g + sum.radiance.b, 1e-20);
    let slot = tail_params.first + id.x + n * (id.y + n * id.z);
    tail[3u * slot] = pack2x16float(mean.xy);
    tail[3u * slot + 1u] = pack2x16float(mean.zw);
    tail[3u * slot + 2u] = pack4x8snorm(vec4<f32>(facing, 0.0));
}
