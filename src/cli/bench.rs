//! `ssskit bench filter`: GPU time per frame of the wgpu post-process.

use super::out::outln;
use ssskit::filter::{gpu, timing};
use ssskit::kernel::KernelFile;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(clap::Subcommand)]
enum What {
    /// GPU timestamps around one frame of the post-process (depth-aware,
    /// perspective scale), upload and readback excluded; refuses to report
    /// a software rasteriser's time.
    Filter(FilterArgs),
}

#[derive(clap::Args)]
struct FilterArgs {
    /// Kernel file whose tap table runs (e.g. kernels/skin1-svd1.json: 17 taps, rank 1).
    #[arg(long)]
    kernel: PathBuf,
    #[arg(long, default_value_t = 1920)]
    width: usize,
    #[arg(long, default_value_t = 1080)]
    height: usize,
    /// Frames timed after one warm-up frame (at most 1000; 2 on a software
    /// rasteriser, which only checks that the path runs).
    #[arg(long, default_value_t = 200)]
    frames: u32,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    match a.what {
        What::Filter(f) => run_filter(f),
    }
}

fn run_filter(a: FilterArgs) -> anyhow::Result<()> {
    let kernel = KernelFile::read(&a.kernel)?;
    let g = gpu::Gpu::new()?;
    outln!("adapter: {}", g.describe())?;
    let frames = if g.is_software() {
        a.frames.min(2)
    } else {
        a.frames
    };
    let t = timing::time_post_process(&g, &kernel, a.width, a.height, frames)?;
    outln!(
        "frame: {}x{}, {} taps, rank {}, perspective (fov_y {} deg), depth-aware (C = {})",
        a.width,
        a.height,
        t.taps,
        t.rank,
        timing::FOV_Y_DEG,
        timing::FOLLOW_SURFACE
    )?;
    if t.software {
        outln!(
            "{} is a software rasteriser: the timestamp path ran ({} frames), but its times \
             are CPU emulation, not a GPU timing; none is reported. Run this on a hardware \
             adapter (docs/filter.md).",
            g.describe(),
            t.frames_ms.len()
        )?;
        return Ok(());
    }
    let mut v = t.frames_ms.clone();
    v.sort_by(f64::total_cmp);
    let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
    outln!(
        "GPU time per frame over {} frames: median {:.3} ms, min {:.3} ms, p95 {:.3} ms, mean {:.3} ms",
        v.len(),
        q(0.5),
        v[0],
        q(0.95),
        v.iter().sum::<f64>() / v.len() as f64
    )?;
    Ok(())
}
