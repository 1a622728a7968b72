//! Command-line settings of the GI techniques, shared by `render` and `bench`.

use clap::Args;
use octolux::gi::probes::{Encoding, Lattice};
use octolux::gi::GiSettings;

/// The technique `render` and `view` use when `--gi` is not given, chosen from the error and
/// time measurements in the README ("Global illumination by default").
pub const DEFAULT_GI: &str = octolux::gi::DEFAULT_TECHNIQUE;

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
    /// LPV family and `vpl`: the RSM layers whose light or objects moved since the last frame
    /// at half the side (the LPVs with half the stride: the same VPLs from a quarter of the
    /// texels); those that hold still keep the whole (default true).
    #[arg(long)]
    pub rsm_moving_half: Option<bool>,
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
    /// Cone tracing: voxels per side of each clipmap level, a power of two (default 64).
    #[arg(long)]
    pub vct_resolution: Option<u32>,
    /// Cone tracing: clipmap levels, 1..=8 (default 4).
    #[arg(long)]
    pub vct_levels: Option<u32>,
    /// Cone tracing: diffuse cones per gather, 6 (003's set) or 8..=64; for both techniques and
    /// both gathers, pixels' and voxels' (default: each technique's own: vct-svo 64 per pixel,
    /// vct-clipmap 16, with one bounce 6; 16 for the voxels' bounce gather).
    #[arg(long)]
    pub vct_cones: Option<u32>,
    /// Cone tracing: full aperture of the diffuse cones in degrees; for both techniques and
    /// both gathers (default: each technique's own: vct-svo 18 per pixel, vct-clipmap 36, with
    /// one bounce 60; for the voxels' bounce gather vct-svo 18, vct-clipmap 36).
    #[arg(long)]
    pub vct_aperture: Option<f32>,
    /// Cone tracing: step as a fraction of the cone's footprint (default 0.5).
    #[arg(long)]
    pub vct_step: Option<f32>,
    /// Cone tracing: apex offset of the diffuse cones off the surface, in voxels of its level;
    /// for both techniques and both gathers (default: each technique's own, 2; vct-clipmap
    /// with one bounce 1.5).
    #[arg(long)]
    pub vct_start: Option<f32>,
    /// Cone tracing: accumulated opacity at which a cone stops (default 0.95).
    #[arg(long)]
    pub vct_stop_opacity: Option<f32>,
    /// Cone tracing (vct-clipmap): visibility for the light injection, `shadow-maps` (the
    /// renderer's, default) or `voxel-rays` (marched through the clipmap).
    #[arg(long)]
    pub vct_injection: Option<octolux::gi::vct::ClipmapInjection>,
    /// Cone tracing: samples per shadow ray of the voxel-ray injection (default 256).
    #[arg(long)]
    pub vct_inject_steps: Option<u32>,
    /// Cone tracing: trace one pixel per N x N block and reconstruct the others (1..=16; 1
    /// traces every pixel; default 0: from the image height, 4 below 225 rows, 8 at 360, 16 from
    /// 720).
    #[arg(long)]
    pub vct_sparse: Option<u32>,
    /// Cone tracing (vct-svo): voxels per side of the octree's grid, a power of two from 16
    /// to 512 (default 128).
    #[arg(long)]
    pub vct_octree_resolution: Option<u32>,
    /// Cone tracing (vct-svo): nodes reserved for the animated objects' voxels (default 65536).
    #[arg(long)]
    pub vct_dynamic_reserve: Option<u32>,
    /// Cone tracing (vct-svo): read the octree's radiance per travel direction (6 values per
    /// node), `true` or `false` (default: isotropic, scaled by the footprint).
    #[arg(long)]
    pub vct_anisotropic: Option<bool>,
    /// vct-svo: only the voxels' bounce gather reads the anisotropic radiance (default false;
    /// docs/vct.md, "Anisotropic radiance in the bounce only").
    #[arg(long)]
    pub vct_anisotropic_bounce: Option<bool>,
    /// Cone tracing: keep the direction the voxels' radiance leaves in (octree or clipmap), so
    /// a cone does not see the light on the far face of a thin wall, nor the sunlit outside of
    /// a building from inside (default true; docs/vct.md, "The radiance's facing").
    #[arg(long)]
    pub vct_facing: Option<bool>,
    /// Cone tracing: multiple bounces through the voxels (octree or clipmap), converging over
    /// frames, `true` (default) or `false` (one bounce).
    #[arg(long)]
    pub vct_multi_bounce: Option<bool>,
    /// Cone tracing, multiple bounces: spread one round of the voxels' bounce gather over N
    /// frames, 1..=8 (default 2; 1: every voxel gathers every frame).
    #[arg(long)]
    pub vct_bounce_frames: Option<u32>,
    /// Cone tracing: also trace one specular cone per pixel (`--output specular` shows it).
    #[arg(long)]
    pub vct_specular: bool,
    /// Cone tracing: roughness of the specular cone, 0..=1 (default 0.3).
    #[arg(long)]
    pub vct_roughness: Option<f32>,
    /// Cone tracing: the specular cone takes exactly N samples from the finest voxel on and
    /// never stops early: fixed work for timing the structures (default 0: off).
    #[arg(long)]
    pub vct_specular_steps: Option<u32>,
    /// VPL GI: number of VPLs (default 1024).
    #[arg(long)]
    pub vpl_count: Option<u32>,
    /// VPL GI: interleave factor, I x I sub-images with 1/I^2 of the VPLs each (default 4).
    #[arg(long)]
    pub vpl_interleave: Option<u32>,
    /// VPL GI: distance clamp of the geometry term in octree voxels (default 2); each VPL is also bounded as a disk of the area it stands for.
    #[arg(long)]
    pub vpl_clamp: Option<f32>,
    /// VPL GI: voxels per side of the visibility octree, a power of two (default 128).
    #[arg(long)]
    pub vpl_resolution: Option<u32>,
    /// VPL GI: RSM side in texels, a power of two (default 256).
    #[arg(long)]
    pub vpl_rsm_size: Option<u32>,
    /// VPL GI: offset of the shadow-ray ends along their normals, in voxels (default 1.75).
    #[arg(long)]
    pub vpl_end_offset: Option<f32>,
    /// VPL GI: skip VPLs contributing at most this irradiance (W/m^2) before their ray
    /// (default 0).
    #[arg(long)]
    pub vpl_cull: Option<f32>,
    /// VPL GI: Russian roulette on shadow rays, 0..=16 (0: off): a VPL below this many times
    /// the mean contribution of the pixel's VPLs traces its ray with probability contribution
    /// / threshold, weighted by the inverse (unbiased; default 2).
    #[arg(long)]
    pub vpl_roulette: Option<f32>,
    /// VPL GI: geometry-aware merge of the sub-images (default true).
    #[arg(long)]
    pub vpl_filter: Option<bool>,
    /// VPL GI: sparse shading, one shaded pixel per N x N block, the others reconstructed
    /// (1..=16; 1 shades every pixel; default 0: from the image height, at least 135 shaded
    /// rows and at most 8: 1 below 270 rows, 2 at 360, 5 at 720, 8 from 1080).
    #[arg(long)]
    pub vpl_sparse: Option<u32>,
    /// Probes: probes per axis of the uniform grid, 2..=128 (default 21: 9261 probes).
    #[arg(long)]
    pub probes_grid: Option<u32>,
    /// Probes: surfels (rays) per probe, 8..=1024; a multiple of 8 on the lat-long lattice
    /// (default 64 for probes-grid, 128 for probes-octree).
    #[arg(long)]
    pub probes_surfels: Option<u32>,
    /// Probes: direction lattice, `fibonacci` or `lat-long` (default fibonacci).
    #[arg(long, value_parser = parse_lattice)]
    pub probes_lattice: Option<Lattice>,
    /// Probes: irradiance encoding, `sh1` or `octahedron` (004's 8 bins) (default sh1).
    #[arg(long, value_parser = parse_encoding)]
    pub probes_encoding: Option<Encoding>,
    /// Probes: surfels also receive the probes' light, one more bounce per frame (default
    /// true).
    #[arg(long)]
    pub probes_multi_bounce: Option<bool>,
    /// Probes: frames each probe's value is the mean of, its rays turned anew every frame,
    /// 0..=1024 (0: one fixed lattice, no history; default 32).
    #[arg(long)]
    pub probes_history: Option<u32>,
    /// Probe octree: deepest level, 2..=5 (default 4); each level halves the probe spacing and
    /// costs 8x the probe slots (3 is too coarse for large interiors such as Sponza:
    /// docs/probes.md, "Probe spacing and freeing on large scenes").
    #[arg(long)]
    pub probes_max_depth: Option<u32>,
    /// Probe octree: levels complete down to this depth (always split above it, keep the
    /// probes down to it), 0..=max depth; 0 is 004's rule (default 3).
    #[arg(long)]
    pub probes_min_depth: Option<u32>,
    /// Probe octree: probe slots, the budget of its buffers; 0 = the full tree of the max depth
    /// (default 2048; a split that finds no free slot waits, the leaf keeps its probe).
    #[arg(long)]
    pub probes_max_probes: Option<u32>,
    /// Probe octree: share of a probe's surfels inside its cube from which its leaf splits
    /// (default 0.25; `004`: 0.5).
    #[arg(long)]
    pub probes_split_fraction: Option<f32>,
    /// Probe octree: share of a probe's surfels inside its cube below which it is freed
    /// (default 0: none is freed; 004's rule is 0.25).
    #[arg(long)]
    pub probes_free_fraction: Option<f32>,
    /// Probe octree: how pixels read the probes, `octree` (the leaves around the pixel) or
    /// `all` (004's loop over every probe) (default octree).
    #[arg(long)]
    pub probes_gather: Option<octolux::gi::probes::OctreeGather>,
    /// Probe octree: which surfels light a probe, `scene` (every hit) or `cube` (only hits
    /// inside its leaf's cube, as 004) (default scene).
    #[arg(long)]
    pub probes_surfel_range: Option<octolux::gi::probes::SurfelRange>,
    /// Probes: `moments` weighs each probe by DDGI's Chebyshev visibility from its depth
    /// moments, against leaks through thin walls; `none` does not (default moments).
    #[arg(long)]
    pub probes_visibility: Option<octolux::gi::probes::Visibility>,
    /// Probes: what the surfel rays run through, `bvh` (the scene's triangles, exact) or
    /// `voxels` (the scene's sparse voxel octree, exact to a voxel) (default bvh).
    #[arg(long)]
    pub probes_rays: Option<octolux::gi::probes::RayBackend>,
    /// Probes with `--probes-rays voxels`: voxels per side of the octree, a power of two in
    /// 16..=1024 (default 128).
    #[arg(long)]
    pub probes_voxel_resolution: Option<u32>,
    /// Probes: offset of the gather point along the surface normal, in probe spacings (the
    /// octree's: its finest cell), 0..=1 (default 0.2).
    #[arg(long)]
    pub probes_normal_bias: Option<f32>,
    /// Probes: share of a probe's rays that may hit back faces before it counts as inside
    /// geometry and is left out of the gather, 0..=1 (default 0.25).
    #[arg(long)]
    pub probes_backface_limit: Option<f32>,
    /// VPL GI: light bounces, 1..=3; later bounces are spawned through the octree (default 1).
    #[arg(long)]
    pub vpl_bounces: Option<u32>,
}

