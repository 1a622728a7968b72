// Voxel fragment list: a count pass (voxels touched per work item), an exclusive scan of the
// counts (on the CPU, which also sizes the list), then an emit pass writing each work item's
// fragments at its offset in a fixed loop order: the list is identical from run to run.
// A fragment is (packed voxel coordinate relative to lo, triangle index); albedo, normal and
// emission are read from the triangle.

import octolux::voxel::voxelize::overlap::{cell_count, CHUNK, linear_index, nth_offset, Piece, piece_cells, piece_test, piece_touches, VoxParams};

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> P: VoxParams;
@group(0) @binding(1) var<storage, read> pieces: array<Piece>;
@group(0) @binding(2) var<storage, read_write> counts: array<u32>;
@group(0) @binding(3) var<storage, read_write> fragments: array<vec2<u32>>;
// Work items: (piece, chunk of CHUNK bounding-box voxels), so that no invocation loops more
// than CHUNK times (lavapipe stops any invocation after 65535 loop iterations in total).
@group(0) @binding(4) var<storage, read> items: array<vec2<u32>>;

fn pack_cell(c: vec3<i32>) -> u32 {
    let u = vec3<u32>(c);
    return (u.x & 1023u) | ((u.y & 1023u) << 10u) | ((u.z & 1023u) << 20u);
}

@compute @workgroup_size(64)
fn count_fragments(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                   @builtin(local_invocation_index) li: u32) {
    let w = linear_index(wg, nwg, li);
    if w >= P.items {
        return;
    }
    let piece = pieces[items[w].x];
    let range = piece_cells(piece, P.hi - P.lo);
    let test = piece_test(piece, range[0]);
    var n = 0u;
    let cells = min(cell_count(range), (items[w].y + 1u) * CHUNK);
    for (var i = items[w].y * CHUNK; i < cells; i++) {
        if piece_touches(test, nth_offset(range, i)) {
            n += 1u;
        }
    }
    counts[w] = n;
}

@compute @workgroup_size(64)
fn emit_fragments(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                  @builtin(local_invocation_index) li: u32) {
    let w = linear_index(wg, nwg, li);
    if w >= P.items {
        return;
    }
    let piece = pieces[items[w].x];
    let t = piece.triangle;
    let range = piece_cells(piece, P.hi - P.lo);
    let test = piece_test(piece, range[0]);
    var at = counts[w];
    let total = arrayLength(&fragments);
    let cells = min(cell_count(range), (items[w].y + 1u) * CHUNK);
    for (var i = items[w].y * CHUNK; i < cells; i++) {
        let l = nth_offset(range, i);
        if piece_touches(test, l) && at < total {
            fragments[at] = vec2<u32>(pack_cell(range[0] + l), t);
            at += 1u;
        }
    }
}

// Appending variant for lists sized by a capacity instead of a count pass (the octree's
// dynamic part, which must not wait for a count): every work item counts its fragments,
// reserves a range with one atomic add on `append[P.counter]` and writes into it what fits
// in `fragments`. The counter ends at the number of fragments the triangles give, also when
// the list overflows; the order of the work items' ranges varies from run to run.
@group(0) @binding(5) var<storage, read_write> append: array<atomic<u32>>;

@compute @workgroup_size(64)
fn append_fragments(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                    @builtin(local_invocation_index) li: u32) {
    let w = linear_index(wg, nwg, li);
    if w >= P.items {
        return;
    }
    let piece = pieces[items[w].x];
    let t = piece.triangle;
    let range = piece_cells(piece, P.hi - P.lo);
    let test = piece_test(piece, range[0]);
    let cells = min(cell_count(range), (items[w].y + 1u) * CHUNK);
    var n = 0u;
    for (var i = items[w].y * CHUNK; i < cells; i++) {
        if piece_touches(test, nth_offset(range, i)) {
            n += 1u;
        }
    }
    if n == 0u {
        return;
    }
    var at = atomicAdd(&append[P.counter], n);
    let total = arrayLength(&fragments);
    for (var i = items[w].y * CHUNK; i < cells && at < total; i++) {
        let l = nth_offset(range, i);
        if piece_touches(test, l) {
            fragments[at] = vec2<u32>(pack_cell(range[0] + l), t);
            at += 1u;
        }
    }
}
