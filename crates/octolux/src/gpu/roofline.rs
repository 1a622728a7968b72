//! How close a pass comes to the hardware: an estimate of the bytes each counted pass reads and
//! writes and the floating-point operations it does, from its work counts ([`super::work`])
//! and a cost per unit of work ([`UNIT_COSTS`]), set against the adapter's peaks, measured by a
//! copy kernel and a kernel of fused multiply-adds (`roofline.wgsl`, [`measure_peaks`]).
//!
//! The bytes are what the shaders ask for, not the DRAM traffic: caches serve much of a
//! pass's requests (neighbouring pixels reading the same probes, cone samples of one brick),
//! so a pass can exceed 100 % of the copy kernel's bandwidth on this measure, and a low share
//! says the pass waits on something else (dependent loads, atomics, occupancy, a few long
//! threads), which docs/performance.md names per pass. The costs per unit are counted from
//! the WGSL (the loads and stores of one unit, its arithmetic to the nearest few operations);
//! passes without counts get no estimate, nor do the rasterised ones but the reflective shadow
//! maps.

use super::pass::dispatch_size;
use super::{GpuContext, PassTimer};
use crate::{Error, Result};

/// The cost of one unit of a counted quantity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitCost {
    /// The pass names it applies to end with this (`" light"`); empty: any pass.
    pub pass_suffix: &'static str,
    /// The work quantity (`"cone samples"`).
    pub quantity: &'static str,
    /// Bytes read and written per unit.
    pub bytes: f64,
    /// Floating-point (and comparable integer) operations per unit.
    pub ops: f64,
}

const fn cost(pass_suffix: &'static str, quantity: &'static str, bytes: f64, ops: f64) -> UnitCost {
    UnitCost {
        pass_suffix,
        quantity,
        bytes,
        ops,
    }
}

/// Costs per unit of work, the first entry whose suffix and quantity match a count applying.
/// Each line says what one unit loads and stores.
pub const UNIT_COSTS: &[UnitCost] = &[
    // Probes. Placement: a ray writes its surfel (3 vec4: position + state, normal + albedo,
    // emission + distance) after its traversal, whose nodes and triangles count apart.
    cost(" place", "rays", 48.0, 30.0),
    cost(" place", "probes", 0.0, 10.0),
    // BVH traversal: a node is two child boxes (32 B) and a slab test each; a triangle 3
    // vertices (36 B) and its index (12 B), Moller-Trumbore (two crosses, four dots).
    cost("", "BVH nodes", 32.0, 24.0),
    cost("", "triangles tested", 48.0, 40.0),
    // Depth moments: a texel read and written (2 f32 each: the blend with the maps before)
    // and, per round of 64 surfels, its lane's surfel fetched (state and distance, 8 B) and its
    // direction made (~20); a kernel term reads a
    // direction and distance from workgroup memory (no device bytes) and weighs it (dot, a
    // 32nd power by squarings, two FMAs).
    cost(" moments", "texels", 24.0, 24.0),
    cost(" moments", "kernel terms", 0.0, 12.0),
    // Surfel light: a surfel's 3 vec4 read, its radiance written; a shadow lookup 4 PCF taps
    // of 4 B and the light's incidence.
    cost(" light", "surfels", 64.0, 20.0),
    cost("", "shadow lookups", 16.0, 30.0),
    // A probe read by a lookup: the default SH L1's 4 coefficient vec4s and its state (80 B;
    // the 8-bin encoding reads 64 B more), 2 moment texels (16 B); SH L1 irradiance (24), the
    // tent and facing weights and Chebyshev's test (~45).
    cost("", "probes read", 96.0, 70.0),
    // Integration: a surfel's radiance and state (32 B) projected on SH L1 (24); a probe's
    // coefficients, state and latest sample written (9 + 8 vec4s).
    cost(" integrate", "surfels", 32.0, 24.0),
    cost(" integrate", "probes", 272.0, 16.0),
    // Tree walks (probe octree, sparse voxel octree): one 4-byte node word and a child
    // choice per node; a descent's setup.
    cost("", "octree nodes", 4.0, 6.0),
    cost("", "octree lookups", 0.0, 10.0),
    cost("", "nodes", 4.0, 6.0),
    // Voxel-octree ray walks: a cell step (exit face of a box) from registers.
    cost("", "ray cells", 0.0, 20.0),
    cost("", "cells", 0.0, 20.0),
    // Pixels of a gather or a shade: depth, normal and albedo read (12 B), rgba16f written.
    cost("", "pixels", 20.0, 30.0),
    // Cone tracing: a sample blends two mip levels of 8 rgba16f texels (128 B) and composites
    // front to back; a cone's setup.
    cost("", "cone samples", 128.0, 40.0),
    cost("", "cones", 0.0, 20.0),
    cost("", "voxels", 8.0, 20.0),
    // VPL shading: a VPL's position, normal and flux (32 B), the geometry term; a shadow ray's
    // setup (its cells and nodes count apart).
    cost("", "VPL pairs", 32.0, 40.0),
    cost("", "shadow rays", 0.0, 20.0),
    // LPV propagation: a cell gathers the 6 neighbours' 3 channels of 4 SH coefficients in
    // f32 (288 B) and writes its own (48 B); 6 faces x 5 sub-faces x 3 channels of 4-term
    // products and sums (~400).
    cost(" propagate", "cell updates", 336.0, 400.0),
    // LPV injection: an RSM texel's flux, normal and depth (16 B) turned into a VPL; a VPL's
    // SH projection (3 channels x 4); each atomic add a read-modify-write of 4 B.
    cost(" inject", "RSM texels", 16.0, 20.0),
    cost(" inject", "VPL injections", 0.0, 40.0),
    cost(" inject", "surfel injections", 0.0, 40.0),
    cost("", "atomic adds", 8.0, 1.0),
    // The octree's radiance mip: a filtered texel's share of its node's staging (the 8
    // children's 216 rgba16f texels for 27 texels: 64 B) and its write (8 B), 27 taps of a
    // multiply-add and a weight (~140); a face transfer reads and writes 9 texels in each of
    // two bricks (288 B) and adds them (~40). Transfers to a missing neighbour read less: an
    // upper bound.
    cost(" radiance mip", "static texels filtered", 72.0, 140.0),
    cost(" radiance mip", "static face transfers", 288.0, 40.0),
    // Reflective shadow maps (rasterised): a texel cleared and then written in its three
    // targets and depth (rgba32f + 2 rgba16f + depth32: 36 B each time, the depth test's read
    // besides), its fragment's flux and measure (~60); a triangle's 3 vertices (32 B each)
    // transformed (~100). A rasteriser's limits are its own, so a low share here says no more
    // than that the memory is not what bounds the pass.
    cost(" rsm", "texels", 76.0, 60.0),
    cost(" rsm", "triangles drawn", 96.0, 100.0),
];

