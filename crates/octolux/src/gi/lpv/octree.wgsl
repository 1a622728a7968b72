// Octree LPV (000 §3): levels O_0..O_{l-1} of side n >> i stored one after another, the
// downsample of eq. 2, the occupancy pyramid and index volume levels I_i, and the merge of
// eq. 1 into one n^3 LPV. Offsets of level i = sum over j < i of (n >> j)^3 cells.

struct OctreeParams {
    // side of level 0
    n: u32,
    // number of levels l
    levels: u32,
    // the level this dispatch works on
    level: u32,
    _pad: u32,
    // first cell of each level (computed on the CPU: the loop it replaces ran per cell and
    // per level)
    offsets: array<vec4<u32>, 2>,
};

// Differs per dispatch (level): a storage buffer, see `param_slots` in mod.rs.
@group(0) @binding(0) var<storage, read> params: OctreeParams;
@group(0) @binding(1) var<storage, read_write> light: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> gv: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> occ: array<u32>;
@group(0) @binding(4) var<storage, read_write> index: array<u32>;
@group(0) @binding(5) var<storage, read> acc: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> merged: array<vec4<f32>>;

fn level_offset(i: u32) -> u32 {
    return params.offsets[i / 4u][i % 4u];
}

fn cell_of(level: u32, c: vec3<u32>) -> u32 {
    let m = params.n >> level;
    return level_offset(level) + c.x + m * (c.y + m * c.z);
}

// Eq. 2: O_i(x) = 1/8 sum of the eight children in O_{i-1}.
@compute @workgroup_size(4, 4, 4)
fn downsample(@builtin(global_invocation_id) id: vec3<u32>) {
    let m = params.n >> params.level;
    if any(id >= vec3<u32>(m)) {
        return;
    }
    var s = array<vec4<f32>, 3>(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var k = 0u; k < 8u; k++) {
        let child = id * 2u + vec3<u32>(k & 1u, (k >> 1u) & 1u, k >> 2u);
        let ci = cell_of(params.level - 1u, child) * 3u;
        s[0] += light[ci];
        s[1] += light[ci + 1u];
        s[2] += light[ci + 2u];
    }
    let i = cell_of(params.level, id) * 3u;
    light[i] = s[0] * 0.125;
    light[i + 1u] = s[1] * 0.125;
    light[i + 2u] = s[2] * 0.125;
}

// Level-0 occupancy: a cell holds geometry when one of its eight geometry-volume corners
// (level 0's geometry volume comes first in `gv`) blocks anything.
@compute @workgroup_size(4, 4, 4)
fn occupancy(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = params.n;
    if any(id >= vec3<u32>(n >> params.level)) {
        return;
    }
    var any_geometry = false;
    if params.level == 0u {
        let m = n + 1u;
        for (var k = 0u; k < 8u; k++) {
            let c = id + vec3<u32>(k & 1u, (k >> 1u) & 1u, k >> 2u);
            any_geometry = any_geometry || gv[c.x + m * (c.y + m * c.z)].x > 1e-6;
        }
    } else {
        for (var k = 0u; k < 8u; k++) {
            let child = id * 2u + vec3<u32>(k & 1u, (k >> 1u) & 1u, k >> 2u);
            any_geometry = any_geometry || occ[cell_of(params.level - 1u, child)] != 0u;
        }
    }
    occ[cell_of(params.level, id)] = u32(any_geometry);
}

// I_i(x) = i where the level-i cell or a neighbour holds geometry, else l - 1.
@compute @workgroup_size(4, 4, 4)
fn index_level(@builtin(global_invocation_id) id: vec3<u32>) {
    let m = i32(params.n >> params.level);
    if any(id >= vec3<u32>(u32(m))) {
        return;
    }
    let c = vec3<i32>(id);
    var near = false;
    for (var k = 0; k < 27; k++) {
        let q = c + vec3<i32>(k % 3, (k / 3) % 3, k / 9) - 1;
        if all(q >= vec3<i32>(0)) && all(q < vec3<i32>(m)) {
            near = near || occ[cell_of(params.level, vec3<u32>(q))] != 0u;
        }
    }
    index[cell_of(params.level, id)] = select(params.levels - 1u, params.level, near);
}

// Eq. 1 and the merge: M(x) = S(x) = O_I(x)(x / 2^I(x)), scaled by 2^I(x) to level-0 units
// (see sh.rs `merge`).
@compute @workgroup_size(4, 4, 4)
fn merge(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id >= vec3<u32>(params.n)) {
        return;
    }
    var level = params.levels - 1u;
    for (var i = 0u; i < params.levels; i++) {
        level = min(level, index[cell_of(i, id >> vec3<u32>(i))]);
    }
    let src = cell_of(level, id >> vec3<u32>(level)) * 3u;
    let dst = cell_of(0u, id) * 3u;
    let scale = f32(1u << level);
    merged[dst] = acc[src] * scale;
    merged[dst + 1u] = acc[src + 1u] * scale;
    merged[dst + 2u] = acc[src + 2u] * scale;
}
