// Irradiance from the probe grid (grid.wgsl goes before it). The includer declares
// `probes: array<vec4<f32>>`.

fn probe_coeffs(probe: u32) -> array<vec3<f32>, 8> {
    let b = probe * PROBE_VEC4;
    return array<vec3<f32>, 8>(probes[b].xyz, probes[b + 1u].xyz, probes[b + 2u].xyz, probes[b + 3u].xyz,
        probes[b + 4u].xyz, probes[b + 5u].xyz, probes[b + 6u].xyz, probes[b + 7u].xyz);
}

// Irradiance at p (unit normal n) from the 8 probes around p + bias n: trilinear weights times
// DDGI's smooth back-face weight ((1 + cos)/2)^2 + 0.2 for the direction to the probe; probes
// inside geometry (too many back-face hits) are left out. CPU twin: `grid_irradiance` in grid.rs.
fn grid_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let q = p + n * P.spacing.w;
    let g = (q - P.lo.xyz) / P.spacing.xyz - 0.5;
    let hi = vec3<i32>(P.dims.xyz) - 2;
    let base = clamp(vec3<i32>(floor(g)), vec3<i32>(0), hi);
    let t = clamp(g - vec3<f32>(base), vec3<f32>(0.0), vec3<f32>(1.0));
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var c = 0u; c < 8u; c++) {
        let off = vec3<u32>(c & 1u, (c >> 1u) & 1u, (c >> 2u) & 1u);
        let coord = vec3<u32>(base) + off;
        let probe = coord.x + P.dims.x * (coord.y + P.dims.y * coord.z);
        if probes[probe * PROBE_VEC4 + 8u].z < 0.5 {
            continue;
        }
        let tri = select(vec3<f32>(1.0) - t, t, off == vec3<u32>(1u));
        let to_probe = probe_position(coord) - p;
        let len = length(to_probe);
        let facing = select(1.0, (dot(to_probe / len, n) + 1.0) * 0.5, len > 1e-6);
        let w = tri.x * tri.y * tri.z * (facing * facing + 0.2);
        sum += w * probe_irradiance(P.misc.y, probe_coeffs(probe), n);
        total += w;
    }
    return select(vec3<f32>(0.0), sum / total, total > 0.0);
}
