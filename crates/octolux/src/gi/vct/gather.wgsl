// The diffuse gather's cone set (`003` §3.2.5): one cone along the normal and five at 60
// degrees around it, weighted by the cosine of their angle to the normal and normalised so
// that the weights sum to 1; irradiance = pi x the weighted mean of the cones' radiance, so a
// uniform environment of radiance L gives exactly pi L. CPU twin: `gi/vct/gather.rs`.

// The cone set is the module `gi/vct/cone_set` (generated: `gather.rs`, `cone_set_wgsl`): DIFFUSE_CONES cones,
// DIFFUSE_SET[i] = direction in the frame whose +y is the normal (xyz) and weight (w; the
// weights sum to 1). The default is 003's six (the ring is cone 2 rotated by multiples of
// 72 degrees about y, weights cos / 3.5); denser sets are cosine-distributed, weights 1/N.

import octolux::gi::vct::cone_set::DIFFUSE_SET;

fn diffuse_cone_local(i: u32) -> vec3<f32> {
    return DIFFUSE_SET[i].xyz;
}

fn diffuse_cone_weight(i: u32) -> f32 {
    return DIFFUSE_SET[i].w;
}

// An orthonormal basis (t, b) around the unit normal n, without a branch on its direction
// beyond the sign of n.z (Duff et al. 2017).
fn cone_basis(n: vec3<f32>) -> mat2x3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    let u = vec3<f32>(b, s + n.y * n.y * a, -n.y);
    return mat2x3<f32>(t, u);
}

// World direction of cone i around the unit normal n.
fn diffuse_cone_dir(n: vec3<f32>, i: u32) -> vec3<f32> {
    let l = diffuse_cone_local(i);
    let basis = cone_basis(n);
    return normalize(basis[0] * l.x + n * l.y + basis[1] * l.z);
}
