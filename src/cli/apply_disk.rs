//! `ssskit apply` with a disk kernel (`ssskit.disk/1`): the disk pass over
//! --frames rotations, on the CPU (f64) or with wgpu.

use super::Args;
use crate::cli::args::Backend;
use anyhow::{bail, Context};
use ssskit::filter::disk::{apply_disk, DiskSetup};
use ssskit::filter::{Image, Setup};
use ssskit::kernel::disk::DiskKernelFile;
use std::path::Path;

pub fn run(args: &Args, path: &Path, view: Setup, image: &Image) -> anyhow::Result<Image> {
    if args.taps_only || args.jitter {
        bail!(
            "--taps-only and --jitter apply to separable kernels; {} is a disk kernel (its \
             samples are its table, turned per pixel and frame)",
            path.display()
        );
    }
    let kernel = DiskKernelFile::read(path)?;
    let setup = DiskSetup::new(&kernel, view, args.frame_seed, args.frames);
    setup
        .validate(image)
        .with_context(|| format!("applying {}", path.display()))?;
    match args.backend.backend {
        Backend::Gpu => bail!("--backend gpu: the disk pass runs on the CPU only for now"),
        Backend::Cpu | Backend::Auto => {
            eprintln!(
                "backend: cpu (disk, f64), {} samples per pixel",
                kernel.samples_per_pixel()
            );
            Ok(apply_disk(image, &setup)?)
        }
    }
}
