// Irradiance from the probe grid (`gi/probes/set_sample` of `probes-grid`).

import octolux::gi::probes::probes::{P, probe_facing_weight};
import octolux::gi::probes::set::probe_position;
import octolux::gi::probes::probe_values::{probe_irradiance_at, probe_valid};
import octolux::gi::probes::moments::probe_visibility;
import octolux::gpu::work::count_work;

// Work of the lookups of one invocation (`gpu/work.wgsl`): probes read (valid, weighed),
// kept only by a counting shader; a pass adds them from its quantity `q` on with
// `count_sample_work` (`GRID_SAMPLE_WORK` in engine.rs).
@if(count_work) var<private> sample_work: u32;

@if(count_work) fn note_probe_read() {
    sample_work += 1u;
}

@if(!count_work) fn note_probe_read() {}

@if(count_work) fn count_sample_work(q: u32) {
    count_work(q, sample_work);
}

@if(!count_work) fn count_sample_work(q: u32) {}

// Irradiance at p (unit normal n) from the 8 probes around p + bias n: trilinear weights times
// the back-face weight for the direction to the probe; probes inside geometry (too many
// back-face hits) are left out. CPU twin: `grid_irradiance` in grid_gi.rs.
fn probes_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let q = p + n * P.normal_offset;
    let g = (q - P.lo) / P.spacing - 0.5;
    let hi = vec3<i32>(P.dims) - 2;
    let base = clamp(vec3<i32>(floor(g)), vec3<i32>(0), hi);
    let t = clamp(g - vec3<f32>(base), vec3<f32>(0.0), vec3<f32>(1.0));
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var c = 0u; c < 8u; c++) {
        let off = vec3<u32>(c & 1u, (c >> 1u) & 1u, (c >> 2u) & 1u);
        let coord = vec3<u32>(base) + off;
        let probe = coord.x + P.dims.x * (coord.y + P.dims.y * coord.z);
        if !probe_valid(probe) {
            continue;
        }
        note_probe_read();
        let tri = select(vec3<f32>(1.0) - t, t, off == vec3<u32>(1u));
        let x = probe_position(coord);
        let w = tri.x * tri.y * tri.z * probe_facing_weight(x - p, n) * probe_visibility(probe, x, q);
        sum += w * probe_irradiance_at(probe, n);
        total += w;
    }
    return select(vec3<f32>(0.0), sum / total, total > 0.0);
}
