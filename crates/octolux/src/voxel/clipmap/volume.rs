//! The GPU object: [`Clipmap`] holds the levels' buffers (albedo and opacity, normals,
//! emission, optional directional values and injected radiance), the resident scene and the
//! pipelines that voxelise, filter and light it. This file makes it and brings its levels to
//! the camera ([`Clipmap::follow`]); the scene it voxelises is managed in `scene.rs`, the
//! revoxelisation in `revoxelise.rs` and `filter.rs`, the light injection in `inject.rs`.

use super::boxes::{boxes_touching, exposed_boxes, uncovered_boxes};
use super::index::TriangleIndex;
use super::inject::Injection;
use super::revoxelise::{Scratch, UpdateStats, ACCUM_BYTES, ACCUM_WORDS};
use super::{ClipmapOptions, ClipmapSettings, UpdateBox, OWNER};
use crate::gpu::alloc::storage;
use crate::gpu::shader::library_shader;
use crate::gpu::{read_buffer, read_words, GpuContext, PassTimer};
use crate::voxel::voxelize::upload_triangles;
use crate::voxel::VoxelTriangle;
use crate::{Error, Result};
use glam::{IVec3, Vec3};

/// A voxel clipmap on the GPU.
pub struct Clipmap {
    /// Ledger owner of its buffers.
    pub(super) owner: &'static str,
    /// Dimensions.
    pub settings: ClipmapSettings,
    /// Per level, the first voxel it covers (world-voxel coordinates), once updated.
    pub origins: Vec<Option<IVec3>>,
    /// The voxels: `levels * resolution^3` RGBA8 words, level after level, toroidal.
    pub voxels: wgpu::Buffer,
    /// Averaged unit normal per voxel (snorm8 x3), same layout as `voxels`.
    pub normals: wgpu::Buffer,
    /// Mean emitted radiance per voxel (RGB9E5 words, [`super::decode_emission`]), same layout
    /// as `voxels`; on filtered levels premultiplied by coverage like the albedo.
    pub emission: wgpu::Buffer,
    /// Injected radiance, once [`Clipmap::inject`] has run: per voxel slot 3 words, RGBA16F
    /// radiance and opacity, then the direction the radiance leaves in (snorm8 x 3, w zero;
    /// [`crate::voxel::facing`], [`super::unpack_facing`]).
    pub radiance: Option<wgpu::Buffer>,
    /// How coarser levels are built.
    pub options: ClipmapOptions,
    /// With [`ClipmapOptions::anisotropic`]: per voxel slot of levels 1 and up (level after
    /// level from level 1, toroidal), 6 RGBA8 words, for travel along +x, -x, +y, -y, +z, -z.
    pub aniso: Option<wgpu::Buffer>,
    /// Bound where a pass's optional buffer (directional values, bounce light) is absent.
    pub(super) placeholder: wgpu::Buffer,
    /// Level filtering (`filter.wgsl`): coarser voxels from finer ones, and the copy of
    /// isotropic values into the directional ones.
    pub(super) filter: wgpu::ComputePipeline,
    pub(super) replicate: wgpu::ComputePipeline,
    /// The light injections' pipelines, parameters and bind groups.
    pub(super) injection: Injection,
    /// Voxelization (`update.wgsl`): per-voxel sums of one box, their resolve into the
    /// levels, and the count of voxels written.
    pub(super) accum: wgpu::Buffer,
    pub(super) written: wgpu::Buffer,
    pub(super) accumulate: wgpu::ComputePipeline,
    pub(super) resolve: wgpu::ComputePipeline,
    /// Statistics of the last revoxelisation, and of the work done since (scene uploads).
    pub(super) stats: UpdateStats,
    pub(super) acc: UpdateStats,
    /// The resident scene: its triangles on the CPU, their bounds' index and their GPU copy
    /// (at least one element); `has_scene` once [`Clipmap::set_scene`] ran.
    pub(super) scene: Vec<VoxelTriangle>,
    pub(super) has_scene: bool,
    pub(super) index: TriangleIndex,
    pub(super) triangles: wgpu::Buffer,
    /// Scratch kept across updates: triangle pieces, work items, box parameters.
    pub(super) scratch: Scratch,
    /// Boxes queued by [`Clipmap::replace_triangles`].
    pub(super) pending: Vec<UpdateBox>,
    /// Every box the last revoxelisation rewrote (camera motion and moving objects).
    pub(super) revoxelised: Vec<UpdateBox>,
    /// Indirect irradiance per voxel slot that the injection adds to the direct irradiance
    /// (multiple bounces; [`Clipmap::set_bounce`]).
    pub(super) bounce: Option<wgpu::Buffer>,
}

