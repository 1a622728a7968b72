//! Light injection: every occupied voxel gets outgoing radiance emission + albedo / pi x its
//! direct irradiance (plus, with multiple bounces, the indirect irradiance of
//! [`Clipmap::set_bounce`]), as RGBA16F per voxel slot, and the direction that radiance leaves
//! in (its facing, [`crate::voxel::facing`]) as snorm8 x 3 ([`Clipmap::radiance`]). Visibility
//! comes from marching the clipmap's own opacity towards each light ([`Clipmap::inject`],
//! `inject.wgsl`) or from the renderer's shadow maps ([`Clipmap::inject_shadow_maps`],
//! `inject_shadow.wgsl`); both store through `inject_common.wgsl`, whose CPU twins are
//! [`injected_radiance`] and [`injected_facing`].
//!
//! Parameters are written with [`wgpu::Queue::write_buffer`], which lands at the submission,
//! so each injection recorded before one takes the next of [`INJECT_SLOTS`] slots.

use super::sample::{ClipInfo, CLIP_BINDINGS};
use super::{decode_emission, Clipmap};
use crate::frame::GpuLight;
use crate::gpu::alloc::{param_slots, storage};
use crate::gpu::pass::{dispatch_1d, KeptBindGroup};
use crate::gpu::shader::library_shader;
use crate::gpu::{read_words, GpuContext, PassTimer};
use crate::scene::Light;
use crate::{Error, Result};
use glam::{Vec3, Vec4};

/// Light injections recorded before one submission (each writes its parameters to its own
/// slot).
const INJECT_SLOTS: u64 = 4;
/// Lights per step of the light buffer's slots (16 x 80 bytes keeps offsets 256-byte aligned).
const INJECT_LIGHT_ALIGN: u64 = 16;
const _: () = assert!((INJECT_LIGHT_ALIGN * INJECT_LIGHT_BYTES).is_multiple_of(256));
/// Bytes of one light ([`GpuLight`], unshadowed: the march finds the visibility).
const INJECT_LIGHT_BYTES: u64 = crate::frame::LIGHT_BYTES;

/// Parameter block `InjectParams` of `inject_common.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct InjectParams {
    /// Lights to inject.
    pub lights: u32,
    /// Most march steps per shadow ray (voxel rays only).
    pub max_steps: u32,
    /// Voxel slots (`levels * resolution^3`).
    pub slots: u32,
    /// 1 when the bounce buffer holds indirect irradiance to add (multiple bounces).
    pub bounce: u32,
}

/// The two injections: voxel shadow rays and shadow maps.
#[derive(Clone, Copy)]
enum Variant {
    VoxelRays = 0,
    ShadowMaps = 1,
}

impl Variant {
    fn name(self) -> &'static str {
        match self {
            Variant::VoxelRays => "clipmap inject",
            Variant::ShadowMaps => "clipmap inject (shadow maps)",
        }
    }
}

/// The injections' state: pipelines (each made at its first use), the parameter and
/// sampling blocks in [`INJECT_SLOTS`] slots, the voxel-ray injection's lights (a slot of
/// `light_room` lights each), the timer submission and slots used so far, and the bind groups
/// per variant and slot.
pub(super) struct Injection {
    pipelines: [Option<wgpu::ComputePipeline>; 2],
    params: wgpu::Buffer,
    info: wgpu::Buffer,
    lights: wgpu::Buffer,
    light_room: u64,
    used: (u64, u64),
    groups: Vec<KeptBindGroup>,
}

impl Injection {
    pub(super) fn new(ctx: &GpuContext, owner: &str) -> Injection {
        Injection {
            pipelines: [None, None],
            params: param_slots(ctx, owner, "inject params", INJECT_SLOTS),
            info: param_slots(ctx, owner, "inject info", INJECT_SLOTS),
            lights: light_buffer(ctx, owner, INJECT_LIGHT_ALIGN),
            light_room: INJECT_LIGHT_ALIGN,
            used: (u64::MAX, 0),
            groups: (0..2 * INJECT_SLOTS).map(|_| Default::default()).collect(),
        }
    }

