//! Command-line settings of the GI techniques, shared by `render` and `bench`.

use clap::Args;
use octolux::gi::GiSettings;

/// The technique `render` and `view` use when `--gi` is not given, chosen from the error and
/// time measurements in the README ("Global illumination by default").
pub const DEFAULT_GI: &str = "lpv";

/// Per-technique settings; each flag overrides the scene file's `[settings]` and the default.
#[derive(Args, Debug, Clone, Default)]
pub struct GiArgs {
    /// LPV: cells per side of the uniform volume (default 32).
    #[arg(long)]
    pub lpv_size: Option<u32>,
    /// LPV: propagation iterations (default 32).
    #[arg(long)]
    pub lpv_iterations: Option<u32>,
    /// LPV family: reflective shadow map side in texels (default 512).
    #[arg(long)]
    pub rsm_size: Option<u32>,
    /// LPV family: RSM texels per VPL side, one VPL per stride^2 block (default 4).
    #[arg(long)]
    pub rsm_stride: Option<u32>,
    /// LPV family: damping against light leaks at lookup, 0 = off (default 0).
    #[arg(long)]
    pub lpv_damping: Option<f32>,
    /// LPV family: share 0..1 of the light crossing a cell face that keeps its direction; the
    /// rest is re-emitted as a Lambertian lobe about the face (default 1).
    #[arg(long)]
    pub lpv_directional: Option<f32>,
    /// LPV family: scale of the indirect irradiance (default 1).
    #[arg(long)]
    pub lpv_gain: Option<f32>,
    /// LPV family: occlusion by the geometry volume (default true).
    #[arg(long)]
    pub lpv_occlusion: Option<bool>,
    /// LPV family: sky lights that get a reflective shadow map (default 8).
    #[arg(long)]
    pub lpv_sky_rsms: Option<u32>,
    /// Cascaded LPV: number of cascades (default 3).
    #[arg(long)]
    pub lpv_cascades: Option<u32>,
    /// Cascaded LPV: cells per side of each cascade (default 32).
    #[arg(long)]
    pub clpv_size: Option<u32>,
    /// Cascaded LPV: propagation iterations per cascade (default 32).
    #[arg(long)]
    pub clpv_iterations: Option<u32>,
    /// Octree LPV: side of level 0, a power of two (default 32).
    #[arg(long)]
    pub olpv_size: Option<u32>,
    /// Octree LPV: propagation iterations per level (default 16).
    #[arg(long)]
    pub olpv_iterations: Option<u32>,
}

impl GiArgs {
    /// Applies the flags that were given to `settings`.
    pub fn apply(&self, settings: &mut GiSettings) {
        let lpv = &mut settings.lpv;
        set(&mut lpv.size, self.lpv_size);
        set(&mut lpv.iterations, self.lpv_iterations);
        set(&mut lpv.rsm_size, self.rsm_size);
        set(&mut lpv.rsm_stride, self.rsm_stride);
        set(&mut lpv.damping, self.lpv_damping);
        set(&mut lpv.directional, self.lpv_directional);
        set(&mut lpv.gain, self.lpv_gain);
        set(&mut lpv.occlusion, self.lpv_occlusion);
        set(&mut lpv.sky_rsms, self.lpv_sky_rsms);
        let clpv = &mut settings.clpv;
        set(&mut clpv.cascades, self.lpv_cascades);
        set(&mut clpv.size, self.clpv_size);
        set(&mut clpv.iterations, self.clpv_iterations);
        let olpv = &mut settings.olpv;
        set(&mut olpv.size, self.olpv_size);
        set(&mut olpv.iterations, self.olpv_iterations);
    }
}

fn set<T>(field: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *field = v;
    }
}
