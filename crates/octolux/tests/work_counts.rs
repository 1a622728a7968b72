//! The work counters `bench` reports: 64-bit sums from 32-bit atomics, one region per pass,
//! counts added on the CPU, and zero again after each read.

mod common;

use common::context;
use octolux::gpu::work::{entry, WorkCounter};
use octolux::gpu::{GpuContext, WorkCount};

const KERNEL: &str = "
import octolux::gpu::work::count_work;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    count_work(0u, 0xffffffffu);
    count_work(1u, id.x);
    count_work(2u, 0u);
}
";

fn run(ctx: &GpuContext, pass: &str, invocations: u32) {
    let source =
        octolux::gpu::shader::compose_text("work count test", KERNEL, &[ctx.work_feature()], &[])
            .unwrap();
    let module = ctx.shader("work count test", &source);
    let pipeline = ctx.compute_pipeline("work count test", &module, "main");
    let quantities = &["big", "index", "nothing"];
    let entries: Vec<_> = entry(ctx, pass, quantities).unwrap().into_iter().collect();
    let group = octolux::gpu::pass::bind(ctx, &pipeline, &entries);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut p = encoder.begin_compute_pass(&Default::default());
        p.set_pipeline(&pipeline);
        p.set_bind_group(0, &group, &[]);
        p.dispatch_workgroups(invocations / 64, 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
}

fn count(counts: &[WorkCount], pass: &str, quantity: &str) -> u64 {
    counts
        .iter()
        .find(|c| c.pass == pass && c.quantity == quantity)
        .unwrap_or_else(|| panic!("no count {pass}/{quantity} in {counts:?}"))
        .count
}

#[test]
fn work_counts_are_exact_64_bit_sums_per_pass() {
    let ctx = context().with_work_counter();
    let work: &WorkCounter = ctx.work().unwrap();
    // 256 invocations each adding 2^32 - 1: the low word wraps 255 times.
    run(&ctx, "first", 256);
    run(&ctx, "second", 128);
    run(&ctx, "first", 64);
    let cpu = work.region("cpu", &["draws"]).unwrap();
    work.add(cpu, 0, 5);
    work.add(cpu, 0, 1 << 40);
    let counts = work.take(&ctx).unwrap();
    let sum = |n: u64| n * (n - 1) / 2;
    assert_eq!(count(&counts, "first", "big"), 320 * 0xffff_ffff);
    assert_eq!(count(&counts, "first", "index"), sum(256) + sum(64));
    assert_eq!(count(&counts, "first", "nothing"), 0);
    assert_eq!(count(&counts, "second", "big"), 128 * 0xffff_ffff);
    assert_eq!(count(&counts, "second", "index"), sum(128));
    assert_eq!(count(&counts, "cpu", "draws"), 5 + (1 << 40));
    // Read again: every count back at zero, the regions kept.
    let again = work.take(&ctx).unwrap();
    assert_eq!(again.len(), counts.len());
    assert!(again.iter().all(|c| c.count == 0), "{again:?}");
    // A pass registered again with other quantities is an error, not a silent mix-up.
    assert!(work.region("first", &["big"]).is_err());
}

#[test]
fn a_context_without_counters_counts_nothing() {
    let ctx = context();
    assert!(ctx.work().is_none());
    assert_eq!(ctx.work_feature(), ("count_work", false));
    // The kernel composes without the binding and runs.
    run(&ctx, "first", 64);
    ctx.check_errors().unwrap();
}
