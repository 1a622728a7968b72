// Clipmap voxelization of one box of one level: accumulate integer albedo, normal and emission
// sums and fragment counts per voxel of the box (work items of at most CHUNK voxels), then
// resolve each voxel of the box into its toroidal slot: RGBA8 (albedo averaged with rounding,
// opacity 255 when any triangle touches the voxel, all zero otherwise), the normalised normal
// sum, and the mean emission (fixed-point sums divided with rounding, RGB9E5, see
// `clipmap/emission.wgsl`).

import octolux::voxel::voxelize::overlap::{cell_count, CHUNK, linear_index, nth_offset, Piece, piece_cells, piece_test, piece_touches, Tri};
import octolux::voxel::clipmap::emission::{emission_encode, emission_fixed};

// Scratch words per voxel (ACCUM_WORDS in clipmap/revoxelise.rs): albedo r, g, b sums, fragment count,
// normal x, y, z sums, emission r, g, b sums as 64 bits (low words, then high words).

const ACCUM_WORDS: u32 = 13u;

// One z slice of an update box (`BoxParams` in clipmap/revoxelise.rs).
struct BoxParams {
    // The slice [lo, hi) in world-voxel coordinates of its level.
    lo: vec3<i32>,
    // Work items of the slice.
    items: u32,
    hi: vec3<i32>,
    // First voxel slot of the level in `voxels`.
    level_first: u32,
    // Voxels per axis of a level.
    resolution: u32,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> P: BoxParams;
@group(0) @binding(1) var<storage, read> tris: array<Tri>;
@group(0) @binding(2) var<storage, read> items: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read_write> accum: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> voxels: array<u32>;
@group(0) @binding(5) var<storage, read_write> written: atomic<u32>;
// Per voxel: averaged unit normal, snorm8 x3 (same slots as `voxels`).
@group(0) @binding(6) var<storage, read_write> normals: array<u32>;
// Per voxel: mean emission, RGB9E5 (same slots as `voxels`).
@group(0) @binding(7) var<storage, read_write> emission: array<u32>;
// The triangles snapped to the box's lattice (`Piece`, see voxelize/overlap.wgsl); items[w].x indexes it.
@group(0) @binding(8) var<storage, read> pieces: array<Piece>;

// Adds `v` to the 64-bit sum in words (lo, hi). The high word counts the wraps of the low
// one, so the total does not depend on the order of the additions (a voxel of a coarse level
// may hold thousands of fragments of up to 65504 x 1024 each).
fn add64(lo: u32, hi: u32, v: u32) {
    let old = atomicAdd(&accum[lo], v);
    if old > 0xffffffffu - v {
        atomicAdd(&accum[hi], 1u);
    }
}

// round((hi * 2^32 + lo) / d) for d > 0 and a quotient below 2^32 (restoring division).
fn div64_rounded(hi_in: u32, lo_in: u32, d: u32) -> u32 {
    let half = d / 2u;
    let lo = lo_in + half;
    var rem = hi_in + select(0u, 1u, lo < lo_in);
    var q = 0u;
    for (var i = 0u; i < 32u; i++) {
        let top = rem >> 31u;
        rem = (rem << 1u) | ((lo >> (31u - i)) & 1u);
        q = q << 1u;
        // With the top bit shifted out the true remainder is rem + 2^32 > d; the wrapping
        // subtraction still gives the right (smaller than d) result.
        if top == 1u || rem >= d {
            rem -= d;
            q |= 1u;
        }
    }
    return q;
}

// Sign-extended byte `i` of a packed snorm8 word, in units of 1/127.
fn snorm_byte(w: u32, i: u32) -> i32 {
    return (bitcast<i32>(w << (24u - 8u * i))) >> 24u;
}

fn box_size() -> vec3<u32> {
    return vec3<u32>(P.hi - P.lo);
}

@compute @workgroup_size(64)
fn accumulate(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) li: u32) {
    let w = linear_index(wg, nwg, li);
    if w >= P.items {
        return;
    }
    let piece = pieces[items[w].x];
    let tri = tris[piece.triangle];
    let size = box_size();
    let range = piece_cells(piece, vec3<i32>(size));
    let test = piece_test(piece, range[0]);
    let cells = min(cell_count(range), (items[w].y + 1u) * CHUNK);
    let albedo = tri.albedo;
    for (var i = items[w].y * CHUNK; i < cells; i++) {
        let off = nth_offset(range, i);
        if piece_touches(test, off) {
            let l = vec3<u32>(range[0] + off);
            let k = ACCUM_WORDS * (l.x + size.x * (l.y + size.y * l.z));
            atomicAdd(&accum[k], albedo & 255u);
            atomicAdd(&accum[k + 1u], (albedo >> 8u) & 255u);
            atomicAdd(&accum[k + 2u], (albedo >> 16u) & 255u);
            atomicAdd(&accum[k + 3u], 1u);
            // Signed normal sums: two's-complement addition wraps the same way as unsigned.
            let nb = tri.normal;
            atomicAdd(&accum[k + 4u], bitcast<u32>(snorm_byte(nb, 0u)));
            atomicAdd(&accum[k + 5u], bitcast<u32>(snorm_byte(nb, 1u)));
            atomicAdd(&accum[k + 6u], bitcast<u32>(snorm_byte(nb, 2u)));
            add64(k + 7u, k + 10u, emission_fixed(tri.emission.r));
            add64(k + 8u, k + 11u, emission_fixed(tri.emission.g));
            add64(k + 9u, k + 12u, emission_fixed(tri.emission.b));
        }
    }
}