/// A pass's estimated bytes and operations in one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Estimate {
    pub bytes: f64,
    pub ops: f64,
}

/// The estimate of pass `pass` from its counts (quantity, count) in one frame; `None` where no
/// count of it has a cost.
pub fn estimate(pass: &str, counts: &[(&str, u64)]) -> Option<Estimate> {
    let mut total = Estimate::default();
    let mut any = false;
    for &(quantity, count) in counts {
        let unit = UNIT_COSTS
            .iter()
            .find(|c| c.quantity == quantity && pass.ends_with(c.pass_suffix));
        if let Some(unit) = unit {
            total.bytes += unit.bytes * count as f64;
            total.ops += unit.ops * count as f64;
            any = true;
        }
    }
    any.then_some(total)
}

/// The adapter's peaks: memory bandwidth (bytes/s) and arithmetic throughput (operations/s).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Peaks {
    pub bytes_per_s: f64,
    pub ops_per_s: f64,
    /// Where they come from (`"measured: copy 512 MiB, 268M FMA vec4 ..."`).
    pub source: String,
}

impl Peaks {
    /// The achieved share of each peak of a pass that did `estimate` in `seconds`.
    pub fn shares(&self, estimate: Estimate, seconds: f64) -> (f64, f64) {
        if seconds <= 0.0 {
            return (0.0, 0.0);
        }
        (
            estimate.bytes / seconds / self.bytes_per_s,
            estimate.ops / seconds / self.ops_per_s,
        )
    }
}

/// Shortest time a measurement should take, so that a CPU-timed pass's overhead is a small
/// part of it (GPU timestamps need far less).
const MIN_SECONDS: f64 = 0.02;
/// Floating-point operations of one invocation of `fma_chains`.
const FMA_OPS: f64 = 8.0 * 4.0 * 256.0 * 2.0;

