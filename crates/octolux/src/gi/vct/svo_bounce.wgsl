// Multiple bounces on the octree (`multi_bounce`): one invocation per static leaf voxel slot
// gathers the indirect irradiance at the voxel with the six diffuse cones of `trace.wgsl`
// through the radiance injected this frame, from the voxel's centre along its mean normal
// (the geometry the injection wrote, `SvoBounce`). The next frame's injection adds it to the
// voxel's direct irradiance, so each frame carries the light one bounce further and the
// octree converges to multi-bounce radiance.

// x: static leaf voxel slots
struct BounceParams {
    misc: vec4<u32>,
}

@group(0) @binding(20) var<storage, read> bounce_params: BounceParams;
@group(0) @binding(21) var<storage, read> bounce_geometry: array<u32>;
@group(0) @binding(22) var<storage, read_write> bounce_irradiance: array<u32>;

@compute @workgroup_size(64)
fn bounce(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * nwg.x + wg.x) * 64u + li;
    if i >= bounce_params.misc.x {
        return;
    }
    let g = bounce_geometry[2u * i];
    let n = unpack4x8snorm(bounce_geometry[2u * i + 1u]).xyz;
    var e = vec3<f32>(0.0);
    if (g & (1u << 30u)) != 0u && dot(n, n) > 0.25 {
        let v = vec3<u32>(g & 1023u, (g >> 10u) & 1023u, (g >> 20u) & 1023u);
        let p = svo_info.origin.xyz + (vec3<f32>(v) + 0.5) * svo_info.origin.w;
        let nn = normalize(n);
        let s = surface_cone(p, nn);
        for (var k = 0u; k < DIFFUSE_CONES; k++) {
            e += diffuse_cone_weight(k) * march_cone(s.apex, diffuse_cone_dir(nn, k), s.cone).rgb;
        }
        e *= 3.14159265;
    }
    bounce_irradiance[2u * i] = pack2x16float(e.rg);
    bounce_irradiance[2u * i + 1u] = pack2x16float(vec2<f32>(e.b, 0.0));
}
