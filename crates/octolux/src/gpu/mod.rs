//! GPU plumbing, the bottom layer every pass stands on: device and adapter choice
//! ([`GpuContext`]), per-pass timers ([`PassTimer`]), the memory ledger ([`MemoryLedger`])
//! every GPU resource is counted in, allocation ([`alloc`]), bind-group and dispatch helpers
//! ([`pass`]), the CPU decoders of packed GPU values ([`pack`]) and the composition of the
//! library's WGSL modules ([`shader`]), the work counters `bench` reads ([`work`]) and the
//! roofline that sets their estimated bytes and operations against the adapter's peaks
//! ([`roofline`]).

pub mod alloc;
mod context;
#[cfg(test)]
pub(crate) mod layout;
mod ledger;
pub mod pack;
pub mod pass;
mod readback;
pub mod requirements;
pub mod roofline;
pub mod shader;
mod timer;
pub mod work;

pub use context::{AdapterChoice, GpuContext, GpuOptions, ResourceCounts, Timestamps, ADAPTER_ENV};
pub use ledger::{LedgerEntry, MemoryLedger};
pub use readback::{read_buffer, read_half_image, read_texture, read_words};
pub use timer::{
    scoped_name, slowest_first, PassTimer, PassTiming, TimingSource, PROFILE_STEPS_ENV,
};
pub use work::{WorkCount, WorkCounter, WorkRegion};

/// A compute-stage storage-buffer entry of a bind group layout at `binding`.
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}
