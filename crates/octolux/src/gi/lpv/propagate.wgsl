// One LPV propagation step in gather form (see sh.rs `propagate_step`): each cell collects the
// flux its six neighbours send through its five non-shared faces (exact solid angles),
// attenuated by the geometry volume at the shared face, re-emits it (a beam along the direction
// it crossed the face and a Lambertian lobe about the face normal, mixed by `directional`),
// writes the result and adds it to the accumulation buffer.

import octolux::frame::common::PI;
import octolux::gi::lpv::sh::{
    FRONT_SOLID_ANGLE, Grid, LOBE_C0, LOBE_C1, SH_C0, SH_C1, SIDE_SOLID_ANGLE, sh_basis, sh_lobe,
};

// Every grid (cascade, octree level) in one 256-byte slot each (`param_slots` in mod.rs), with
// the first of its 4x4x4-cell bricks; one dispatch steps all of them (`propagate::slot_data`).

struct GridSlot {
    grid: Grid,
    first_brick: u32,
    // share of the crossing flux re-emitted as a beam along its direction (sh.rs `reemit`)
    directional: f32,
    _pad1: u32,
    _pad2: u32,
    _pad: array<vec4<u32>, 13>,
};
@group(0) @binding(0) var<storage, read> slots: array<GridSlot>;

// The grid of this invocation.
var<private> grid: Grid;
@group(0) @binding(1) var<storage, read> src: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> dst: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> acc: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> gv: array<vec4<f32>>;

const DIRS = array<vec3<i32>, 6>(
    vec3<i32>(1, 0, 0), vec3<i32>(-1, 0, 0),
    vec3<i32>(0, 1, 0), vec3<i32>(0, -1, 0),
    vec3<i32>(0, 0, 1), vec3<i32>(0, 0, -1),
);

fn cell_index(c: vec3<i32>) -> u32 {
    let n = i32(grid.n);
    return grid.offset + u32(c.x + n * (c.y + n * c.z));
}

// 1 - blocking potential at the face cell `c` shares with `c - dir` (sh.rs `transmittance`).
fn transmittance(c: vec3<i32>, dir: vec3<i32>) -> f32 {
    let m = i32(grid.n) + 1;
    var b = vec4<f32>(0.0);
    let near = vec3<i32>(dir < vec3<i32>(0));
    for (var o = 0; o < 8; o++) {
        let corner = c + vec3<i32>(o & 1, (o >> 1) & 1, (o >> 2) & 1);
        let on_face = (dir == vec3<i32>(0)) | (corner == c + near);
        if all(on_face) {
            b += 0.25 * gv[grid.gv_offset + u32(corner.x + m * (corner.y + m * corner.z))];
        }
    }
    // Opaque from both sides, normalised by the lobe's peak (sh.rs `blocking`).
    let d = vec3<f32>(dir);
    let peak = LOBE_C0 * SH_C0 + LOBE_C1 * SH_C1;
    return 1.0 - clamp(max(dot(b, sh_basis(-d)), dot(b, sh_basis(d))) / peak, 0.0, 1.0);
}

// One workgroup per brick of 4x4x4 cells of every grid, the grids' bricks one after another.
@compute @workgroup_size(4, 4, 4)
fn main(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let brick = wg.x + wg.y * groups.x;
    var which = 0u;
    for (var k = 1u; k < arrayLength(&slots); k++) {
        if brick >= slots[k].first_brick {
            which = k;
        }
    }
    grid = slots[which].grid;
    let directional = slots[which].directional;
    let per = (grid.n + 3u) / 4u;
    let own = brick - slots[which].first_brick;
    if own >= per * per * per {
        return;
    }
    let id = vec3<u32>(own % per, (own / per) % per, own / (per * per)) * 4u + local;
    let n = i32(grid.n);
    if any(id >= vec3<u32>(grid.n)) {
        return;
    }
    let c = vec3<i32>(id);
    var r = vec4<f32>(0.0);
    var g = vec4<f32>(0.0);
    var b = vec4<f32>(0.0);
    for (var k = 0; k < 6; k++) {
        let dir = DIRS[k];
        let s = c - dir;
        if any(s < vec3<i32>(0)) || any(s >= vec3<i32>(n)) {
            continue;
        }
        let si = cell_index(s) * 3u;
        let sr = src[si];
        let sg = src[si + 1u];
        let sb = src[si + 2u];
        var t = 1.0;
        if (grid.flags & 1u) != 0u {
            t = transmittance(c, dir);
        }
        let d = vec3<f32>(dir);
        for (var f = 0; f < 6; f++) {
            if all(DIRS[f] == -dir) {
                continue;
            }
            let nf = vec3<f32>(DIRS[f]);
            var w = d;
            var dw = FRONT_SOLID_ANGLE;
            if f != k {
                w = normalize(d + 0.5 * nf);
                dw = SIDE_SOLID_ANGLE;
            }
            let y = sh_basis(w);
            let l = (sh_lobe(nf) * ((1.0 - directional) / PI) + y * directional) * (dw * t);
            r += l * dot(sr, y);
            g += l * dot(sg, y);
            b += l * dot(sb, y);
        }
    }
    let i = cell_index(c) * 3u;
    dst[i] = r;
    dst[i + 1u] = g;
    dst[i + 2u] = b;
    acc[i] += r;
    acc[i + 1u] += g;
    acc[i + 2u] += b;
}