/// Measures the adapter's peaks: the best of three runs of a copy kernel over a buffer of up to
/// 128 MiB (or the adapter's binding limit; two of them are more than a GPU's last-level
/// cache), repeated within one pass until it takes [`MIN_SECONDS`], and of the FMA kernel,
/// grown likewise.
pub fn measure_peaks(ctx: &GpuContext) -> Result<Peaks> {
    let limit = ctx
        .device
        .limits()
        .max_storage_buffer_binding_size
        .min(ctx.device.limits().max_buffer_size);
    let bytes = (128u64 << 20).min(limit / 16 * 16);
    let vec4s = (bytes / 16) as u32;
    let buffer = |label: &str| {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        })
    };
    let (from, to) = (
        buffer("roofline copy source"),
        buffer("roofline copy target"),
    );
    let module = ctx.shader(
        "roofline",
        &super::shader::library_shader("gpu/roofline", &[]),
    );
    let copy = ctx.compute_pipeline("roofline copy", &module, "copy");
    let fma = ctx.compute_pipeline("roofline fma", &module, "fma_chains");
    let copy_group = super::pass::bind_buffers(ctx, &copy, &[(0, &from), (1, &to)]);
    let fma_group = super::pass::bind_buffers(ctx, &fma, &[(1, &to)]);

    // Runs `repeats` dispatches of `invocations` in one pass; its best time of three.
    let run = |pipeline: &wgpu::ComputePipeline,
               group: &wgpu::BindGroup,
               invocations: u32,
               repeats: u32|
     -> Result<f64> {
        let (x, y) = dispatch_size(invocations);
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let mut timer = PassTimer::new(ctx);
            timer.pass("roofline", |encoder, stamps| {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("roofline"),
                    timestamp_writes: stamps.compute(),
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, group, &[]);
                for _ in 0..repeats {
                    pass.dispatch_workgroups(x, y, 1);
                }
            });
            let timings = timer.finish_frame()?;
            let ms: f64 = timings.iter().map(|t| t.ms).sum();
            best = best.min(ms * 1e-3);
        }
        Ok(best)
    };
    let grow = |what: &str,
                pipeline: &wgpu::ComputePipeline,
                group: &wgpu::BindGroup,
                invocations: u32|
     -> Result<(u32, f64)> {
        let mut repeats = 1u32;
        loop {
            let seconds = run(pipeline, group, invocations, repeats)?;
            if seconds >= MIN_SECONDS || repeats >= 1 << 12 {
                if !(seconds.is_finite() && seconds > 0.0) {
                    return Err(Error::Gpu(format!("roofline {what}: no time measured")));
                }
                return Ok((repeats, seconds));
            }
            repeats *= 2;
        }
    };
    let (copies, copy_seconds) = grow("copy", &copy, &copy_group, vec4s)?;
    // 2^16 invocations (1.07e9 operations) a dispatch, repeated as the copy.
    let fma_invocations = vec4s.min(1 << 16);
    let (fmas, fma_seconds) = grow("fma", &fma, &fma_group, fma_invocations)?;
    let copied = 2.0 * bytes as f64 * copies as f64;
    let ops = FMA_OPS * fma_invocations as f64 * fmas as f64;
    Ok(Peaks {
        bytes_per_s: copied / copy_seconds,
        ops_per_s: ops / fma_seconds,
        source: format!(
            "measured: a copy of {} MiB x {copies} in {:.3} ms, {:.3e} FMA operations in {:.3} ms ({})",
            bytes >> 20,
            copy_seconds * 1e3,
            ops,
            fma_seconds * 1e3,
            if ctx.timestamps { "GPU timestamps" } else { "CPU submit+wait" }
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_estimate_sums_its_counts_costs_and_ignores_the_rest() {
        let e = estimate(
            "probes-grid light",
            &[
                ("surfels", 10),
                ("shadow lookups", 4),
                ("probes read", 2),
                ("unknown", 99),
            ],
        )
        .unwrap();
        assert_eq!(e.bytes, 10.0 * 64.0 + 4.0 * 16.0 + 2.0 * 96.0);
        assert_eq!(e.ops, 10.0 * 20.0 + 4.0 * 30.0 + 2.0 * 70.0);
        // The same quantity costs what its pass does with it.
        let integrate = estimate("probes-grid integrate", &[("surfels", 1)]).unwrap();
        assert_eq!(integrate.bytes, 32.0);
        assert!(estimate("compose", &[("lanes", 5)]).is_none());
    }

    #[test]
    fn every_counted_quantity_of_a_dominant_pass_has_a_cost() {
        // The quantities the techniques' heavy passes count (docs/performance.md, "Work
        // counts"); a renamed quantity must not silently lose its cost.
        for (pass, quantity) in [
            ("probes-grid place", "rays"),
            ("probes-grid light", "surfels"),
            ("probes-grid gather", "probes read"),
            ("probes-octree gather", "octree nodes"),
            ("vct-svo trace", "cone samples"),
            ("vct-clipmap bounce", "cone samples"),
            ("vpl shade", "VPL pairs"),
            ("lpv propagate", "cell updates"),
            ("clpv inject", "atomic adds"),
        ] {
            assert!(
                estimate(pass, &[(quantity, 1)]).is_some(),
                "{pass}: {quantity}"
            );
        }
    }

    #[test]
    fn the_peak_kernels_measure_something_on_this_adapter() {
        let ctx = GpuContext::shared(&Default::default()).expect("a GPU adapter");
        let peaks = measure_peaks(&ctx).unwrap();
        assert!(
            peaks.bytes_per_s > 1e6 && peaks.bytes_per_s.is_finite(),
            "{peaks:?}"
        );
        assert!(
            peaks.ops_per_s > 1e6 && peaks.ops_per_s.is_finite(),
            "{peaks:?}"
        );
    }
}