fn parse_lattice(name: &str) -> Result<Lattice, String> {
    Lattice::from_name(name).ok_or_else(|| format!("'{name}': expected fibonacci or lat-long"))
}

fn parse_encoding(name: &str) -> Result<Encoding, String> {
    Encoding::from_name(name).ok_or_else(|| format!("'{name}': expected sh1 or octahedron"))
}

impl GiArgs {
    /// Applies the flags that were given to `settings`.
    pub fn apply(&self, settings: &mut GiSettings) {
        let lpv = &mut settings.lpv;
        set(&mut lpv.size, self.lpv_size);
        set(&mut lpv.iterations, self.lpv_iterations);
        set(&mut lpv.rsm_size, self.rsm_size);
        set(&mut lpv.rsm_stride, self.rsm_stride);
        set(&mut lpv.rsm_moving_half, self.rsm_moving_half);
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
        let vct = &mut settings.vct;
        set(&mut vct.resolution, self.vct_resolution);
        set(&mut vct.levels, self.vct_levels);
        // The diffuse cones' settings are optional (None: each technique's own default); a
        // flag given sets them for both techniques.
        set(&mut vct.cones, self.vct_cones.map(Some));
        set(&mut vct.aperture, self.vct_aperture.map(Some));
        set(&mut vct.step, self.vct_step);
        set(&mut vct.start, self.vct_start.map(Some));
        set(&mut vct.stop_opacity, self.vct_stop_opacity);
        set(&mut vct.injection, self.vct_injection);
        set(&mut vct.inject_steps, self.vct_inject_steps);
        set(&mut vct.sparse, self.vct_sparse);
        set(&mut vct.octree_resolution, self.vct_octree_resolution);
        set(&mut vct.dynamic_reserve, self.vct_dynamic_reserve);
        set(&mut vct.anisotropic, self.vct_anisotropic);
        set(&mut vct.anisotropic_bounce, self.vct_anisotropic_bounce);
        set(&mut vct.facing, self.vct_facing);
        set(&mut vct.roughness, self.vct_roughness);
        set(&mut vct.specular_steps, self.vct_specular_steps);
        set(&mut vct.multi_bounce, self.vct_multi_bounce);
        set(&mut vct.bounce_frames, self.vct_bounce_frames);
        if self.vct_specular {
            vct.specular = true;
        }
        let vpl = &mut settings.vpl;
        set(&mut vpl.count, self.vpl_count);
        set(&mut vpl.interleave, self.vpl_interleave);
        set(&mut vpl.clamp, self.vpl_clamp);
        set(&mut vpl.resolution, self.vpl_resolution);
        set(&mut vpl.rsm_size, self.vpl_rsm_size);
        set(&mut vpl.end_offset, self.vpl_end_offset);
        set(&mut vpl.cull, self.vpl_cull);
        set(&mut vpl.roulette, self.vpl_roulette);
        set(&mut vpl.filter, self.vpl_filter);
        set(&mut vpl.sparse, self.vpl_sparse);
        set(&mut vpl.bounces, self.vpl_bounces);
        set(&mut vpl.rsm_moving_half, self.rsm_moving_half);
        let probes = &mut settings.probes;
        set(&mut probes.grid, self.probes_grid.map(|n| [n; 3]));
        set(&mut probes.surfels, self.probes_surfels.map(Some));
        set(&mut probes.lattice, self.probes_lattice);
        set(&mut probes.encoding, self.probes_encoding);
        if let Some(on) = self.probes_multi_bounce {
            probes.multi_bounce = Some(on);
        }
        set(&mut probes.history, self.probes_history);
        set(&mut probes.max_depth, self.probes_max_depth);
        set(&mut probes.min_depth, self.probes_min_depth);
        set(&mut probes.max_probes, self.probes_max_probes);
        set(&mut probes.split_fraction, self.probes_split_fraction);
        set(&mut probes.free_fraction, self.probes_free_fraction);
        set(&mut probes.gather, self.probes_gather);
        set(&mut probes.surfel_range, self.probes_surfel_range);
        set(&mut probes.visibility, self.probes_visibility);
        set(&mut probes.rays, self.probes_rays);
        set(&mut probes.voxel_resolution, self.probes_voxel_resolution);
        set(&mut probes.normal_bias, self.probes_normal_bias);
        set(&mut probes.backface_limit, self.probes_backface_limit);
    }
}

fn set<T>(field: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *field = v;
    }
}
