// Directional sampling of the octree's anisotropic node values (svo/aniso.wgsl). Goes after
// `svo/sample.wgsl`; the includer also declares
//   var<storage, read> svo_aniso: array<u32>;   (SvoAnisoValues::buffer)
//
// `svo_sample_aniso(p, footprint, dir)` returns premultiplied albedo and opacity at `p` seen by
// a cone travelling along `dir`, filtered over `footprint` metres. Level d's values sit at its
// node centres (node size voxel * 2^(depth - d)) and are interpolated trilinearly; the level
// whose node size matches the footprint is read, quadrilinear between two levels. Each node's
// value is its directional values for the three faces `dir` travels through (+x when
// dir.x >= 0), weighted by |dir.x|, |dir.y|, |dir.z| normalised to sum to one. Below the finest
// node size (footprint < 2 voxels) the sample blends from the isotropic `svo_sample` (at one
// voxel and less) to the finest directional level (at two voxels). Zero where no node exists.

// Brick index + 1 of the node of level d at node coordinates c (0 where no node, or no brick).
fn svo_node_brick(c: vec3<i32>, d: u32) -> u32 {
    let size = i32(1u << d);
    if any(c < vec3<i32>(0)) || any(c >= vec3<i32>(size)) {
        return 0u;
    }
    let u = vec3<u32>(c);
    var node = 0u;
    for (var l = 0u; l < d; l++) {
        let first = svo_child[node];
        if first == 0u {
            return 0u;
        }
        let s = d - 1u - l;
        node = first + ((u.x >> s) & 1u) + (((u.y >> s) & 1u) << 1u) + (((u.z >> s) & 1u) << 2u);
    }
    return svo_brick_index[node];
}

// Node-centred trilinear sample of level d's directional values at grid position g (voxels).
fn svo_aniso_level(g: vec3<f32>, d: u32, dir: vec3<f32>) -> vec4<f32> {
    let depth = svo_info.misc.x;
    let x = g / f32(1u << (depth - d)) - 0.5;
    var sum = vec4<f32>(0.0);
    if any(x < vec3<f32>(-1.0)) || any(x > vec3<f32>(f32(1u << d))) {
        return sum;
    }
    let a = abs(dir);
    let w = a / max(a.x + a.y + a.z, 1e-20);
    let dx = select(1u, 0u, dir.x >= 0.0);
    let dy = select(3u, 2u, dir.y >= 0.0);
    let dz = select(5u, 4u, dir.z >= 0.0);
    let i0 = vec3<i32>(floor(x));
    let f = x - floor(x);
    for (var k = 0u; k < 8u; k++) {
        let o = svo_corner(k);
        let b = svo_node_brick(i0 + vec3<i32>(o), d);
        if b == 0u {
            continue;
        }
        let base = (b - 1u) * 6u;
        let v = w.x * unpack4x8unorm(svo_aniso[base + dx])
            + w.y * unpack4x8unorm(svo_aniso[base + dy])
            + w.z * unpack4x8unorm(svo_aniso[base + dz]);
        let t = select(1.0 - f, f, o == vec3<u32>(1u));
        sum += t.x * t.y * t.z * v;
    }
    return sum;
}

fn svo_sample_aniso(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    let depth = svo_info.misc.x;
    let g = (p - svo_info.origin.xyz) / svo_info.origin.w;
    let s = log2(max(footprint / svo_info.origin.w, 1.0));
    if s < 1.0 {
        let iso = svo_sample(p, footprint);
        if s <= 0.0 {
            return iso;
        }
        return mix(iso, svo_aniso_level(g, depth - 1u, dir), s);
    }
    let lod = min(s - 1.0, f32(depth - 1u));
    let fine = depth - 1u - u32(floor(lod));
    let t = lod - floor(lod);
    let a = svo_aniso_level(g, fine, dir);
    if t <= 0.0 || fine == 0u {
        return a;
    }
    return mix(a, svo_aniso_level(g, fine - 1u, dir), t);
}
