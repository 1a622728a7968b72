// Filtered sampling of the sparse voxel octree: `svo_sample(p, footprint)` returns the
// premultiplied albedo and opacity at world position `p`, filtered over a footprint of
// `footprint` metres (the lattice spacing of the chosen level; quadrilinear between levels).
// Its bindings (group 0 from 50, bound by `voxel::svo::sample::svo_bindings` and
// `svo_albedo_bindings`) are the octree's: the parameter block (storage, not uniform:
// "Parameter blocks" in voxel/mod.rs), the child links, the brick of each node and the
// brick pool's 4 albedo buffers. The radiance and anisotropic samplers add theirs after them.

import octolux::gpu::work::count_work;

// The octree's description (`SvoInfo` in voxel/svo/sample.rs).
struct SvoInfo {
    // The grid's origin and voxel size (metres).
    origin: vec3<f32>,
    voxel_size: f32,
    // Levels of the octree.
    depth: u32,
    // Voxels per axis of the grid.
    resolution: u32,
    // Bricks per pool buffer.
    pool_bricks: u32,
    _pad: u32,
}

@group(0) @binding(50) var<storage, read> svo_info: SvoInfo;
@group(0) @binding(51) var<storage, read> svo_child: array<u32>;
@group(0) @binding(52) var<storage, read> svo_brick_index: array<u32>;
@group(0) @binding(53) var<storage, read> svo_bricks0: array<u32>;
@group(0) @binding(54) var<storage, read> svo_bricks1: array<u32>;
@group(0) @binding(55) var<storage, read> svo_bricks2: array<u32>;
@group(0) @binding(56) var<storage, read> svo_bricks3: array<u32>;

fn svo_texel(brick: u32, t: vec3<u32>) -> vec4<f32> {
    let w = (brick % svo_info.pool_bricks) * 27u + t.x + 3u * t.y + 9u * t.z;
    var word = 0u;
    switch brick / svo_info.pool_bricks {
        case 0u: { word = svo_bricks0[w]; }
        case 1u: { word = svo_bricks1[w]; }
        case 2u: { word = svo_bricks2[w]; }
        default: { word = svo_bricks3[w]; }
    }
    return unpack4x8unorm(word);
}

// The brick cell of level d holding grid position g (voxel units): `brick` is the brick index
// + 1 (0 where no node or no brick exists: an all-zero lattice), `i0` the lower lattice corner
// and `f` the trilinear weights inside the cell. Shared by every channel's sampler.
struct SvoCell {
    brick: u32,
    i0: vec3<u32>,
    f: vec3<f32>,
}

// Work of the lookups of one invocation (`gpu/work.wgsl`): cells located (each a descent
// from the root) and the nodes the descents passed, kept only by a counting shader.
@if(count_work) var<private> svo_lookup_work: vec2<u32>;

@if(count_work) fn note_lookup(nodes: u32) {
    svo_lookup_work += vec2<u32>(1u, nodes);
}

@if(!count_work) fn note_lookup(nodes: u32) {}

// Adds this invocation's lookups and nodes to quantities `lookups_q` and `nodes_q`.
@if(count_work) fn count_lookup_work(lookups_q: u32, nodes_q: u32) {
    count_work(lookups_q, svo_lookup_work.x);
    count_work(nodes_q, svo_lookup_work.y);
}

@if(!count_work) fn count_lookup_work(lookups_q: u32, nodes_q: u32) {}

// The cell of the node `node` (of the level whose lattice position is `x`, node coordinates
// `c`) holding x.
fn svo_cell(node: u32, x: vec3<f32>, c: vec3<u32>) -> SvoCell {
    var cell: SvoCell;
    cell.brick = svo_brick_index[node];
    let local = clamp(x - 2.0 * vec3<f32>(c), vec3<f32>(0.0), vec3<f32>(2.0));
    cell.i0 = min(vec3<u32>(local), vec3<u32>(1u));
    cell.f = local - vec3<f32>(cell.i0);
    return cell;
}

// The cells of level d (`fine`) and, with `coarse` and d > 0, of level d - 1 holding grid
// position g, from one descent: the node of level d - 1 is the one the descent to level d
// passes (level d - 1's lattice position is half level d's, its node coordinates half too),
// so a sample between two levels reads the nodes of one descent, not two.
struct SvoCells {
    fine: SvoCell,
    coarse: SvoCell,
}

fn svo_locate_levels(g: vec3<f32>, d: u32, coarse: bool) -> SvoCells {
    var cells: SvoCells;
    let depth = svo_info.depth;
    let x = g / f32(1u << (depth - 1u - d));
    let size = 1u << d;
    if any(x < vec3<f32>(0.0)) || any(x > vec3<f32>(2.0 * f32(size))) {
        return cells;
    }
    let c = min(vec3<u32>(x * 0.5), vec3<u32>(size - 1u));
    var node = 0u;
    for (var l = 0u; l < d; l++) {
        if coarse && l + 1u == d {
            cells.coarse = svo_cell(node, x * 0.5, c >> vec3<u32>(1u));
        }
        let first = svo_child[node];
        if first == 0u {
            note_lookup(l + 1u);
            return cells;
        }
        let s = d - 1u - l;
        node = first + ((c.x >> s) & 1u) + (((c.y >> s) & 1u) << 1u) + (((c.z >> s) & 1u) << 2u);
    }
    note_lookup(d);
    cells.fine = svo_cell(node, x, c);
    return cells;
}

// Trilinear weight of corner `k` (bit 0: x, 1: y, 2: z) of a cell, and its lattice offset.
fn svo_corner(k: u32) -> vec3<u32> {
    return vec3<u32>(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u);
}

