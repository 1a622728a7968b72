// Filtered sampling of the clipmap: `clip_sample(p, footprint)` returns the premultiplied
// albedo and opacity at world position `p` from the finest level whose voxels are at least
// `footprint` and which contains `p` with its whole trilinear neighbourhood (a level that does
// not contain the point is never read), blended with the next level by the fractional level.
// Its bindings (group 0 from 64, bound by `voxel::clipmap::sample::clip_bindings`): the
// parameter block (storage, not uniform: "Parameter blocks" in voxel/mod.rs) and the
// voxels; the radiance and anisotropic samplers add theirs after them.

// `ClipInfo` in voxel/clipmap/sample.rs.
struct ClipInfo {
    // Voxel edge of the finest level.
    voxel_size: f32,
    // Voxels per axis of every level.
    resolution: u32,
    levels: u32,
    // First voxel of each level (world-voxel coordinates of that level).
    origins: array<vec4<i32>, 8>,
}

@group(0) @binding(64) var<storage, read> clip_info: ClipInfo;
@group(0) @binding(65) var<storage, read> clip_voxels: array<u32>;

// Index of the voxel at world-voxel coordinates `g` of level `l` (toroidal addressing).
fn clip_slot(l: u32, g: vec3<i32>) -> u32 {
    let res = i32(clip_info.resolution);
    let m = vec3<u32>(((g % res) + res) % res);
    let r = clip_info.resolution;
    return l * r * r * r + m.x + r * (m.y + r * m.z);
}

// The inverse of `clip_slot`: the centre (xyz, world) and edge (w) of the voxel that slot `i`
// of the whole array holds now, from its level's origin.
fn clip_slot_centre(i: u32) -> vec4<f32> {
    let r = clip_info.resolution;
    let l = i / (r * r * r);
    let s = i % (r * r * r);
    let m = vec3<i32>(vec3<u32>(s % r, (s / r) % r, s / (r * r)));
    let o = clip_info.origins[l].xyz;
    let ri = i32(r);
    let g = o + ((m - o) % ri + ri) % ri;
    let size = clip_info.voxel_size * f32(1u << l);
    return vec4<f32>((vec3<f32>(g) + 0.5) * size, size);
}

fn clip_voxel(l: u32, g: vec3<i32>) -> vec4<f32> {
    return unpack4x8unorm(clip_voxels[clip_slot(l, g)]);
}

// Whether level l holds p's trilinear neighbourhood.
fn clip_contains(p: vec3<f32>, l: u32) -> bool {
    let g = p / (clip_info.voxel_size * f32(1u << l)) - 0.5;
    let lo = vec3<f32>(clip_info.origins[l].xyz);
    return all(g >= lo) && all(g < lo + vec3<f32>(f32(clip_info.resolution) - 1.0));
}

// Trilinear cell of level l around p: lower corner and weights.
struct ClipCell {
    i0: vec3<i32>,
    f: vec3<f32>,
}

fn clip_cell(p: vec3<f32>, l: u32) -> ClipCell {
    let g = p / (clip_info.voxel_size * f32(1u << l)) - 0.5;
    return ClipCell(vec3<i32>(floor(g)), g - floor(g));
}

fn clip_corner(k: u32) -> vec3<i32> {
    return vec3<i32>(i32(k & 1u), i32((k >> 1u) & 1u), i32((k >> 2u) & 1u));
}

fn clip_weight(cell: ClipCell, o: vec3<i32>) -> f32 {
    let w = select(1.0 - cell.f, cell.f, o == vec3<i32>(1));
    return w.x * w.y * w.z;
}

// Level choice for a footprint: the finest level at least as coarse as the footprint that
// contains p (`level` = levels when none does), and the blend `t` towards the next level, 0
// when that level cannot be read.
struct ClipLod {
    level: u32,
    t: f32,
}

fn clip_lod(p: vec3<f32>, footprint: f32) -> ClipLod {
    let levels = clip_info.levels;
    let lod = clamp(log2(max(footprint / clip_info.voxel_size, 1.0)), 0.0, f32(levels - 1u));
    var l = u32(floor(lod));
    while l < levels && !clip_contains(p, l) {
        l++;
    }
    var t = lod - floor(lod);
    if l >= levels || f32(l) > floor(lod) || l + 1u >= levels || !clip_contains(p, l + 1u) {
        t = 0.0;
    }
    return ClipLod(l, t);
}

fn clip_sample_level(p: vec3<f32>, l: u32) -> vec4<f32> {
    let cell = clip_cell(p, l);
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let o = clip_corner(k);
        sum += clip_weight(cell, o) * clip_voxel(l, cell.i0 + o);
    }
    return sum;
}

fn clip_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let lod = clip_lod(p, footprint);
    if lod.level >= clip_info.levels {
        return vec4<f32>(0.0);
    }
    let a = clip_sample_level(p, lod.level);
    if lod.t <= 0.0 {
        return a;
    }
    return mix(a, clip_sample_level(p, lod.level + 1u), lod.t);
}
