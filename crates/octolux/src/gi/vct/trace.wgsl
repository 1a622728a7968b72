// Diffuse gather: the six cones of `gather.wgsl` from the surface (apex moved off the
// surface's own voxels along the normal), marched through the structure's injected radiance
// by `march_cone`; irradiance E = pi x the weighted mean of the cones' radiance, in W/m^2, and
// in alpha the ambient occlusion of the same cones (1 - their weighted mean opacity). With
// sparse tracing (`sparse` = f > 1) the centre pixel of each f x f block is traced, into the
// block's texel of a reduced image; `upsample.wgsl` fills the full image. A pixel's cones run
// on several lanes (`cone_lanes.wgsl`).
// The structure is the module `gi/vct/structure` (`clipmap_trace.wgsl`, `svo_trace.wgsl`), which
// the marcher samples (`vct_sample`) and which gives
//   fn vct_surface_voxel(p: vec3<f32>, finest: f32) -> f32
// the voxel size where a surface at p is (`finest`: the finest voxel); its bindings are the
// structure's (group 0 from 50).

import octolux::frame::common::{Camera, world_from_depth};
import octolux::gi::vct::cone::{ConeParams, march_cone};
import octolux::gi::vct::gather::{diffuse_cone_dir, diffuse_cone_weight};
import octolux::frame::sparse::block_pixel;
import octolux::gi::vct::cone_set::{CONES_PER_LANE, DIFFUSE_CONES};
import octolux::gi::vct::cone_lanes::{
    first_lane, gather_item, keep_cone, lane_cone, sum_item_cones,
};
import octolux::gi::vct::structure::{vct_count_structure_work, vct_surface_voxel};
import octolux::gi::vct::cone::count_cone_work;
import octolux::gpu::work::count_work;

@group(0) @binding(0) var<uniform> cam: Camera;
@group(0) @binding(1) var depth_tex: texture_depth_2d;
@group(0) @binding(2) var normal_tex: texture_2d<f32>;
@group(0) @binding(5) var<storage, read> trace: TraceParams;
@group(0) @binding(6) var out_tex: texture_storage_2d<rgba16float, write>;

// `TraceParams` in tracer.rs.
struct TraceParams {
    cone: ConeParams,
    // Apex offset along the normal and first sample, in voxels of the surface's level.
    apex_offset: f32,
    // Sparse factor f: one traced pixel per f x f block.
    sparse: u32,
    // The specular cone's full aperture (radians).
    specular_aperture: f32,
    // The specular cone's fixed sample count (0: none).
    specular_steps: u32,
}

// The cone parameters at a surface point p: start and smallest footprint from the voxel
// size there (cones start `apex_offset` such voxels off the surface and never sample finer, so
// the surface's own voxels do not occlude them).
struct SurfaceCone {
    apex: vec3<f32>,
    cone: ConeParams,
}

fn surface_cone(p: vec3<f32>, n: vec3<f32>) -> SurfaceCone {
    let voxel = vct_surface_voxel(p, trace.cone.voxel);
    var s: SurfaceCone;
    s.cone = trace.cone;
    s.cone.voxel = voxel;
    s.cone.start = trace.apex_offset * voxel;
    s.apex = p + n * (trace.apex_offset * voxel);
    return s;
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    // One traced pixel per item, its cones spread over the item's lanes (`cone_lanes.wgsl`);
    // items run along the rows of the traced (reduced) image.
    let size = vec2<u32>(cam.size.xy);
    let f = trace.sparse;
    let traced = (size + vec2<u32>(f - 1u)) / f;
    let q = gather_item(wg.y * nwg.x + wg.x, li);
    let id = vec2<u32>(q % traced.x, q / traced.x);
    let inside = q < traced.x * traced.y;
    var sky = true;
    if inside {
        let px = block_pixel(id, f, size);
        let depth = textureLoad(depth_tex, px, 0);
        sky = depth >= 1.0;
        if !sky {
            let p = world_from_depth(cam, px, depth);
            let n = normalize(textureLoad(normal_tex, px, 0).xyz);
            let s = surface_cone(p, n);
            for (var j = 0u; j < CONES_PER_LANE; j++) {
                let cone = lane_cone(li, j);
                if cone < DIFFUSE_CONES {
                    let l = march_cone(s.apex, diffuse_cone_dir(n, cone), s.cone);
                    keep_cone(li, cone, diffuse_cone_weight(cone) * l);
                }
            }
        }
    }
    let sum = sum_item_cones(li);
    if inside && first_lane(li) {
        if sky {
            textureStore(out_tex, id, vec4<f32>(0.0, 0.0, 0.0, 1.0));
        } else {
            textureStore(out_tex, id, vec4<f32>(3.14159265 * sum.rgb, 1.0 - sum.a));
            // Work counts (`TRACE_WORK` in tracer.rs): pixels traced, then every lane's cones,
            // samples and the structure's lookups.
            count_work(0u, 1u);
        }
    }
    count_cone_work(1u, 2u);
    vct_count_structure_work(3u);
}

// The optional specular cone (`specular` setting): one cone per pixel along the view
// direction mirrored about the normal, with the aperture of the roughness setting; writes the
// radiance it gathers (W/(m^2 sr)) into its own image at full resolution.
@group(0) @binding(30) var specular_tex: texture_storage_2d<rgba16float, write>;

@compute @workgroup_size(8, 8)
fn specular(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(cam.size.xy);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let depth = textureLoad(depth_tex, id.xy, 0);
    if depth >= 1.0 {
        textureStore(specular_tex, id.xy, vec4<f32>(0.0, 0.0, 0.0, 1.0));
        return;
    }
    let p = world_from_depth(cam, id.xy, depth);
    let n = normalize(textureLoad(normal_tex, id.xy, 0).xyz);
    var s = surface_cone(p, n);
    s.cone.aperture = trace.specular_aperture;
    // Fixed work (`specular_steps`, for timing the structures, `003` §5.3.5): exactly that
    // many samples from the finest voxel on, never stopping at opacity or distance.
    if trace.specular_steps > 0u {
        s.cone.voxel = trace.cone.voxel;
        s.cone.stop_opacity = 2.0;
        s.cone.max_distance = 3.0e38;
        s.cone.max_steps = trace.specular_steps;
    }
    let v = normalize(p - cam.position.xyz);
    let l = march_cone(s.apex, reflect(v, n), s.cone);
    textureStore(specular_tex, id.xy, vec4<f32>(l.rgb, 1.0));
}