@compute @workgroup_size(64)
fn resolve(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
           @builtin(local_invocation_index) li: u32) {
    let i = linear_index(wg, nwg, li);
    let size = box_size();
    if i < size.x * size.y * size.z {
        resolve_voxel(i, size);
        atomicAdd(&workgroup_written, 1u);
    }
    // One add to the global counter per workgroup: every voxel adding to one word would make
    // the GPU's lanes wait on each other for a statistic.
    workgroupBarrier();
    if li == 0u {
        atomicAdd(&written, atomicLoad(&workgroup_written));
    }
}

var<workgroup> workgroup_written: atomic<u32>;

// Voxel `i` of the box of `size` from its accumulated sums, which it clears.
fn resolve_voxel(i: u32, size: vec3<u32>) {
    let l = vec3<u32>(i % size.x, (i / size.x) % size.y, i / (size.x * size.y));
    let k = ACCUM_WORDS * i;
    let count = atomicExchange(&accum[k + 3u], 0u);
    let r = atomicExchange(&accum[k], 0u);
    let g = atomicExchange(&accum[k + 1u], 0u);
    let b = atomicExchange(&accum[k + 2u], 0u);
    let n = vec3<f32>(vec3<i32>(bitcast<i32>(atomicExchange(&accum[k + 4u], 0u)),
                                bitcast<i32>(atomicExchange(&accum[k + 5u], 0u)),
                                bitcast<i32>(atomicExchange(&accum[k + 6u], 0u))));
    var e_lo: array<u32, 3>;
    var e_hi: array<u32, 3>;
    for (var c = 0u; c < 3u; c++) {
        e_lo[c] = atomicExchange(&accum[k + 7u + c], 0u);
        e_hi[c] = atomicExchange(&accum[k + 10u + c], 0u);
    }
    var value = 0u;
    var emitted = 0u;
    if count > 0u {
        emitted = emission_encode(vec3<u32>(div64_rounded(e_hi[0], e_lo[0], count),
                                            div64_rounded(e_hi[1], e_lo[1], count),
                                            div64_rounded(e_hi[2], e_lo[2], count)));
        let half = count / 2u;
        value = ((r + half) / count) | (((g + half) / count) << 8u) | (((b + half) / count) << 16u)
            | (255u << 24u);
    }
    let res = i32(P.resolution);
    let cell = P.lo + vec3<i32>(l);
    let m = vec3<u32>(((cell % res) + res) % res);
    let slot = P.level_first + m.x + P.resolution * (m.y + P.resolution * m.z);
    voxels[slot] = value;
    var packed_normal = 0u;
    if dot(n, n) > 0.0 {
        packed_normal = pack4x8snorm(vec4<f32>(normalize(n), 0.0));
    }
    normals[slot] = packed_normal;
    emission[slot] = emitted;
}
