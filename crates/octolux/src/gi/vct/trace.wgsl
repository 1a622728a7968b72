// Diffuse gather: the six cones of `gather.wgsl` from the surface (apex moved off the
// surface's own voxels along the normal), marched through the clipmap's injected radiance by
// `march_cone`; irradiance E = pi x the weighted mean of the cones' radiance, in W/m^2. With
// sparse tracing (misc.y = f > 1) one invocation traces the centre pixel of each f x f block
// and writes the block's texel of a reduced image; `upsample.wgsl` fills the full image.

@group(0) @binding(0) var<uniform> cam: Camera;
@group(0) @binding(1) var depth_tex: texture_depth_2d;
@group(0) @binding(2) var normal_tex: texture_2d<f32>;
@group(0) @binding(3) var<storage, read> clip_info: ClipInfo;
@group(0) @binding(4) var<storage, read> clip_radiance: array<u32>;
@group(0) @binding(5) var<storage, read> trace: TraceParams;
@group(0) @binding(6) var out_tex: texture_storage_2d<rgba16float, write>;
// Declared for the sampler's albedo path, which the gather does not read.
@group(0) @binding(7) var<storage, read> clip_voxels: array<u32>;

struct TraceParams {
    cone: ConeParams,
    // x: apex offset along the normal and first sample, in voxels of the surface's level;
    // y: sparse factor f (one traced pixel per f x f block)
    misc: vec4<f32>,
}

// The clipmap back-end of the marcher's sampling function.
fn vct_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    return clip_radiance_sample(p, footprint);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(cam.size.xy);
    let f = u32(trace.misc.y);
    if id.x * f >= size.x || id.y * f >= size.y {
        return;
    }
    let px = block_pixel(id.xy, f, size);
    let depth = textureLoad(depth_tex, px, 0);
    if depth >= 1.0 {
        textureStore(out_tex, id.xy, vec4<f32>(0.0, 0.0, 0.0, 1.0));
        return;
    }
    let p = world_from_depth(cam, px, depth);
    let n = normalize(textureLoad(normal_tex, px, 0).xyz);
    // The voxel size where the surface is: the finest level holding it. Cones start one such
    // voxel (x `start`) off the surface and never sample finer, so the surface's own voxels
    // do not occlude them (a coarse level's voxel is thicker than a fine level's offset).
    var voxel = trace.cone.voxel;
    for (var l = 0u; l < clip_info.misc.y; l++) {
        if clip_contains(p, l) {
            break;
        }
        voxel *= 2.0;
    }
    var cone = trace.cone;
    cone.voxel = voxel;
    cone.start = trace.misc.x * voxel;
    let apex = p + n * (trace.misc.x * voxel);
    var e = vec3<f32>(0.0);
    for (var i = 0u; i < DIFFUSE_CONES; i++) {
        let l = march_cone(apex, diffuse_cone_dir(n, i), cone);
        e += diffuse_cone_weight(i) * l.rgb;
    }
    textureStore(out_tex, id.xy, vec4<f32>(3.14159265 * e, 1.0));
}