impl Clipmap {
    /// Allocates an empty clipmap with per-level voxelization.
    pub fn new(ctx: &GpuContext, settings: ClipmapSettings) -> Result<Clipmap> {
        Self::with_options(ctx, settings, ClipmapOptions::default())
    }

    /// Allocates an empty clipmap built as `options` say.
    pub fn with_options(
        ctx: &GpuContext,
        settings: ClipmapSettings,
        options: ClipmapOptions,
    ) -> Result<Clipmap> {
        Self::with_owner(ctx, settings, options, OWNER)
    }

    /// [`Clipmap::with_options`] with its memory recorded in the ledger under `owner` (a
    /// technique that owns the clipmap) instead of `clipmap`.
    pub fn with_owner(
        ctx: &GpuContext,
        settings: ClipmapSettings,
        options: ClipmapOptions,
        owner: &'static str,
    ) -> Result<Clipmap> {
        settings.validate()?;
        let res = settings.resolution as u64;
        let bytes = settings.slots() * 4;
        if bytes > ctx.device.limits().max_storage_buffer_binding_size {
            return Err(Error::InvalidArgument(format!(
                "a clipmap of {} levels of {}^3 needs {bytes} bytes, more than this GPU can \
                 bind",
                settings.levels, settings.resolution
            )));
        }
        let aniso_bytes = (settings.levels as u64 - 1) * res * res * res * 24;
        if options.anisotropic && aniso_bytes > ctx.device.limits().max_storage_buffer_binding_size
        {
            return Err(Error::InvalidArgument(format!(
                "anisotropic voxels for {} levels of {}^3 need {aniso_bytes} bytes, more than \
                 this GPU can bind",
                settings.levels, settings.resolution
            )));
        }
        // The accumulation scratch holds at least one z layer of a level, at most ACCUM_BYTES.
        let accum_voxels = (ACCUM_BYTES / (ACCUM_WORDS * 4))
            .min(res * res * res)
            .max(res * res);
        let update = ctx.shader("clipmap", &library_shader("voxel/clipmap/update", &[]));
        let filter = ctx.shader(
            "clipmap filter",
            &library_shader("voxel/clipmap/filter", &[]),
        );
        Ok(Clipmap {
            settings,
            origins: vec![None; settings.levels as usize],
            voxels: storage(ctx, owner, "voxels", bytes),
            normals: storage(ctx, owner, "normals", bytes),
            emission: storage(ctx, owner, "emission", bytes),
            radiance: None,
            options,
            aniso: (options.anisotropic && aniso_bytes > 0)
                .then(|| storage(ctx, owner, "anisotropic voxels", aniso_bytes)),
            placeholder: storage(ctx, owner, "no anisotropic voxels", 16),
            filter: ctx.compute_pipeline("clipmap filter", &filter, "filter_level"),
            replicate: ctx.compute_pipeline("clipmap replicate", &filter, "replicate"),
            injection: Injection::new(ctx, owner),
            accum: storage(
                ctx,
                owner,
                "accumulation scratch",
                accum_voxels * ACCUM_WORDS * 4,
            ),
            written: storage(ctx, owner, "written counter", 16),
            accumulate: ctx.compute_pipeline("clipmap accumulate", &update, "accumulate"),
            resolve: ctx.compute_pipeline("clipmap resolve", &update, "resolve"),
            stats: UpdateStats::default(),
            acc: UpdateStats::default(),
            scene: Vec::new(),
            has_scene: false,
            index: TriangleIndex::default(),
            triangles: upload_triangles(ctx, owner, &[]),
            scratch: Scratch::new(ctx, owner),
            pending: Vec::new(),
            revoxelised: Vec::new(),
            bounce: None,
            owner,
        })
    }

    /// Bytes the clipmap keeps on the GPU: albedo/opacity, normals and emission (4 + 4 + 4
    /// bytes per voxel), with anisotropic voxels 24 bytes per voxel of levels 1 and up, and,
    /// once light has been injected, radiance (8 bytes per voxel). The accumulation scratch is
    /// reported separately in the ledger.
    pub fn bytes(&self) -> u64 {
        self.voxels.size()
            + self.normals.size()
            + self.emission.size()
            + self.aniso.as_ref().map_or(0, |a| a.size())
            + self.radiance.as_ref().map_or(0, |r| r.size())
    }

    /// Brings every level to the camera position `camera`, revoxelising only the voxels the
    /// levels did not cover before (everything on the first call). Passes are recorded into
    /// `timer` as `clipmap L<l>`. Returns the boxes revoxelised.
    ///
    /// `tris` becomes the clipmap's scene ([`Clipmap::set_scene`]) when it differs from it; a
    /// scene that differs in a few triangles only has those replaced (as
    /// [`Clipmap::replace_triangles`] does, but without revoxelising the regions they left and
    /// entered). Comparing costs one pass over `tris`; [`Clipmap::follow`] skips it.
    pub fn update(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        tris: &[VoxelTriangle],
        camera: Vec3,
    ) -> Result<Vec<UpdateBox>> {
        if !camera.is_finite() {
            return Err(Error::InvalidArgument(format!("camera position {camera}")));
        }
        self.sync_scene(ctx, tris);
        self.follow(ctx, timer, camera)
    }

