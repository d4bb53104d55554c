//! `ssskit apply` with a disk kernel (`ssskit.disk/1`): the disk pass over
//! --frames rotations, on the CPU (f64) or with wgpu.

use super::Args;
use crate::cli::args::Backend;
use anyhow::{bail, Context};
use ssskit::filter::accumulate::Accumulate;
use ssskit::filter::disk::{apply_disk_in_place_with, check_cpu_work, DiskSetup};
use ssskit::filter::disk_gpu::DiskGpu;
use ssskit::filter::{Image, Setup};
use ssskit::kernel::disk::DiskKernelFile;
use std::path::Path;

/// The disk pass over `image`: the CPU filters it in place (docs/filter.md).
pub fn run(args: &Args, path: &Path, view: Setup, image: Image) -> anyhow::Result<Image> {
    let separable_only = [
        ("--taps-only", args.taps_only),
        ("--full-factors", args.full_factors),
        ("--jitter", args.jitter),
    ];
    if let Some((flag, _)) = separable_only.iter().find(|(_, given)| *given) {
        bail!(
            "{flag} applies to separable kernels (their tap table or full factors); {} is a \
             disk kernel: its samples are its table, turned per pixel and frame",
            path.display()
        );
    }
    let kernel = DiskKernelFile::read(path)?;
    let setup =
        DiskSetup::new(&kernel, view, args.frame_seed, args.frames).accumulated_by(args.accumulate);
    let ema = setup.accumulate != Accumulate::Mean;
    setup
        .validate(&image)
        .with_context(|| format!("applying {}", path.display()))?;
    let n = kernel.samples_per_pixel();
    let cpu = |mut image: Image, why: &str| -> anyhow::Result<Image> {
        check_cpu_work(&image, &setup)?;
        eprintln!("backend: cpu (disk, f64{why}), {n} samples per pixel");
        apply_disk_in_place_with(&mut image, &setup, &crate::cli::progress::Bar::new())?;
        Ok(image)
    };
    match args.backend.backend {
        Backend::Cpu => cpu(image, ""),
        Backend::Gpu if ema => bail!(
            "--accumulate {}: the wgpu disk pass takes the plain mean; use --backend cpu",
            setup.accumulate.name()
        ),
        Backend::Auto if ema => cpu(image, "; auto: --accumulate ema runs on the CPU"),
        Backend::Gpu => {
            let g = DiskGpu::new()?;
            eprintln!(
                "backend: gpu (disk), adapter {}, {n} samples per pixel",
                g.describe()
            );
            Ok(g.apply(&image, &setup)?)
        }
        Backend::Auto => match ssskit::gpu::GpuContext::open() {
            Ok(ctx) if !ctx.is_software() => {
                drop(ctx);
                let g = DiskGpu::new()?;
                eprintln!("backend: gpu (auto, disk), adapter {}", g.describe());
                Ok(g.apply(&image, &setup)?)
            }
            Ok(ctx) => cpu(
                image,
                &format!(
                    "; auto: the only adapter, {}, is a software rasteriser",
                    ctx.describe()
                ),
            ),
            Err(e) => cpu(image, &format!("; auto: {e}")),
        },
    }
}
