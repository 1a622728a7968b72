// Voxel fragment list: a count pass (voxels touched per triangle), an exclusive scan of the
// counts (on the CPU, which also sizes the list), then an emit pass writing each triangle's
// fragments at its offset in a fixed loop order: the list is identical from run to run.
// A fragment is (packed voxel coordinate relative to lo, triangle index); albedo, normal and
// emission are read from the triangle.

@group(0) @binding(0) var<uniform> P: VoxParams;
@group(0) @binding(1) var<storage, read> tris: array<Tri>;
@group(0) @binding(2) var<storage, read_write> counts: array<u32>;
@group(0) @binding(3) var<storage, read_write> fragments: array<vec2<u32>>;
// Work items: (triangle, chunk of CHUNK bounding-box voxels), so that no invocation loops more
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
    if w >= P.misc.x {
        return;
    }
    let t = items[w].x;
    let tri = tris[t];
    let a = to_grid(tri.p0.xyz, P.origin);
    let b = to_grid(tri.p1.xyz, P.origin);
    let c = to_grid(tri.p2.xyz, P.origin);
    let range = tri_cells(a, b, c, P.lo.xyz, P.hi.xyz);
    var n = 0u;
    let cells = min(cell_count(range), (items[w].y + 1u) * CHUNK);
    for (var i = items[w].y * CHUNK; i < cells; i++) {
        if tri_box_overlap(a, b, c, nth_cell(range, i)) {
            n += 1u;
        }
    }
    counts[w] = n;
}

@compute @workgroup_size(64)
fn emit_fragments(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                  @builtin(local_invocation_index) li: u32) {
    let w = linear_index(wg, nwg, li);
    if w >= P.misc.x {
        return;
    }
    let t = items[w].x;
    let tri = tris[t];
    let a = to_grid(tri.p0.xyz, P.origin);
    let b = to_grid(tri.p1.xyz, P.origin);
    let c = to_grid(tri.p2.xyz, P.origin);
    let range = tri_cells(a, b, c, P.lo.xyz, P.hi.xyz);
    var at = counts[w];
    let total = arrayLength(&fragments);
    let cells = min(cell_count(range), (items[w].y + 1u) * CHUNK);
    for (var i = items[w].y * CHUNK; i < cells; i++) {
        let cell = nth_cell(range, i);
        if tri_box_overlap(a, b, c, cell) && at < total {
            fragments[at] = vec2<u32>(pack_cell(cell - P.lo.xyz), t);
            at += 1u;
        }
    }
}
