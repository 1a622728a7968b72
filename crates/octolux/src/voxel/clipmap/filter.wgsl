// Clipmap level filtering: the voxels of level l = F.level that lie wholly inside level l - 1
// are rebuilt from the 2x2x2 finer voxels instead of being voxelized on their own:
// premultiplied colour and opacity are the rounded means of the eight (opacity becomes the
// covered fraction), normals the normalised sum, emission the rounded integer mean of the
// eight fixed-point values (empty voxels count as zero, so emission is premultiplied by
// coverage like the colour, `clipmap/emission.wgsl`). With anisotropic voxels (F.anisotropic = 1), each of
// the 6 directional values (travel +x, -x, +y, -y, +z, -z) composites the two finer voxels met
// one after the other along that direction, front to back, and averages the 4 pairs across
// the other two axes; the finer values are the finer level's directional values, or its
// isotropic ones on level 0. `replicate` copies the isotropic value of the voxels of a box
// into all 6 directions (voxels voxelized on their own have no direction).

import octolux::voxel::voxelize::overlap::linear_index;
import octolux::voxel::clipmap::emission::{emission_decode_fixed, emission_encode};
import octolux::voxel::pairs::pair_along;

// One box of one level (`FilterParams` in clipmap/filter.rs).
struct FilterParams {
    // The box [lo, hi) in world-voxel coordinates of `level`.
    lo: vec3<i32>,
    level: u32,
    hi: vec3<i32>,
    // Voxels per axis of a level.
    resolution: u32,
    // 1 where the clipmap keeps directional values.
    anisotropic: u32,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> F: FilterParams;
@group(0) @binding(1) var<storage, read_write> voxels: array<u32>;
@group(0) @binding(2) var<storage, read_write> normals: array<u32>;
@group(0) @binding(3) var<storage, read_write> aniso: array<u32>;
@group(0) @binding(4) var<storage, read_write> emission: array<u32>;

fn level_slots() -> u32 {
    return F.resolution * F.resolution * F.resolution;
}

fn slot_in_level(g: vec3<i32>) -> u32 {
    let res = i32(F.resolution);
    let m = vec3<u32>(((g % res) + res) % res);
    return m.x + F.resolution * (m.y + F.resolution * m.z);
}

fn unpack_u8(w: u32) -> vec4<u32> {
    return vec4<u32>(w & 255u, (w >> 8u) & 255u, (w >> 16u) & 255u, w >> 24u);
}

fn pack_u8(v: vec4<u32>) -> u32 {
    return v.x | (v.y << 8u) | (v.z << 16u) | (v.w << 24u);
}

fn snorm_part(w: u32, i: u32) -> i32 {
    return (bitcast<i32>(w << (24u - 8u * i))) >> 24u;
}

// The cell of the box for invocation i, or false when i is past the box.
fn box_cell(i: u32, cell: ptr<function, vec3<i32>>) -> bool {
    let size = vec3<u32>(F.hi - F.lo);
    if any(F.hi <= F.lo) || i >= size.x * size.y * size.z {
        return false;
    }
    *cell = F.lo + vec3<i32>(vec3<u32>(i % size.x, (i / size.x) % size.y,
                                           i / (size.x * size.y)));
    return true;
}

// Directional value d of finer level fl at slot s (its isotropic value on level 0).
fn fine_dir(fl: u32, s: u32, d: u32) -> vec4<u32> {
    if fl == 0u {
        return unpack_u8(voxels[s]);
    }
    return unpack_u8(aniso[((fl - 1u) * level_slots() + s) * 6u + d]);
}

// Front-to-back compositing of premultiplied RGBA8 values, rounded.
fn over(front: vec4<u32>, back: vec4<u32>) -> vec4<u32> {
    return front + ((255u - front.w) * back + vec4<u32>(127u)) / 255u;
}

@compute @workgroup_size(64)
fn filter_level(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                @builtin(local_invocation_index) li: u32) {
    var c: vec3<i32>;
    if !box_cell(linear_index(wg, nwg, li), &c) {
        return;
    }
    let l = F.level;
    let fl = l - 1u;
    let n = level_slots();
    var fine: array<u32, 8>;
    var sum = vec4<u32>(0u);
    var nsum = vec3<i32>(0);
    // At most 8 x (511 << 17) per channel: no overflow.
    var esum = vec3<u32>(0u);
    for (var k = 0u; k < 8u; k++) {
        let o = vec3<i32>(vec3<u32>(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u));
        let s = slot_in_level(2 * c + o);
        fine[k] = s;
        sum += unpack_u8(voxels[fl * n + s]);
        let nw = normals[fl * n + s];
        nsum += vec3<i32>(snorm_part(nw, 0u), snorm_part(nw, 1u), snorm_part(nw, 2u));
        esum += emission_decode_fixed(emission[fl * n + s]);
    }
    let cs = slot_in_level(c);
    voxels[l * n + cs] = pack_u8((sum + vec4<u32>(4u)) / 8u);
    var packed_normal = 0u;
    if any(nsum != vec3<i32>(0)) {
        packed_normal = pack4x8snorm(vec4<f32>(normalize(vec3<f32>(nsum)), 0.0));
    }
    normals[l * n + cs] = packed_normal;
    emission[l * n + cs] = emission_encode((esum + vec3<u32>(4u)) / 8u);
    if F.anisotropic == 0u {
        return;
    }
    for (var d = 0u; d < 6u; d++) {
        var acc = vec4<u32>(0u);
        for (var j = 0u; j < 4u; j++) {
            let pair = pair_along(d, j);
            acc += over(fine_dir(fl, fine[pair.x], d), fine_dir(fl, fine[pair.y], d));
        }
        aniso[((l - 1u) * n + cs) * 6u + d] = pack_u8((acc + vec4<u32>(2u)) / 4u);
    }
}

@compute @workgroup_size(64)
fn replicate(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
             @builtin(local_invocation_index) li: u32) {
    var c: vec3<i32>;
    if !box_cell(linear_index(wg, nwg, li), &c) {
        return;
    }
    let l = F.level;
    let n = level_slots();
    let s = slot_in_level(c);
    let v = voxels[l * n + s];
    for (var d = 0u; d < 6u; d++) {
        aniso[((l - 1u) * n + s) * 6u + d] = v;
    }
}
