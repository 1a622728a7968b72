// Pixel gather: the indirect irradiance of every G-buffer pixel from the probes around it.

import octolux::frame::common::{Camera, world_from_depth};
import octolux::gi::probes::set_sample::{count_sample_work, probes_irradiance};
import octolux::gpu::work::count_work;

// The probes (3) and their depth moments (8) are the sampler's bindings (probe_values.wgsl,
// moments.wgsl).
@group(0) @binding(1) var<uniform> cam: Camera;
@group(0) @binding(2) var depth_tex: texture_depth_2d;
@group(0) @binding(4) var normal_tex: texture_2d<f32>;
@group(0) @binding(5) var out_tex: texture_storage_2d<rgba16float, write>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(cam.size.xy);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let depth = textureLoad(depth_tex, id.xy, 0);
    if depth >= 1.0 {
        textureStore(out_tex, id.xy, vec4<f32>(0.0, 0.0, 0.0, 1.0));
        return;
    }
    let p = world_from_depth(cam, id.xy, depth);
    let n = normalize(textureLoad(normal_tex, id.xy, 0).xyz);
    textureStore(out_tex, id.xy, vec4<f32>(probes_irradiance(p, n), 1.0));
    // Work counts (`*_GATHER_WORK` in engine.rs): pixels gathered, then the lookup's work.
    count_work(0u, 1u);
    count_sample_work(1u);
}
