//! `ssskit fit --model disk`: an importance-sampled disk kernel
//! (`ssskit.disk/1`) from a profile, or a disk kernel file read back for
//! `--emit`.

use super::out::out;
use anyhow::{bail, Context};
use ssskit::kernel::disk::{DiskKernelFile, RadiusPdf};
use ssskit::kernel::disk_emit::emit_disk;
use ssskit::kernel::disk_fit::fit_disk;
use ssskit::kernel::emit::Lang;
use ssskit::profile::Profile;
use std::path::Path;

/// `--radii`: the library's [`RadiusPdf`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RadiiArg {
    Widest,
    Mean,
    PerChannel,
}

impl From<RadiiArg> for RadiusPdf {
    fn from(r: RadiiArg) -> RadiusPdf {
        match r {
            RadiiArg::Mean => RadiusPdf::Mean,
            RadiiArg::Widest => RadiusPdf::Widest,
            RadiiArg::PerChannel => RadiusPdf::PerChannel,
        }
    }
}

/// What `fit` passes on for a disk kernel.
pub struct Disk<'a> {
    pub profile: Option<&'a Path>,
    pub kernel: Option<&'a Path>,
    pub out: Option<&'a Path>,
    pub samples: usize,
    pub radii: RadiiArg,
    pub quiet: bool,
}

pub fn run(d: &Disk, lang: Option<Lang>) -> anyhow::Result<()> {
    let kernel = match (d.kernel, d.profile) {
        (Some(path), _) => DiskKernelFile::read(path)?,
        (None, Some(pp)) => {
            if d.out.is_none() && lang.is_none() {
                bail!("nothing to do: give --out KERNEL.json and/or --emit LANG");
            }
            if let Some(out) = d.out {
                ssskit::io::check_extension(out, &["json"], "kernel")?;
            }
            let profile = Profile::read(pp)?;
            let k = fit_disk(&profile, d.samples, d.radii.into())
                .with_context(|| format!("fitting a disk kernel to {}", pp.display()))?;
            if let Some(out) = d.out {
                k.write(out)?;
                DiskKernelFile::read(out)?;
            }
            k
        }
        (None, None) => bail!("give --profile and --model (or --kernel)"),
    };
    if !d.quiet {
        let s = kernel.raw_weight_sum;
        eprintln!(
            "disk ({}): {} samples per pixel, radii {}, weight sums before normalising \
             {:.6} {:.6} {:.6}",
            kernel
                .material
                .as_ref()
                .map(|m| m.name.as_str())
                .unwrap_or("?"),
            kernel.samples_per_pixel(),
            kernel.model.params["radii"].as_str().unwrap_or("?"),
            s[0],
            s[1],
            s[2]
        );
    }
    if let Some(lang) = lang {
        out!("{}", emit_disk(&kernel, lang)?)?;
    }
    Ok(())
}
