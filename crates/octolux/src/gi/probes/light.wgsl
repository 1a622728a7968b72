// Surfel light: outgoing radiance emission + albedo / pi x E of every front-facing surfel,
// with E the direct irradiance from the renderer's lights and shadow maps (`frame/lights.wgsl`,
// as the deferred pass lights pixels) plus, with multiple bounces, the probes' irradiance of
// the previous frame at the surfel. Back faces and misses send no light (the sky seen directly
// is the direct pass's). With two surfel sets both are lit while samples come (the older one
// relights the probes' history), the latest alone once the probes keep their value.

import octolux::frame::lights::{Light, light_incidence, lights, shadow_visibility};
import octolux::frame::common::PI;
import octolux::gi::probes::probes::{linear_index, P, probe_surfels, Surfel, SURFEL_FRONT};
import octolux::gi::probes::set::{probe_live, probe_restarts, probe_slot, probe_slots};
import octolux::gi::probes::set_sample::{count_sample_work, probes_irradiance};
import octolux::gpu::work::count_work;

@group(0) @binding(1) var<storage, read> surfels: array<Surfel>;
@group(0) @binding(2) var<storage, read_write> radiance: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    // Invocation k: surfel k % n of the set's (k / n)-th probe.
    let k = linear_index(wg, nwg, li);
    let per_probe = probe_surfels();
    if k >= probe_slots() * per_probe {
        return;
    }
    let probe = probe_slot(k / per_probe);
    let s = probe * per_probe + k % per_probe;
    if !probe_live(probe) {
        return;
    }
    // Two sets and no new sample this frame: only the latest set is integrated (both for a
    // probe that restarts its history).
    let latest_only = P.set_count > 1u && P.latest_placed == 0u && !probe_restarts(probe);
    if latest_only && (k % per_probe) / P.surfels_per_set != P.latest_set {
        return;
    }
    let surfel = surfels[s];
    // Only front faces are lit.
    if surfel.state != SURFEL_FRONT {
        radiance[s] = vec4<f32>(0.0);
        return;
    }
    let p = surfel.position;
    let n = surfel.normal;
    let albedo = unpack4x8unorm(surfel.albedo).rgb;
    var e = vec3<f32>(0.0);
    // Work counts (`*_LIGHT_WORK` in engine.rs): surfels lit, shadow lookups, then the probe
    // lookups' work (with multiple bounces).
    var shadow_lookups = 0u;
    for (var i = 0u; i < P.light_count; i++) {
        let light = lights[i];
        let inc = light_incidence(light, p);
        let cos_theta = dot(n, inc.to_light);
        if cos_theta <= 0.0 || all(inc.irradiance <= vec3<f32>(0.0)) {
            continue;
        }
        shadow_lookups += 1u;
        e += inc.irradiance * cos_theta * shadow_visibility(light, p, n, inc.to_light, inc.dist, 0.0);
    }
    if P.multi_bounce != 0u {
        // Last frame's bounces scale with the lights that made them: a light that dims or
        // switches off takes its higher bounces with it at once, not over a bounce per frame.
        e += P.bounce_scale * probes_irradiance(p, n);
    }
    count_work(0u, 1u);
    count_work(1u, shadow_lookups);
    count_sample_work(2u);
    radiance[s] = vec4<f32>(surfel.emission + albedo / PI * e, 0.0);
}
