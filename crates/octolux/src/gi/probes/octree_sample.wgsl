// Irradiance from the probe octree (`gi/probes/set_sample` of `probes-octree`). CPU twin:
// `OctreeView::irradiance` in octree_gi.rs.

import octolux::gi::probes::probes::{P, probe_facing_weight};
import octolux::gi::probes::octree_tree::octree_leaf;
import octolux::gi::probes::tree_bindings::{O, tree};
import octolux::gi::probes::set::{probe_edge, probe_info, probe_live};
import octolux::gi::probes::probe_values::{probe_irradiance_at, probe_valid};
import octolux::gi::probes::moments::probe_visibility;
import octolux::gpu::work::count_work;

// Work of the lookups of one invocation (`gpu/work.wgsl`): probes read (valid, weighed),
// leaf lookups (descents of the tree) and the tree nodes they read, kept only by a counting
// shader; a pass adds them from its quantity `q` on with `count_sample_work`
// (`OCTREE_SAMPLE_WORK` in engine.rs).
@if(count_work) var<private> sample_work: vec3<u32>;

@if(count_work) fn note_sample(probes: u32, lookups: u32, nodes: u32) {
    sample_work += vec3<u32>(probes, lookups, nodes);
}

@if(!count_work) fn note_sample(probes: u32, lookups: u32, nodes: u32) {}

@if(count_work) fn count_sample_work(q: u32) {
    count_work(q, sample_work.x);
    count_work(q + 1u, sample_work.y);
    count_work(q + 2u, sample_work.z);
}

@if(!count_work) fn count_sample_work(q: u32) {}

// The leaf holding q, noted as one lookup: `octree_leaf` reads one tree word per level down
// to the leaf's depth (y).
fn leaf_at(q: vec3<f32>) -> vec2<u32> {
    let leaf = octree_leaf(q);
    note_sample(0u, 1u, leaf.y + 1u);
    return leaf;
}

// Through the octree: at q = p + bias n, the leaves holding the 8 corners of a box of the
// size of q's leaf around q; their probes are blended with tent weights (radius: the larger of
// the probe's cube and the box; trilinear where the leaves are equal) times the back-face
// weight and the visibility (moments.wgsl); probes inside geometry are left out. Where they
// weigh nothing, or their visible weight is under VISIBLE_SHARE of what it would be without
// visibility (the probes found are behind walls), the box doubles, up to the root.
const VISIBLE_SHARE: f32 = 0.1;

fn octree_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let lo = O.root_lo;
    let hi = lo + vec3<f32>(O.root_size);
    let q = p + n * P.normal_offset;
    let leaf = leaf_at(clamp(q, lo, hi));
    var h = ldexp(O.root_size, -i32(leaf.y)) * 0.5;
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var level = 0u; level <= O.max_depth + 1u; level++) {
        var seen: array<u32, 8>;
        var count = 0u;
        var open = 0.0;
        sum = vec3<f32>(0.0);
        total = 0.0;
        for (var c = 0u; c < 8u; c++) {
            let upper = vec3<bool>((c & 1u) != 0u, (c & 2u) != 0u, (c & 4u) != 0u);
            let corner = clamp(q + select(vec3<f32>(-h), vec3<f32>(h), upper), lo, hi);
            let v = tree[leaf_at(corner).x];
            if v >= 0 {
                continue;
            }
            let probe = u32(~v);
            var known = false;
            for (var k = 0u; k < count; k++) {
                known = known || seen[k] == probe;
            }
            if known {
                continue;
            }
            seen[count] = probe;
            count += 1u;
            if !probe_valid(probe) {
                continue;
            }
            note_sample(1u, 0u, 0u);
            let x = probe_info[probe].position;
            let tent = max(vec3<f32>(1.0) - abs(q - x) / max(probe_edge(probe), 2.0 * h), vec3<f32>(0.0));
            let w0 = tent.x * tent.y * tent.z * probe_facing_weight(x - p, n);
            let w = w0 * probe_visibility(probe, x, q);
            sum += w * probe_irradiance_at(probe, n);
            total += w;
            open += w0;
        }
        if total > 0.0 && total >= VISIBLE_SHARE * open {
            break;
        }
        h *= 2.0;
    }
    return select(vec3<f32>(0.0), sum / total, total > 0.0);
}

// 004's loop over every probe: the back-face weight times 8^-depth / max(r^2, (edge / 2)^2),
// r the distance from q to the probe (004 attenuates by distance and by the probe's volume
// and clamps inside its cube); normalised by the weights' sum.
fn all_probes_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let q = p + n * P.normal_offset;
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var probe = 0u; probe < P.probe_slots; probe++) {
        if !probe_live(probe) || !probe_valid(probe) {
            continue;
        }
        note_sample(1u, 0u, 0u);
        let x = probe_info[probe].position;
        let r = x - q;
        let e = probe_edge(probe) * 0.5;
        let w = probe_facing_weight(x - p, n) * probe_visibility(probe, x, q) * ldexp(1.0, -3 * i32(probe_info[probe].depth)) / max(dot(r, r), e * e);
        sum += w * probe_irradiance_at(probe, n);
        total += w;
    }
    return select(vec3<f32>(0.0), sum / total, total > 0.0);
}

fn probes_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    if O.gather_all != 0u {
        return all_probes_irradiance(p, n);
    }
    return octree_irradiance(p, n);
}
