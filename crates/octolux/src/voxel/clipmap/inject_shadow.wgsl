// Light injection into the clipmap from the renderer's shadow maps (`003` §4.2's "inject
// direct light from the shadow map", per voxel): direct irradiance from the renderer's
// lights (`frame/lights.wgsl`, the same incidence and PCF lookup as the deferred lighting),
// looked up half a voxel off the voxel centre along its normal, where a surface in the voxel
// may lie.

import octolux::frame::lights::{Light, light_incidence, lights, shadow_visibility};
import octolux::voxel::clipmap::inject_common::{InjectLit, inject_add, inject_slot, inject_store, inject_voxel, params};



@compute @workgroup_size(64)
fn inject_shadow(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                 @builtin(local_invocation_index) li: u32) {
    let i = inject_slot(wg, nwg, li);
    if i >= params.slots {
        return;
    }
    let v = inject_voxel(i);
    if v.value.a == 0.0 {
        return;
    }
    var lit = InjectLit(vec3<f32>(0.0), vec3<f32>(0.0));
    for (var k = 0u; k < params.lights; k++) {
        let light = lights[k];
        let inc = light_incidence(light, v.p);
        // A voxel without a dominant normal (opposite faces cancelled) is lit as facing the
        // light.
        var cos_theta = 1.0;
        if v.has_normal {
            cos_theta = dot(v.n, inc.to_light);
        }
        if cos_theta <= 0.0 || all(inc.irradiance <= vec3<f32>(0.0)) {
            continue;
        }
        let vis = shadow_visibility(light, v.p, v.n, inc.to_light, inc.dist, 0.5 * v.size);
        inject_add(&lit, v, inc.irradiance * cos_theta * vis, inc.to_light);
    }
    inject_store(i, v, lit);
}
