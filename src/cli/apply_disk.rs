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

/// The disk kernel at `path`, after refusing the flags of separable
/// kernels.
pub fn read(args: &Args, path: &Path) -> anyhow::Result<DiskKernelFile> {
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
    Ok(DiskKernelFile::read(path)?)
}

/// Which frames run and why: `given` by --frames, or the kernel's
/// recorded accumulation, or one frame where it records none.
pub fn frames_note(kernel: &DiskKernelFile, given: Option<u32>, frames: u32, first: u32) -> String {
    let run = format!("frames: {frames} from frame seed {first}");
    match (given, &kernel.accumulation) {
        (None, Some(a)) => format!(
            "{run}: {}, as the kernel's predicted error assumes (--frames N to change)",
            a.describe()
        ),
        (None, None) => format!(
            "{run}: the kernel records no frames (it carries no predicted error), one frame is \
             assumed (--frames N accumulates N)"
        ),
        (Some(_), Some(a)) if a.frames == frames => {
            format!("{run} (--frames), as the kernel's predicted error assumes")
        }
        (Some(_), Some(a)) => format!(
            "{run} (--frames), where the kernel's predicted error assumes {}: the noise differs \
             from the prediction's by about sqrt({} / {frames})",
            a.describe(),
            a.frames
        ),
        (Some(_), None) => format!("{run} (--frames)"),
    }
}

/// The disk pass over `image` for (frames, first frame seed): the CPU
/// filters it in place (docs/filter.md).
pub fn run(
    args: &Args,
    path: &Path,
    kernel: &DiskKernelFile,
    (frames, first): (u32, u32),
    view: Setup,
    image: Image,
) -> anyhow::Result<Image> {
    let setup = DiskSetup::new(kernel, view, first, frames).accumulated_by(args.accumulate);
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