    /// The pipeline of `variant`, made at its first use.
    fn pipeline(&mut self, ctx: &GpuContext, variant: Variant) -> wgpu::ComputePipeline {
        let made = &mut self.pipelines[variant as usize];
        made.get_or_insert_with(|| {
            let (module, entry) = match variant {
                Variant::VoxelRays => ("voxel/clipmap/inject", "inject"),
                Variant::ShadowMaps => ("voxel/clipmap/inject_shadow", "inject_shadow"),
            };
            let shader = ctx.shader(variant.name(), &library_shader(module, &[]));
            ctx.compute_pipeline(variant.name(), &shader, entry)
        })
        .clone()
    }

    /// The parameter slot of an injection recorded now: the next one of this submission.
    fn next_slot(&mut self, timer: &PassTimer) -> Result<u64> {
        let submission = timer.submissions();
        let next = match self.used {
            (s, used) if s == submission => used,
            _ => 0,
        };
        if next >= INJECT_SLOTS {
            return Err(Error::InvalidArgument(format!(
                "clipmap: more than {INJECT_SLOTS} light injections recorded before one \
                 submission (finish the frame between them)"
            )));
        }
        self.used = (submission, next + 1);
        Ok(next)
    }
}

/// The voxel-ray injection's light buffer: [`INJECT_SLOTS`] slots of `room` lights.
fn light_buffer(ctx: &GpuContext, owner: &str, room: u64) -> wgpu::Buffer {
    storage(
        ctx,
        owner,
        "inject lights",
        INJECT_SLOTS * room * INJECT_LIGHT_BYTES,
    )
}

/// CPU twin of the injections' store (`inject_common.wgsl`): the outgoing radiance of a voxel
/// slot with RGBA8 word `voxel` (albedo, premultiplied by coverage on filtered levels, and
/// opacity) and RGB9E5 `emission` under `irradiance` W/m^2 (direct, plus with multiple bounces
/// the indirect irradiance of [`Clipmap::set_bounce`]): emission + albedo / pi x irradiance;
/// zero for an empty slot. The GPU stores it as f16.
pub fn injected_radiance(voxel: u32, emission: u32, irradiance: Vec3) -> Vec3 {
    if voxel >> 24 == 0 {
        return Vec3::ZERO;
    }
    let albedo = Vec3::new(
        (voxel & 255) as f32,
        ((voxel >> 8) & 255) as f32,
        ((voxel >> 16) & 255) as f32,
    ) / 255.0;
    decode_emission(emission) + albedo / std::f32::consts::PI * irradiance
}

/// CPU twin of the injections' facing (`inject_common.wgsl`): the direction the radiance of a
/// voxel slot leaves in, before its snorm8 storage ([`pack_facing`]). A voxel with a dominant
/// normal (its snorm8 `normal` word's length above 0.1) faces along it; one without (opposite
/// faces cancelled, lit as facing each light) faces the mean of the directions to its lights,
/// `lit` holding each light's direction and the irradiance it brings (after incidence and
/// visibility), weighted by the light the voxel reflects from it over all it sends out
/// (`radiance`, [`injected_radiance`]): its emission and bounce light have no direction.
pub fn injected_facing(voxel: u32, normal: u32, lit: &[(Vec3, Vec3)], radiance: Vec3) -> Vec3 {
    let n = unpack_facing(normal);
    if n.length_squared() > 0.01 {
        return n.normalize();
    }
    let albedo = Vec3::new(
        (voxel & 255) as f32,
        ((voxel >> 8) & 255) as f32,
        ((voxel >> 16) & 255) as f32,
    ) / 255.0;
    let toward: Vec3 = lit.iter().map(|&(to, e)| to * albedo.dot(e)).sum();
    toward / (std::f32::consts::PI * radiance.element_sum().max(1e-20))
}

/// The facing's storage (WGSL `pack4x8snorm` of xyz, w = 0): each component rounded to the
/// nearest of k / 127 (halves up).
pub fn pack_facing(f: Vec3) -> u32 {
    let byte = |c: f32| ((0.5 + 127.0 * c.clamp(-1.0, 1.0)).floor() as i32 as u8) as u32;
    byte(f.x) | byte(f.y) << 8 | byte(f.z) << 16
}

/// A facing word (or a normal word, the same snorm8 layout) read back: WGSL
/// `unpack4x8snorm(..).xyz`.
pub fn unpack_facing(w: u32) -> Vec3 {
    let c = |k: u32| ((w >> (8 * k)) as u8 as i8 as f32 / 127.0).max(-1.0);
    Vec3::new(c(0), c(1), c(2))
}