    /// [`Clipmap::update`] with the clipmap's own scene ([`Clipmap::set_scene`],
    /// [`Clipmap::replace_triangles`]): the per-frame call for a moving camera. Also
    /// revoxelises the boxes that [`Clipmap::replace_triangles`] queued since the last
    /// revoxelisation (clipped to the levels' new extents). Returns the boxes revoxelised for
    /// the camera's motion.
    pub fn follow(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        camera: Vec3,
    ) -> Result<Vec<UpdateBox>> {
        if !camera.is_finite() {
            return Err(Error::InvalidArgument(format!("camera position {camera}")));
        }
        let res = self.settings.resolution as i32;
        let old = self.origins.clone();
        let mut boxes = Vec::new();
        for l in 0..self.settings.levels {
            let new = self.settings.level_origin(l, camera);
            boxes.extend(exposed_boxes(l, old[l as usize], new, res));
            self.origins[l as usize] = Some(new);
        }
        if self.options.filters() {
            boxes.extend(uncovered_boxes(&self.settings, &old, &self.origins));
        }
        self.revoxelise_boxes(ctx, timer, &boxes)?;
        Ok(boxes)
    }

    /// The boxes of every level that cover the world-space box `[lo, hi]` (with one voxel of
    /// margin, since touching counts), clipped to each level's current extent. For a moving
    /// object, revoxelise the boxes of its old and of its new bounds (or use
    /// [`Clipmap::replace_triangles`], which does).
    pub fn boxes_touching(&self, lo: Vec3, hi: Vec3) -> Vec<UpdateBox> {
        boxes_touching(&self.settings, &self.origins, lo, hi)
    }

    /// Every box (of its level, inside the level's extent) that the last [`Clipmap::update`],
    /// [`Clipmap::follow`] or [`Clipmap::revoxelise`] rewrote: the camera's exposed slabs and
    /// the regions moving objects left and entered. Whatever a caller keeps per voxel slot is
    /// stale there (a wrapped slot now holds another voxel, or the voxel changed).
    pub fn last_revoxelised(&self) -> &[UpdateBox] {
        &self.revoxelised
    }

    /// CPU cost and size of the last [`Clipmap::update`] or [`Clipmap::revoxelise`].
    pub fn last_update_stats(&self) -> UpdateStats {
        self.stats
    }

    /// Multiple bounces: from now on both injections add `bounce` (per voxel slot, layout of
    /// [`Clipmap::voxels`], RGBA16F indirect irradiance in W/m^2, alpha unused; at least 8
    /// bytes per slot) to each voxel's direct irradiance, so its outgoing radiance is
    /// emission + albedo / pi x (direct + indirect). `None` stops it.
    pub fn set_bounce(&mut self, bounce: Option<wgpu::Buffer>) -> Result<()> {
        let needed = self.settings.slots() * 8;
        if let Some(b) = &bounce {
            if b.size() < needed {
                return Err(Error::InvalidArgument(format!(
                    "clipmap bounce buffer of {} bytes, {needed} needed",
                    b.size()
                )));
            }
        }
        self.bounce = bounce;
        Ok(())
    }

    /// Voxels written by all updates so far (read from the GPU counter). Blocks.
    pub fn voxels_written(&self, ctx: &GpuContext) -> Result<u32> {
        let bytes = read_buffer(ctx, &self.written, 0, 4)?;
        Ok(bytemuck::cast_slice::<u8, u32>(&bytes)[0])
    }

    /// Reads all voxels back (RGBA8 words, level after level, toroidal order). Blocks.
    pub fn read_voxels(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        read_words(ctx, &self.voxels)
    }

    /// Reads the averaged normals back (snorm8 x 3 words, [`super::unpack_facing`] decodes
    /// them; layout of `voxels`). Blocks.
    pub fn read_normals(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        read_words(ctx, &self.normals)
    }

    /// Reads the emission back (RGB9E5 words, [`super::decode_emission`], layout of
    /// `voxels`). Blocks.
    pub fn read_emission(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        read_words(ctx, &self.emission)
    }

    /// Reads the directional values back ([`Clipmap::aniso`]; empty without them). Blocks.
    pub fn read_aniso(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        match &self.aniso {
            Some(aniso) => read_words(ctx, aniso),
            None => Ok(Vec::new()),
        }
    }
}
