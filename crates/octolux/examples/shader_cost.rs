//! What composing the WGSL modules costs (docs/architecture.md, "WGSL modules"): for every
//! module of `gpu::shader::MODULES`, the median time of composing it with its imports (wesl),
//! of creating the `wgpu` shader module from the result (naga parse and validation, the
//! driver's compile) and, for comparison, of creating one from the same WGSL text given
//! directly, as the concatenation before it did.
//!
//! ```text
//! cargo run --release -p octolux --example shader_cost -- runs=20
//! ```

use octolux::gpu::shader::{compose_alone, MODULES};
use octolux::gpu::{GpuContext, GpuOptions};
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> octolux::Result<()> {
    let runs: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.strip_prefix("runs=").and_then(|n| n.parse().ok()))
        .unwrap_or(20)
        .max(1);
    let ctx = GpuContext::new(&GpuOptions::default())?;
    println!("adapter: {}", ctx.describe());
    println!("| module | compose ms | shader module from it ms | lines |");
    println!("| --- | ---: | ---: | ---: |");
    let (mut compose_total, mut module_total) = (0.0, 0.0);
    // Each module with what a technique would compose in (`compose_alone`), isotropic.
    let features = [("anisotropic", false)];
    for (path, _) in MODULES {
        let mut times = Vec::new();
        let mut wgsl = String::new();
        for _ in 0..runs {
            let start = Instant::now();
            wgsl = compose_alone(path, &features)?;
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
        let compose_ms = median(times);
        let mut times = Vec::new();
        for _ in 0..runs {
            let start = Instant::now();
            let module = ctx.shader(path, &wgsl);
            ctx.wait_idle()?;
            times.push(start.elapsed().as_secs_f64() * 1e3);
            drop(module);
        }
        let module_ms = median(times);
        compose_total += compose_ms;
        module_total += module_ms;
        println!(
            "| {path} | {compose_ms:.2} | {module_ms:.2} | {} |",
            wgsl.lines().count()
        );
    }
    println!("| all | {compose_total:.2} | {module_total:.2} | |");
    Ok(())
}
