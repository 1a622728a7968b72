//! Shared by the growth tests (`frame_growth`, `voxel_growth`): what "nothing grows" is
//! measured with.

use octolux::gpu::{GpuContext, ResourceCounts};

/// Resident set size of this process in MiB (Linux), None elsewhere.
pub fn resident_mib() -> Option<f64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: f64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096.0 / (1024.0 * 1024.0))
}

/// Resident memory, wgpu's live objects and the ledger total at one moment.
pub struct Snapshot {
    pub rss: Option<f64>,
    pub counts: Option<ResourceCounts>,
    pub ledger: u64,
}

/// The state of the process and of `ctx` now.
pub fn snapshot(ctx: &GpuContext) -> Snapshot {
    Snapshot {
        rss: resident_mib(),
        counts: ctx.resource_counts(),
        ledger: ctx.ledger.total(),
    }
}
