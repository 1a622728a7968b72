//! What octolux needs of a caller's device: no optional feature (it uses `TIMESTAMP_QUERY`
//! where the device has it) and limits above WebGPU's defaults where its passes bind more.

use crate::{Error, Result};

/// Features a device must have for octolux: none. `TIMESTAMP_QUERY` gives per-pass GPU times
/// when present.
pub fn required_features() -> wgpu::Features {
    wgpu::Features::empty()
}

/// The limits octolux's passes need: WebGPU's defaults, raised where a pass binds more storage
/// buffers or textures, or a larger storage buffer, than they allow. Request at least these
/// (`adapter.limits()` is simplest) when creating the device. Techniques with large settings
/// check their own buffers against the device's `max_storage_buffer_binding_size` and say
/// which setting to lower.
pub fn required_limits() -> wgpu::Limits {
    wgpu::Limits {
        // vct-svo's light injection with the radiance's facing (its default) binds 22
        // (`gi::vct::FACING_STORAGE_BUFFERS`; tests/embed.rs checks that they agree).
        max_storage_buffers_per_shader_stage: 22,
        ..wgpu::Limits::default()
    }
}

/// Checks that `device` has [`required_features`] and [`required_limits`]; the error names
/// every one it lacks with the value it has and the value needed.
pub fn check_device(device: &wgpu::Device) -> Result<()> {
    let mut missing = Vec::new();
    let features = required_features() - device.features();
    if !features.is_empty() {
        missing.push(format!("features {features:?}"));
    }
    required_limits().check_limits_with_fail_fn(&device.limits(), false, |name, needed, has| {
        missing.push(format!("{name} is {has}, octolux needs {needed}"));
    });
    if missing.is_empty() {
        return Ok(());
    }
    Err(Error::InvalidArgument(format!(
        "this device lacks what octolux needs: {}. Create it with at least \
         octolux::embed::required_limits() (or the adapter's own limits)",
        missing.join("; ")
    )))
}
