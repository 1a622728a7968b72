// Light injection into the clipmap by voxel shadow rays: direct irradiance from point, spot
// and directional lights with visibility from marching the clipmap's own opacity towards the
// light (no shadow maps).

import octolux::voxel::clipmap::inject_common::{InjectLit, inject_add, inject_slot, inject_store, inject_voxel, params};
import octolux::voxel::clipmap::sample::clip_sample;
// The renderer's light record; its own bindings (from 40) stay out of this pass's layout.
import octolux::frame::lights::{Light, LIGHT_DIRECTIONAL, LIGHT_SPOT};

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(3) var<storage, read> inject_lights: array<Light>;

fn spot_falloff(cos_angle: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let x = clamp((cos_angle - cos_outer) / max(cos_inner - cos_outer, 1e-6), 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

// Fraction of light passing from p along dir over dist, composited front to back from
// samples of footprint `voxel` half a voxel apart (a whole-voxel step lets about a quarter of
// the light through a one-voxel-thick occluder, as trilinear weights split between samples).
fn transmittance(p: vec3<f32>, dir: vec3<f32>, dist: f32, voxel: f32) -> f32 {
    var alpha = 0.0;
    var t = 0.0;
    for (var i = 0u; i < params.max_steps && t < dist && alpha < 0.99; i++) {
        alpha += (1.0 - alpha) * clip_sample(p + t * dir, voxel).a;
        t += 0.5 * voxel;
    }
    return 1.0 - alpha;
}

@compute @workgroup_size(64)
fn inject(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) li: u32) {
    let i = inject_slot(wg, nwg, li);
    if i >= params.slots {
        return;
    }
    let vox = inject_voxel(i);
    if vox.value.a == 0.0 {
        return;
    }
    let p = vox.p;
    let n = vox.n;
    let has_normal = vox.has_normal;
    let v = vox.size;
    var lit = InjectLit(vec3<f32>(0.0), vec3<f32>(0.0));
    for (var k = 0u; k < params.lights; k++) {
        let light = inject_lights[k];
        var to_light: vec3<f32>;
        var el: vec3<f32>;
        var dist = 1.0e4;
        if light.kind == LIGHT_DIRECTIONAL {
            to_light = -light.direction;
            el = light.radiant;
        } else {
            let d = light.position - p;
            let r2 = max(dot(d, d), 1e-8);
            dist = sqrt(r2);
            to_light = d / dist;
            el = light.radiant / r2;
            if light.kind == LIGHT_SPOT {
                el *= spot_falloff(dot(light.direction, -to_light), light.cos_inner, light.cos_outer);
            }
        }
        var cos_theta = 1.0;
        if has_normal {
            cos_theta = dot(n, to_light);
        }
        if cos_theta <= 0.0 || all(el <= vec3<f32>(0.0)) {
            continue;
        }
        // Leave the voxel's own footprint: two voxels along the normal before marching.
        var start = p + to_light * v;
        if has_normal {
            start += n * 2.0 * v;
        }
        let vis = transmittance(start, to_light, dist - 3.0 * v, v);
        inject_add(&lit, vox, el * cos_theta * vis, to_light);
    }
    inject_store(i, vox, lit);
}
