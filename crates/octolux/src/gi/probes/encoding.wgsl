// Probe irradiance encodings (gi/probes/encoding.rs, CPU twins `Encoding::add` and
// `Encoding::irradiance`). kind 0: 004's 8 octahedron-facet bins (bin k = irradiance facing
// facet normal k, blended trilinearly on the cube of facet normals); kind 1: SH L1 of radiance,
// irradiance by the cosine lobe's band factors.

import octolux::frame::common::PI;

const SH_Y0: f32 = 0.282095;
const SH_Y1: f32 = 0.488603;
const INV_SQRT3: f32 = 0.57735027;

// Facet normal k (unnormalised): bit 0, 1, 2 set = +x, +y, +z.
fn probe_facet(k: u32) -> vec3<f32> {
    return vec3<f32>(select(-1.0, 1.0, (k & 1u) != 0u), select(-1.0, 1.0, (k & 2u) != 0u), select(-1.0, 1.0, (k & 4u) != 0u));
}

// Adds radiance l from unit direction dir over solid angle dw.
fn probe_encode(kind: u32, c: ptr<function, array<vec3<f32>, 8>>, l: vec3<f32>, dir: vec3<f32>, dw: f32) {
    if kind == 0u {
        for (var k = 0u; k < 8u; k++) {
            (*c)[k] += l * (max(dot(probe_facet(k) * INV_SQRT3, dir), 0.0) * dw);
        }
        return;
    }
    (*c)[0] += l * (SH_Y0 * dw);
    (*c)[1] += l * (SH_Y1 * dir.y * dw);
    (*c)[2] += l * (SH_Y1 * dir.z * dw);
    (*c)[3] += l * (SH_Y1 * dir.x * dw);
}

// Irradiance (W/m^2) for unit normal n.
fn probe_irradiance(kind: u32, c: array<vec3<f32>, 8>, n: vec3<f32>) -> vec3<f32> {
    if kind == 0u {
        let m = n / max(max(abs(n.x), max(abs(n.y), abs(n.z))), 1e-20);
        var e = vec3<f32>(0.0);
        for (var k = 0u; k < 8u; k++) {
            let w = clamp((vec3<f32>(1.0) + probe_facet(k) * m) * 0.5, vec3<f32>(0.0), vec3<f32>(1.0));
            e += c[k] * (w.x * w.y * w.z);
        }
        return e;
    }
    let e = c[0] * (PI * SH_Y0) + (c[1] * (SH_Y1 * n.y) + c[2] * (SH_Y1 * n.z) + c[3] * (SH_Y1 * n.x)) * (2.0 * PI / 3.0);
    return max(e, vec3<f32>(0.0));
}
