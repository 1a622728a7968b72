//! `--gi none`: no indirect light; the indirect image stays zero.

use super::{GiFrame, GiTechnique};
use crate::gpu::{GpuContext, PassTimer};
use crate::Result;

/// The technique that adds nothing.
pub struct NoGi {
    _texture: wgpu::Texture,
    view: wgpu::TextureView,
}

impl NoGi {
    /// A zero indirect-irradiance image of the given size.
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> NoGi {
        // New textures are zero-initialised by wgpu.
        let (texture, view) = super::indirect_target(ctx, "none", width, height);
        NoGi {
            _texture: texture,
            view,
        }
    }
}

impl GiTechnique for NoGi {
    fn name(&self) -> &str {
        "none"
    }

    fn update(
        &mut self,
        _ctx: &GpuContext,
        _frame: &GiFrame,
        _timer: &mut PassTimer,
    ) -> Result<()> {
        Ok(())
    }

    fn indirect_view(&self) -> &wgpu::TextureView {
        &self.view
    }

    fn reference_transport(&self) -> crate::transport::Transport {
        // The direct pass lights with the lights and the sky; emissive surfaces are only seen.
        crate::transport::Transport {
            bounces: crate::transport::Bounces::DirectOnly,
            emissive: crate::transport::EmissiveSurfaces::Unlit,
        }
    }
}
