//! Work counts: exact integer counts of what each pass does (cone samples, octree nodes
//! visited, shadow-ray steps, triangles drawn), the cost a pass has on any adapter. Pass times
//! on lavapipe track work but not contention or bandwidth, and on a GPU they vary from run to
//! run; a work count is the same number on every adapter, so it shows where a pass's cost comes
//! from and what a change saved, on machines without a GPU.
//!
//! Counting is off in ordinary renderers. A context made by [`GpuContext::with_work_counter`]
//! carries a [`WorkCounter`]; techniques created on it compose their counted shaders with the
//! `count_work` flag (`gpu/work.wgsl`), bind their pass's region of the counters at
//! [`WORK_BINDING`] and add the counts they know on the CPU (draws, dispatch sizes). Counting
//! adds atomics to every counted invocation, so its frames are not the timed ones: `bench`
//! renders them with a second renderer after measuring.

use super::GpuContext;
use crate::{Error, Result};
use std::sync::{Arc, Mutex};

/// The group 0 binding of a counting pass's region (`work_counts` in `gpu/work.wgsl`).
pub const WORK_BINDING: u32 = 63;
/// Quantities one pass can count.
pub const MAX_QUANTITIES: usize = 16;
/// Passes one counter holds.
const MAX_REGIONS: u64 = 64;
/// Bytes of the counters of one region: 16 quantities of two words.
const REGION_BYTES: u64 = MAX_QUANTITIES as u64 * 8;

/// One counted quantity of one pass in one frame.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct WorkCount {
    /// The pass, as its timer names it.
    pub pass: String,
    /// What is counted (`"cone samples"`).
    pub quantity: String,
    /// How many, summed over the pass's dispatches in the frame.
    pub count: u64,
}

/// The work counters of one renderer: a region per counted pass on the GPU, and counts the CPU
/// adds. Cloning shares them.
#[derive(Clone, Debug)]
pub struct WorkCounter(Arc<Inner>);

#[derive(Debug)]
struct Inner {
    buffer: wgpu::Buffer,
    /// Bytes between regions: [`REGION_BYTES`] rounded up to the storage offset alignment.
    stride: u64,
    regions: Mutex<Vec<Region>>,
}

#[derive(Debug)]
struct Region {
    pass: String,
    quantities: Vec<&'static str>,
    /// Counts added on the CPU since the last [`WorkCounter::take`].
    cpu: [u64; MAX_QUANTITIES],
}

/// A pass's region of the counters: what its shaders bind and its CPU counts go to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WorkRegion(usize);

impl WorkCounter {
    pub(crate) fn new(ctx: &GpuContext) -> WorkCounter {
        let align = ctx.device.limits().min_storage_buffer_offset_alignment as u64;
        let stride = REGION_BYTES.next_multiple_of(align.max(4));
        let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("work counts"),
            size: stride * MAX_REGIONS,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        WorkCounter(Arc::new(Inner {
            buffer,
            stride,
            regions: Mutex::new(Vec::new()),
        }))
    }

    fn regions(&self) -> std::sync::MutexGuard<'_, Vec<Region>> {
        self.0.regions.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The region of `pass`, counting `quantities` (the shader's quantity `q` is
    /// `quantities[q]`): made on the first call, the same one for later calls with the same
    /// pass. An error past [`MAX_QUANTITIES`] quantities or 64 passes, or where a pass is
    /// registered again with other quantities.
    pub fn region(&self, pass: &str, quantities: &[&'static str]) -> Result<WorkRegion> {
        let mut regions = self.regions();
        if let Some(i) = regions.iter().position(|r| r.pass == pass) {
            if regions[i].quantities != quantities {
                return Err(Error::Gpu(format!(
                    "work counts: pass '{pass}' counts {:?} and {quantities:?}",
                    regions[i].quantities
                )));
            }
            return Ok(WorkRegion(i));
        }
        if quantities.len() > MAX_QUANTITIES || regions.len() as u64 >= MAX_REGIONS {
            return Err(Error::Gpu(format!(
                "work counts: no room for pass '{pass}' ({} quantities; at most \
                 {MAX_QUANTITIES} per pass and {MAX_REGIONS} passes)",
                quantities.len()
            )));
        }
        regions.push(Region {
            pass: pass.to_string(),
            quantities: quantities.to_vec(),
            cpu: [0; MAX_QUANTITIES],
        });
        Ok(WorkRegion(regions.len() - 1))
    }

    /// The bind group entry of `region` (at [`WORK_BINDING`]).
    pub fn entry(&self, region: WorkRegion) -> (u32, wgpu::BindingResource<'_>) {
        (
            WORK_BINDING,
            wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &self.0.buffer,
                offset: region.0 as u64 * self.0.stride,
                size: wgpu::BufferSize::new(REGION_BYTES),
            }),
        )
    }

    /// Adds `n` to quantity `quantity` of `region`, counted on the CPU (triangles drawn,
    /// texels cleared: what the dispatch or draw sizes say).
    pub fn add(&self, region: WorkRegion, quantity: usize, n: u64) {
        if let Some(r) = self.regions().get_mut(region.0) {
            if let Some(c) = r.cpu.get_mut(quantity) {
                *c += n;
            }
        }
    }

    /// The counts since the last call (every quantity of every region, zeros included), and
    /// the counters set back to zero. Waits for the GPU.
    pub fn take(&self, ctx: &GpuContext) -> Result<Vec<WorkCount>> {
        let bytes = crate::gpu::read_buffer(ctx, &self.0.buffer, 0, self.0.buffer.size())?;
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&self.0.buffer, 0, None);
        ctx.queue.submit([encoder.finish()]);
        let words: &[u32] = bytemuck::cast_slice(&bytes);
        let mut out = Vec::new();
        for (i, r) in self.regions().iter_mut().enumerate() {
            let base = i * (self.0.stride / 4) as usize;
            for (q, name) in r.quantities.iter().enumerate() {
                let gpu = words[base + 2 * q] as u64 | (words[base + 2 * q + 1] as u64) << 32;
                out.push(WorkCount {
                    pass: r.pass.clone(),
                    quantity: name.to_string(),
                    count: gpu + r.cpu[q],
                });
            }
            r.cpu = [0; MAX_QUANTITIES];
        }
        Ok(out)
    }
}

/// The bind group entry of `pass`'s region, counting `quantities`, where `ctx` counts work
/// (add it to the pass's entries); None where it does not.
pub fn entry<'a>(
    ctx: &'a GpuContext,
    pass: &str,
    quantities: &[&'static str],
) -> Result<Option<(u32, wgpu::BindingResource<'a>)>> {
    match ctx.work() {
        Some(work) => Ok(Some(work.entry(work.region(pass, quantities)?))),
        None => Ok(None),
    }
}

/// Adds `n` to quantity `quantity` of `pass` (counting `quantities`), where `ctx` counts work:
/// for counts the CPU knows (draws, dispatch sizes).
pub fn add(
    ctx: &GpuContext,
    pass: &str,
    quantities: &[&'static str],
    quantity: usize,
    n: u64,
) -> Result<()> {
    if let Some(work) = ctx.work() {
        work.add(work.region(pass, quantities)?, quantity, n);
    }
    Ok(())
}
