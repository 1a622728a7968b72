// One virtual point light as the generation, the bounces and the shading share it (`GpuVpl` in
// gi/vpl/generate.rs, which decodes it for the tests).
struct Vpl {
    position: vec3<f32>,
    // The surface area it stands for, m^2 (0 for a bounce VPL: bounded by the clamp alone).
    area: f32,
    // Unit normal, facing the light.
    normal: vec3<f32>,
    _pad: u32,
    // Flux, W.
    flux: vec3<f32>,
    // Mean of the flux's channels.
    mean_flux: f32,
};
