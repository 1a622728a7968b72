//! `octolux diff`: error metrics of an image against a reference.

use anyhow::Context;
use octolux::metrics::{self, MetricOptions};
use std::path::PathBuf;

/// Compare an image with a reference: MSE, relMSE, PSNR, SSIM, FLIP, the ratio of their
/// means and how relMSE spreads over the pixels.
#[derive(clap::Args, Debug, Clone)]
pub struct DiffArgs {
    /// Image to judge (.exr linear HDR; .png is decoded from sRGB to linear).
    pub a: PathBuf,
    /// Reference image, same size.
    pub b: PathBuf,
    /// Mask PNG of the same size: white pixels are compared, black ones ignored.
    #[arg(long)]
    pub mask: Option<PathBuf>,
    /// Write the per-pixel FLIP error map (magma colours) to this PNG.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the metrics as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Exposure in stops applied before tone mapping for PSNR, SSIM and FLIP.
    #[arg(long, default_value_t = 0.0)]
    pub exposure: f32,
}

/// Runs `octolux diff`.
pub fn run(args: &DiffArgs) -> anyhow::Result<()> {
    if !args.exposure.is_finite() || args.exposure.abs() > octolux::scene::MAX_EXPOSURE {
        anyhow::bail!(
            "--exposure {}: expected a finite EV within -{1}..={1}",
            args.exposure,
            octolux::scene::MAX_EXPOSURE
        );
    }
    if let Some(out) = &args.out {
        let inputs: Vec<PathBuf> = [&args.a, &args.b]
            .into_iter()
            .chain(&args.mask)
            .cloned()
            .collect();
        crate::outputs::check(
            &[crate::outputs::Planned {
                flag: "--out",
                path: out,
                format: crate::outputs::Format::Png,
            }],
            &inputs,
        )?;
    }
    let a = metrics::load_image(&args.a)?;
    let b = metrics::load_image(&args.b)?;
    for (path, image) in [(&args.a, &a), (&args.b, &b)] {
        if let Some((x, y, v)) = image.first_non_finite() {
            anyhow::bail!(
                "{}: pixel ({x}, {y}) is {v}: the metrics need finite values",
                path.display()
            );
        }
    }
    let mask = match &args.mask {
        Some(path) => Some(metrics::load_mask(path, b.width, b.height)?),
        None => None,
    };
    let options = MetricOptions {
        exposure: args.exposure,
        ..MetricOptions::default()
    };
    let m = metrics::compare_with(&a, &b, mask.as_deref(), &options)
        .with_context(|| format!("comparing {} with {}", args.a.display(), args.b.display()))?;
    if let Some(out) = &args.out {
        metrics::flip_map(&a, &b, &options)?.write_png(out, mask.as_deref())?;
    }
    // The ratio of the mean linear values (channels averaged, over the compared pixels): how
    // much light one renderer finds more than the other, which noise does not bias.
    let mean = |image: &octolux::image_io::HdrImage| {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for (i, p) in image.pixels.iter().enumerate() {
            if mask.as_ref().is_none_or(|m| m[i]) {
                sum += p.element_sum() as f64 / 3.0;
                n += 1;
            }
        }
        sum / n.max(1) as f64
    };
    let mean_ratio = mean(&a) / mean(&b);
    let spread = metrics::rel_mse_distribution(&a, &b, mask.as_deref())?;
    if args.json {
        #[derive(serde::Serialize)]
        struct Report<'a> {
            #[serde(flatten)]
            metrics: &'a metrics::Metrics,
            mean_ratio: f64,
            rel_mse_distribution: metrics::ErrorDistribution,
        }
        let report = Report {
            metrics: &m,
            mean_ratio,
            rel_mse_distribution: spread,
        };
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!("{} vs {} (reference)", args.a.display(), args.b.display());
        println!("{:<8} {:>14}", "metric", "value");
        println!("{:<8} {:>14.6e}", "MSE", m.mse);
        println!("{:<8} {:>14.6e}", "relMSE", m.rel_mse);
        println!("{:<8} {:>11.3} dB", "PSNR", m.psnr);
        println!("{:<8} {:>14.5}", "SSIM", m.ssim);
        println!("{:<8} {:>14.5}", "FLIP", m.flip);
        println!("{:<8} {:>14.5}", "mean A/B", mean_ratio);
        println!(
            "relMSE per pixel: median {:.3e}, 90 % {:.3e}, 99 % {:.3e}; worst 1 % of pixels \
             {:.1} % of it, worst 0.1 % {:.1} %",
            spread.p50,
            spread.p90,
            spread.p99,
            100.0 * spread.worst_1_percent,
            100.0 * spread.worst_0_1_percent
        );
        if let Some(out) = &args.out {
            println!("error map: {}", out.display());
        }
    }
    Ok(())
}