fn svo_weight(cell: SvoCell, o: vec3<u32>) -> f32 {
    let w = select(1.0 - cell.f, cell.f, o == vec3<u32>(1u));
    return w.x * w.y * w.z;
}

// Level choice for a footprint: the finer level, the blend `t` towards the next coarser one,
// and the grid position. Level d has lattice spacing voxel * 2^(depth - 1 - d).
struct SvoLod {
    fine: u32,
    t: f32,
    g: vec3<f32>,
}

fn svo_lod(p: vec3<f32>, footprint: f32) -> SvoLod {
    let depth = svo_info.depth;
    let lod = clamp(log2(max(footprint / svo_info.voxel_size, 1.0)), 0.0, f32(depth - 1u));
    return SvoLod(depth - 1u - u32(floor(lod)), lod - floor(lod), (p - svo_info.origin) / svo_info.voxel_size);
}

// Trilinear albedo/opacity sample of a cell; zero where no node exists.
fn svo_sample_cell(cell: SvoCell) -> vec4<f32> {
    var sum = vec4<f32>(0.0);
    if cell.brick == 0u {
        return sum;
    }
    for (var k = 0u; k < 8u; k++) {
        let o = svo_corner(k);
        sum += svo_weight(cell, o) * svo_texel(cell.brick - 1u, cell.i0 + o);
    }
    return sum;
}

fn svo_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let lod = svo_lod(p, footprint);
    let blend = lod.t > 0.0 && lod.fine > 0u;
    let cells = svo_locate_levels(lod.g, lod.fine, blend);
    let a = svo_sample_cell(cells.fine);
    if !blend {
        return a;
    }
    return mix(a, svo_sample_cell(cells.coarse), lod.t);
}

// The octree's per-node values (anisotropic albedo and radiance) sit at node centres: level d
// has nodes of voxel * 2^(depth - d) metres.

// Brick index + 1 of the node of level d at node coordinates c (0 where no node, or no brick);
// a lookup in the work counts, with the nodes its descent read.
fn svo_node_brick(c: vec3<i32>, d: u32) -> u32 {
    let size = i32(1u << d);
    if any(c < vec3<i32>(0)) || any(c >= vec3<i32>(size)) {
        return 0u;
    }
    let u = vec3<u32>(c);
    var node = 0u;
    for (var l = 0u; l < d; l++) {
        let first = svo_child[node];
        if first == 0u {
            note_lookup(l + 1u);
            return 0u;
        }
        let s = d - 1u - l;
        node = first + ((u.x >> s) & 1u) + (((u.y >> s) & 1u) << 1u) + (((u.z >> s) & 1u) << 2u);
    }
    note_lookup(d);
    return svo_brick_index[node];
}

// The 8 nodes of level d around grid position g (voxels), for a node-centred trilinear
// sample: their brick index + 1 (0 where no node or no brick, also outside the grid) and
// weights. All zero more than one node outside the level.
struct SvoNodeCell {
    bricks: array<u32, 8>,
    weights: array<f32, 8>,
}

fn svo_node_cell(g: vec3<f32>, d: u32) -> SvoNodeCell {
    var cell: SvoNodeCell;
    let depth = svo_info.depth;
    let x = g / f32(1u << (depth - d)) - 0.5;
    if any(x < vec3<f32>(-1.0)) || any(x > vec3<f32>(f32(1u << d))) {
        return cell;
    }
    let i0 = vec3<i32>(floor(x));
    let f = x - floor(x);
    for (var k = 0u; k < 8u; k++) {
        let o = svo_corner(k);
        cell.bricks[k] = svo_node_brick(i0 + vec3<i32>(o), d);
        let t = select(1.0 - f, f, o == vec3<u32>(1u));
        cell.weights[k] = t.x * t.y * t.z;
    }
    return cell;
}

// The three faces a cone travelling along `dir` enters a node through (directions +x, -x,
// +y, -y, +z, -z = 0..5; +x when dir.x >= 0) and their weights |dir.x|, |dir.y|, |dir.z|
// normalised to sum to one.
struct SvoFaces {
    face: vec3<u32>,
    w: vec3<f32>,
}

fn svo_faces(dir: vec3<f32>) -> SvoFaces {
    let a = abs(dir);
    return SvoFaces(
        vec3<u32>(select(1u, 0u, dir.x >= 0.0), select(3u, 2u, dir.y >= 0.0), select(5u, 4u, dir.z >= 0.0)),
        a / max(a.x + a.y + a.z, 1e-20),
    );
}

// Level choice for the per-node values at a footprint: the level whose node size matches it
// (`fine`), the blend `t` towards the next coarser one, and the grid position `g`. Below two
// finest voxels (the finest node size) `fine` is the finest level and `below` in [0, 1) says
// how far the footprint is from one voxel to two, for a blend from the isotropic lattice
// (`below` = 1 otherwise).
struct SvoNodeLod {
    fine: u32,
    t: f32,
    below: f32,
    g: vec3<f32>,
}

fn svo_node_lod(p: vec3<f32>, footprint: f32) -> SvoNodeLod {
    let depth = svo_info.depth;
    let s = log2(max(footprint / svo_info.voxel_size, 1.0));
    let lod = clamp(s - 1.0, 0.0, f32(depth - 1u));
    return SvoNodeLod(
        depth - 1u - u32(floor(lod)),
        lod - floor(lod),
        min(s, 1.0),
        (p - svo_info.origin) / svo_info.voxel_size,
    );
}
