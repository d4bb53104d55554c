//! `ssskit bench filter`: GPU time per frame of the wgpu post-process.

use super::args::{self, count, ImageSizeArg, KernelFile};
use super::out::outln;
use ssskit::filter::{gpu, timing};

pub type Args = args::Group<What>;

#[derive(clap::Subcommand)]
pub enum What {
    /// GPU time of one frame of the post-process, by timestamp queries.
    ///
    /// GPU timestamps around one frame of the post-process (depth-aware,
    /// perspective scale), upload and readback excluded; refuses to report
    /// a software rasteriser's time.
    Filter(FilterArgs),
}

#[derive(clap::Args)]
#[command(
    mut_arg("kernel", |a| args::required()(a).help(
        "Kernel file (ssskit.kernel/1 JSON): its tap table runs, e.g. kernels/skin1-svd1.json"
    )),
    mut_arg("image_size", |a| a
        .default_value(format!("{}x{}", timing::DEFAULT_FRAME.0, timing::DEFAULT_FRAME.1))
        .help("Image size in pixels, WIDTHxHEIGHT: the frame")),
)]
pub struct FilterArgs {
    #[command(flatten)]
    kernel: KernelFile,
    #[command(flatten)]
    image_size: ImageSizeArg,
    /// Deprecated: use --image-size WxH.
    #[arg(long, hide = true, conflicts_with = "image_size", value_parser = count::<usize>)]
    width: Option<usize>,
    /// Deprecated: use --image-size WxH.
    #[arg(long, hide = true, conflicts_with = "image_size", value_parser = count::<usize>)]
    height: Option<usize>,
    /// Frames: timed after one warm-up frame (at most 1000).
    ///
    /// 2 on a software rasteriser, which only checks that the path runs.
    #[arg(long, value_name = "N", default_value_t = timing::DEFAULT_FRAMES, value_parser = count::<u32>)]
    frames: u32,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    match a.what {
        What::Filter(f) => run_filter(f),
    }
}

fn run_filter(a: FilterArgs) -> anyhow::Result<()> {
    let path = a
        .kernel
        .kernel
        .as_deref()
        .ok_or_else(|| anyhow::anyhow!("give --kernel"))?;
    let kernel = ssskit::kernel::KernelFile::read(path)?;
    let (w, h) = a.image_size.image_size;
    let (width, height) = (a.width.unwrap_or(w), a.height.unwrap_or(h));
    let g = gpu::Gpu::new()?;
    outln!("adapter: {}", g.describe())?;
    let frames = if g.is_software() {
        a.frames.min(2)
    } else {
        a.frames
    };
    let t = timing::time_post_process(&g, &kernel, width, height, frames)?;
    outln!(
        "frame: {}x{}, {} taps, rank {}, perspective (fov_y {} deg), depth-aware (C = {})",
        width,
        height,
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
