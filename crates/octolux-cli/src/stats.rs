//! Tables of pass times and GPU memory, shared by `render --stats` and `bench`.

use octolux::gpu::{MemoryLedger, PassTiming};

/// Average time per pass name over several frames, in first-seen order.
pub fn average_timings(frames: &[Vec<PassTiming>]) -> Vec<PassTiming> {
    let mut out: Vec<(PassTiming, usize)> = Vec::new();
    for frame in frames {
        for t in frame {
            match out.iter_mut().find(|(o, _)| o.name == t.name) {
                Some((o, n)) => {
                    o.ms += t.ms;
                    *n += 1;
                }
                None => out.push((t.clone(), 1)),
            }
        }
    }
    out.into_iter()
        .map(|(mut t, n)| {
            t.ms /= n as f64;
            t
        })
        .collect()
}

/// Prints pass times as a table.
pub fn print_timings(timings: &[PassTiming], frames: usize) {
    let source = timings.first().map(|t| t.source.label()).unwrap_or("-");
    println!("pass times ({source}, mean of {frames} frame(s)):");
    println!("  {:<24} {:>10}", "pass", "ms");
    let mut total = 0.0;
    for t in timings {
        println!("  {:<24} {:>10.3}", t.name, t.ms);
        total += t.ms;
    }
    println!("  {:<24} {:>10.3}", "total", total);
}

/// Prints GPU memory per owner as a table.
pub fn print_memory(ledger: &MemoryLedger) {
    println!("GPU memory by owner:");
    println!("  {:<24} {:>10}", "owner", "MiB");
    for (owner, bytes) in ledger.by_owner() {
        println!("  {:<24} {:>10.3}", owner, mib(bytes));
    }
    println!("  {:<24} {:>10.3}", "total", mib(ledger.total()));
}

/// Prints what a technique keeps that its passes' times do not show: the probes of
/// `probes-octree` (a tree that kept none would silently turn GI off).
pub fn print_technique_state(
    ctx: &octolux::gpu::GpuContext,
    technique: &dyn octolux::gi::GiTechnique,
) -> anyhow::Result<()> {
    let any = technique.as_any();
    if let Some(octree) = any.and_then(|a| a.downcast_ref::<octolux::gi::probes::ProbesOctree>()) {
        println!("probes kept: {}", octree.probe_count(ctx)?);
    }
    Ok(())
}

/// Prints wgpu's own count of live objects (what the ledger cannot see: bind groups, views,
/// pipelines, command buffers), so a count that grows with `--frames` shows a leak.
pub fn print_objects(ctx: &octolux::gpu::GpuContext) {
    if let Some(c) = ctx.resource_counts() {
        println!(
            "wgpu objects alive: {} buffers, {} textures, {} views, {} bind groups, {} pipelines, \
             {} command buffers",
            c.buffers, c.textures, c.texture_views, c.bind_groups, c.pipelines, c.command_buffers
        );
    }
}

/// Bytes to MiB.
pub fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1024.0 * 1024.0)
}