impl Clipmap {
    /// Injects light: every occupied voxel gets outgoing radiance emission + albedo / pi x the
    /// irradiance from `lights` (point, spot, directional), with visibility found by marching
    /// the clipmap's own opacity towards each light (at most `max_steps` samples, half a voxel
    /// of the voxel's level apart, per ray). Writes [`Clipmap::radiance`]; the pass is
    /// `clipmap inject`.
    pub fn inject(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        lights: &[Light],
        max_steps: u32,
    ) -> Result<()> {
        let mut gpu: Vec<GpuLight> = lights.iter().map(GpuLight::unshadowed).collect();
        let count = gpu.len() as u32;
        // A binding is never empty.
        if gpu.is_empty() {
            gpu.push(bytemuck::Zeroable::zeroed());
        }
        let inj = &mut self.injection;
        let room = (gpu.len() as u64).next_multiple_of(INJECT_LIGHT_ALIGN);
        if room > inj.light_room {
            inj.light_room = room;
            inj.lights = light_buffer(ctx, self.owner, room);
        }
        let slot = inj.next_slot(timer)?;
        let slot_bytes = inj.light_room * INJECT_LIGHT_BYTES;
        let at = slot * slot_bytes;
        ctx.queue
            .write_buffer(&inj.lights, at, bytemuck::cast_slice(&gpu));
        let pipeline = inj.pipeline(ctx, Variant::VoxelRays);
        let lights_buffer = inj.lights.clone();
        let lights = [(
            3,
            wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &lights_buffer,
                offset: at,
                size: wgpu::BufferSize::new(gpu.len() as u64 * INJECT_LIGHT_BYTES),
            }),
        )];
        let steps = max_steps.clamp(1, 4096);
        let variant = (Variant::VoxelRays, slot);
        self.inject_with(ctx, timer, variant, &pipeline, (count, steps), &lights);
        Ok(())
    }

    /// Injects light as [`Clipmap::inject`] does, with visibility from the renderer's shadow
    /// maps instead of voxel shadow rays: the first `light_count` lights of `lights` (the
    /// renderer's light buffer, `array<Light>` of `frame/lights.wgsl`) and its shadow maps
    /// (`shadows`, [`crate::frame::ShadowMaps::lookup`]), looked up with the deferred
    /// lighting's PCF half a voxel off each voxel's centre along its normal. Every voxel costs
    /// one lookup per light instead of a march per light. The pass is
    /// `clipmap inject (shadow maps)`.
    pub fn inject_shadow_maps(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        lights: &wgpu::Buffer,
        light_count: u32,
        shadows: crate::frame::ShadowLookup<'_>,
    ) -> Result<()> {
        let needed = light_count as u64 * crate::frame::LIGHT_BYTES;
        if lights.size() < needed {
            return Err(Error::InvalidArgument(format!(
                "clipmap injection: {light_count} lights need a light buffer of {needed} \
                 bytes, it has {}",
                lights.size()
            )));
        }
        let pipeline = self.injection.pipeline(ctx, Variant::ShadowMaps);
        let slot = self.injection.next_slot(timer)?;
        let lights = crate::frame::light_bindings(lights, shadows);
        let counts = (light_count, 0);
        let variant = (Variant::ShadowMaps, slot);
        self.inject_with(ctx, timer, variant, &pipeline, counts, &lights);
        Ok(())
    }

    /// One injection dispatch over every voxel slot: `variant` and `slot` choose the kept bind
    /// group and the parameter slot, `(lights, max_steps)` are the light count and the
    /// march's step limit, `extra` the variant's own bindings (its lights).
    fn inject_with(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        (variant, slot): (Variant, u64),
        pipeline: &wgpu::ComputePipeline,
        (lights, max_steps): (u32, u32),
        extra: &[(u32, wgpu::BindingResource)],
    ) {
        let slots = self.settings.slots() as u32;
        let params = InjectParams {
            lights,
            max_steps,
            slots,
            bounce: self.bounce.is_some() as u32,
        };
        let info = ClipInfo::new(&self.settings, &self.origins);
        let inj = &self.injection;
        let offset = slot * crate::gpu::pass::SLOT;
        ctx.queue
            .write_buffer(&inj.params, offset, bytemuck::bytes_of(&params));
        ctx.queue
            .write_buffer(&inj.info, offset, bytemuck::bytes_of(&info));
        let radiance = self
            .radiance
            .get_or_insert_with(|| storage(ctx, self.owner, "radiance", slots as u64 * 12));
        let mut entries: Vec<(u32, wgpu::BindingResource)> = [
            (2, &self.normals),
            (4, &*radiance),
            (6, &self.emission),
            (10, self.bounce.as_ref().unwrap_or(&self.placeholder)),
        ]
        .map(|(binding, buffer)| (binding, buffer.as_entire_binding()))
        .into();
        let at = |buffer, bytes: usize| crate::gpu::pass::slot(buffer, slot, bytes as u64);
        entries.extend([
            (5, at(&inj.params, std::mem::size_of_val(&params))),
            (CLIP_BINDINGS, at(&inj.info, std::mem::size_of_val(&info))),
            (CLIP_BINDINGS + 1, self.voxels.as_entire_binding()),
        ]);
        entries.extend(extra.iter().cloned());
        let kept = &inj.groups[(variant as u64 * INJECT_SLOTS + slot) as usize];
        let group = kept.get(ctx, variant.name(), pipeline, &entries);
        dispatch_1d(timer, variant.name(), pipeline, &group, slots);
    }

    /// Reads the injected radiance back: per voxel slot (layout of `voxels`), RGB radiance
    /// and opacity. Empty before [`Clipmap::inject`]. Blocks.
    pub fn read_radiance(&self, ctx: &GpuContext) -> Result<Vec<Vec4>> {
        Ok(self
            .read_radiance_words(ctx)?
            .chunks_exact(3)
            .map(|w| crate::gpu::pack::unpack_half4(w[0], w[1]))
            .collect())
    }

    /// Reads the injected radiance's facing back: per voxel slot, the direction its radiance
    /// leaves in, as stored ([`unpack_facing`]). Empty before [`Clipmap::inject`]. Blocks.
    pub fn read_facing(&self, ctx: &GpuContext) -> Result<Vec<Vec3>> {
        Ok(self
            .read_radiance_words(ctx)?
            .chunks_exact(3)
            .map(|w| unpack_facing(w[2]))
            .collect())
    }

    fn read_radiance_words(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        match &self.radiance {
            Some(radiance) => read_words(ctx, radiance),
            None => Ok(Vec::new()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn facing_words_round_as_wgsl_snorm8() {
        assert_eq!(pack_facing(Vec3::new(1.0, -1.0, 0.0)), 0x00_81_7f);
        assert_eq!(
            unpack_facing(pack_facing(Vec3::new(1.0, -1.0, 0.0))),
            Vec3::new(1.0, -1.0, 0.0)
        );
        // Halves round up: 0.5 / 127 -> 1, -0.5 / 127 -> 0.
        assert_eq!(
            pack_facing(Vec3::new(0.5 / 127.0, -0.5 / 127.0, 2.0)),
            0x7f_00_01
        );
        for k in -127..=127 {
            let c = k as f32 / 127.0;
            assert_eq!(unpack_facing(pack_facing(Vec3::splat(c))), Vec3::splat(c));
        }
    }

    #[test]
    fn facing_of_a_voxel_without_normal_is_the_reflected_lights_mean_direction() {
        let grey = 0xff_80_80_80u32;
        let lit = [(Vec3::X, Vec3::splat(2.0)), (Vec3::NEG_X, Vec3::splat(1.0))];
        let e: Vec3 = lit.iter().map(|l| l.1).sum();
        let radiance = injected_radiance(grey, 0, e);
        let f = injected_facing(grey, 0, &lit, radiance);
        // (2 - 1) / (2 + 1) of the way towards +x.
        assert!((f - Vec3::X / 3.0).length() < 1e-6, "{f}");
        // With a normal it faces along it, whatever the lights.
        assert_eq!(
            injected_facing(grey, pack_facing(Vec3::Y), &lit, radiance),
            Vec3::Y
        );
        // Emission has no direction: it shortens the mean.
        let glowing = radiance + Vec3::splat(1.0);
        assert!(injected_facing(grey, 0, &lit, glowing).length() < f.length());
    }

    #[test]
    fn injection_blocks_mirror_the_wgsl_ones() {
        assert_mirrors_wgsl!(
            InjectParams,
            "voxel/clipmap/inject_common",
            "InjectParams",
            [lights, max_steps, slots, bounce]
        );
    }
}
