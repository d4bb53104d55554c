//! `ssskit fit`: a separable kernel from a reflectance profile.

use super::args::{
    self, count, ExtentArg, KernelFile as KernelFileArg, ModelArg, OutFile, ProfileFile, TapsArg,
};
use super::out::out;
use anyhow::{bail, Context};
use clap::ValueEnum;
use ssskit::kernel::disk::is_disk_file;
use ssskit::kernel::emit::{emit, Lang};
use ssskit::kernel::guided::GuidedParams;
use ssskit::kernel::jimenez::JimenezParams;
use ssskit::kernel::manual::ManualParams;
use ssskit::kernel::preintegrate::PreMethod;
use ssskit::kernel::{fit_kernel_file_with, Kernel2DSpec, KernelFile, Model};
use ssskit::profile::Profile;
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum MethodArg {
    Abel,
    Grid,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum LangArg {
    Hlsl,
    Glsl,
    Wgsl,
}

impl From<LangArg> for Lang {
    fn from(l: LangArg) -> Lang {
        match l {
            LangArg::Hlsl => Lang::Hlsl,
            LangArg::Glsl => Lang::Glsl,
            LangArg::Wgsl => Lang::Wgsl,
        }
    }
}

/// Named parameter sets: the manual model's (Freude 2014, table A.1) and
/// the Gaussians model's (d'Eon et al. 2007).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PresetArg {
    /// manual (Freude 2014, table A.1).
    Apple,
    /// manual (Freude 2014, table A.1).
    Ketchup,
    /// manual (Freude 2014, table A.1).
    Marble,
    /// manual (Freude 2014, table A.1).
    Skin1,
    /// manual (Freude 2014, table A.1).
    Wholemilk,
    /// gaussians: d'Eon et al. 2007's six-Gaussian skin.
    DeonSkin,
}

#[derive(clap::Args)]
#[command(
    mut_arg("profile", |a| a.required_unless_present("kernel")
        .help("Reflectance profile file (ssskit.profile/1 JSON): the profile to fit")),
    mut_arg("kernel", |a| a.conflicts_with_all(["profile", "model"])
        .help("Kernel file (ssskit.kernel/1 JSON): read instead of fitting (validate, --emit)")),
    mut_arg("out", args::help("Output file: the kernel, .json [default: not written]")),
)]
pub struct Args {
    #[command(flatten)]
    profile: ProfileFile,
    /// Kernel model.
    #[arg(
        long,
        value_enum,
        value_name = "MODEL",
        required_unless_present = "kernel"
    )]
    model: Option<ModelArg>,
    #[command(flatten)]
    out: OutFile,
    #[command(flatten)]
    kernel: KernelFileArg,
    /// Kernel grid cells per side (odd) [default: chosen from the profile].
    #[arg(long, value_name = "N", alias = "size", value_parser = count::<usize>)]
    grid_size: Option<usize>,
    #[command(flatten)]
    extent: ExtentArg,
    #[command(flatten)]
    taps: TapsArg,
    /// Half-width in mm the taps span [default: chosen for the tap count].
    ///
    /// The default is the radius holding 1 - 0.7 taps^-1.2 of the factor's
    /// mass; for jimenez, iryoku's span: RANGE x width, RANGE 2 below 21
    /// taps and 3 from 21.
    #[arg(long, value_name = "MM", allow_negative_numbers = true, value_parser = args::real)]
    tap_extent: Option<f64>,
    /// Print the tap table as a shader constant array [default: not printed].
    #[arg(long, value_enum, value_name = "LANG", ignore_case = true)]
    emit: Option<LangArg>,
    /// Thickness table (`ssskit transmission --out`): fitted for shaders [default: none].
    ///
    /// The kernel file carries the transmittance through a thickness as two
    /// exponentials per channel fitted to the table, with the fit's error;
    /// --emit writes it as sss_transmittance(thickness_mm).
    #[arg(long, value_name = "TABLE.json")]
    transmission: Option<PathBuf>,
    #[command(flatten)]
    opts: Box<ModelOpts>,
    /// Do not print the summary.
    #[arg(long, short)]
    quiet: bool,
}

/// Model parameters (boxed: they make the argument struct large).
#[derive(clap::Args)]
pub struct ModelOpts {
    /// svd: number of separable terms.
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = count::<usize>)]
    rank: usize,
    /// svd: scale to the ground truth's 1-norm (Freude 2014, eq. 5.12).
    #[arg(long)]
    renormalize: bool,
    /// preintegrate: Abel projection of the profile or row sums of the grid.
    #[arg(long, value_enum, value_name = "METHOD", default_value_t = MethodArg::Abel)]
    method: MethodArg,
    /// guided: exponent of the radial weight (Freude 2014, eq. 5.20).
    #[arg(long, value_name = "K", default_value_t = GuidedParams::default().k, allow_negative_numbers = true, value_parser = args::real)]
    k: f64,
    /// guided: axis suppression (Freude 2014, eq. 5.20, for x, y in [-1, 1]); 0 = off.
    #[arg(long, value_name = "B", default_value_t = GuidedParams::default().b, allow_negative_numbers = true, value_parser = args::real)]
    b: f64,
    /// guided: L-BFGS iteration limit.
    #[arg(long, value_name = "N", default_value_t = GuidedParams::default().max_iters, value_parser = count::<u64>)]
    max_iters: u64,
    /// manual: weight of the near Gaussian [default: none: give --w, --near, --far].
    #[arg(long, value_name = "W", allow_negative_numbers = true, value_parser = args::real)]
    w: Option<f64>,
    /// manual: sqrt(tau_n) per channel in mm, "R,G,B" [default: none].
    #[arg(long, value_name = "R,G,B", value_parser = args::rgb)]
    near: Option<[f64; 3]>,
    /// manual: sqrt(tau_f) per channel in mm, "R,G,B" [default: none].
    #[arg(long, value_name = "R,G,B", value_parser = args::rgb)]
    far: Option<[f64; 3]>,
    /// manual or gaussians: a published parameter set [default: none].
    #[arg(long, value_enum, value_name = "NAME", ignore_case = true)]
    preset: Option<PresetArg>,
    /// manual: find w, tau_n, tau_f by least squares in kernel space.
    #[arg(long)]
    fit: bool,
    /// gaussians: number of 2D Gaussians.
    #[arg(long, value_name = "N", default_value_t = ssskit::kernel::gaussians::DEFAULT_COUNT, value_parser = count::<usize>)]
    count: usize,
    /// jimenez: mm per unit of the kernel's offsets (w = 1: d'Eon's skin
    /// profile in mm, iryoku's table in its offset units).
    #[arg(long, value_name = "SCALE", alias = "width", default_value_t = JimenezParams::default().width, allow_negative_numbers = true, value_parser = args::real)]
    jimenez_width: f64,
    /// jimenez: strength t per channel, "R,G,B".
    #[arg(long, value_name = "R,G,B", alias = "strength", default_value = args::rgb_text(JimenezParams::default().strength), value_parser = args::rgb)]
    jimenez_strength: [f64; 3],
    /// jimenez: falloff f per channel, "R,G,B".
    #[arg(long, value_name = "R,G,B", alias = "falloff", default_value = args::rgb_text(JimenezParams::default().falloff), value_parser = args::rgb)]
    jimenez_falloff: [f64; 3],
    #[arg(long, value_name = "N", value_parser = count::<usize>, help = samples_help())]
    samples: Option<usize>,
    /// disk: the density the radii are drawn from [default: widest].
    ///
    /// widest: one set from the widest channel (the engines' choice, the
    /// least noise in the worst channel, measured in docs/kernels.md);
    /// mean: one set from the mean of the channels' kernels, weights below
    /// 3; per-channel: N radii per channel, 3 N fetches.
    #[arg(long, value_enum, value_name = "PDF")]
    radii: Option<super::fit_disk::RadiiArg>,
}

/// `--samples`' help, with the library's bounds and default.
fn samples_help() -> String {
    use ssskit::kernel::disk::{DEFAULT_SAMPLES, MAX_SAMPLES, MIN_SAMPLES};
    format!(
        "disk: samples per pixel (per channel with --radii per-channel), {MIN_SAMPLES} to \
         {MAX_SAMPLES} [default: {DEFAULT_SAMPLES}]"
    )
}

/// The first flag of a disk kernel (`--samples`, `--radii`) given to a
/// separable model, or of a separable kernel given to a disk one: each
/// kind refuses the other's settings rather than ignore them.
fn other_kinds_flag(a: &Args, disk: bool) -> Option<&'static str> {
    let given = if disk {
        vec![
            ("--grid-size", a.grid_size.is_some()),
            ("--extent", a.extent.extent.is_some()),
            ("--tap-extent", a.tap_extent.is_some()),
        ]
    } else {
        vec![
            ("--samples", a.opts.samples.is_some()),
            ("--radii", a.opts.radii.is_some()),
        ]
    };
    given.into_iter().find(|(_, g)| *g).map(|(f, _)| f)
}

fn model(a: &Args, m: ModelArg) -> anyhow::Result<Model> {
    Ok(match m {
        ModelArg::Svd => Model::Svd {
            rank: a.opts.rank,
            renormalize: a.opts.renormalize,
        },
        ModelArg::Preintegrate => Model::Preintegrate {
            method: match a.opts.method {
                MethodArg::Abel => PreMethod::Abel,
                MethodArg::Grid => PreMethod::Grid,
            },
        },
        ModelArg::Guided => Model::Guided(GuidedParams {
            k: a.opts.k,
            b: a.opts.b,
            max_iters: a.opts.max_iters,
        }),
        ModelArg::Manual => {
            let explicit = a.opts.w.is_some() || a.opts.near.is_some() || a.opts.far.is_some();
            match (a.opts.preset, a.opts.fit, explicit) {
                (Some(PresetArg::DeonSkin), _, _) => {
                    bail!("manual: --preset deon-skin is a preset of --model gaussians")
                }
                (Some(p), false, false) => Model::ManualPreset(args::flag_value(&p)),
                (None, true, false) => Model::ManualFit,
                (None, false, true) => {
                    let (Some(w), Some(n), Some(f)) = (a.opts.w, a.opts.near, a.opts.far) else {
                        bail!("manual: give all of --w, --near and --far (or --preset / --fit)");
                    };
                    Model::Manual(ManualParams {
                        w,
                        sqrt_tau_near: n,
                        sqrt_tau_far: f,
                    })
                }
                _ => bail!(
                    "manual: give exactly one of --preset NAME, --fit, or --w W --near R,G,B --far R,G,B"
                ),
            }
        }
        ModelArg::Gaussians => match a.opts.preset {
            None => Model::Gaussians {
                count: a.opts.count,
            },
            Some(PresetArg::DeonSkin) => Model::DeonSkin,
            Some(p) => bail!(
                "gaussians: --preset {} is a preset of --model manual (gaussians has deon-skin)",
                args::flag_value(&p)
            ),
        },
        ModelArg::Jimenez => Model::Jimenez(JimenezParams {
            width: a.opts.jimenez_width,
            strength: a.opts.jimenez_strength,
            falloff: a.opts.jimenez_falloff,
        }),
        ModelArg::Disk => bail!("disk kernels are fitted by fit_disk"),
    })
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let lang = a.emit.map(Lang::from);
    let disk = matches!(a.model, Some(ModelArg::Disk))
        || a.kernel.kernel.as_deref().is_some_and(is_disk_file);
    if let Some(flag) = other_kinds_flag(&a, disk) {
        match a.model {
            Some(m) => bail!(
                "{flag}: a setting of {} kernels; --model {} is {}",
                if disk { "separable" } else { "disk" },
                args::flag_value(&m),
                if disk { "a disk kernel" } else { "separable" }
            ),
            None if a.profile.profile.is_none() => bail!(
                "{flag}: a setting of a fit (--profile with --model); --kernel reads a kernel \
                 file as it is"
            ),
            None => {}
        }
    }
    if disk {
        let disk = super::fit_disk::Disk {
            profile: a.profile.profile.as_deref(),
            kernel: a.kernel.kernel.as_deref(),
            out: a.out.out.as_deref(),
            samples: a
                .opts
                .samples
                .unwrap_or(ssskit::kernel::disk::DEFAULT_SAMPLES),
            radii: a.opts.radii.unwrap_or(super::fit_disk::RadiiArg::Widest),
            quiet: a.quiet,
        };
        return super::fit_disk::run(&disk, lang);
    }
    let kernel = if let Some(path) = &a.kernel.kernel {
        KernelFile::read(path)?
    } else {
        let (Some(pp), Some(m)) = (&a.profile.profile, a.model) else {
            bail!("give --profile and --model (or --kernel)")
        };
        if a.out.out.is_none() && lang.is_none() {
            bail!("nothing to do: give --out KERNEL.json and/or --emit LANG");
        }
        if let Some(out) = &a.out.out {
            ssskit::io::check_extension(out, &["json"], "kernel")?;
        }
        let profile = Profile::read(pp)?;
        let table = match &a.transmission {
            Some(t) => Some(ssskit::profile::transmission::ThicknessTable::read(t)?),
            None => None,
        };
        let spec = Kernel2DSpec {
            size: a.grid_size,
            extent_mm: a.extent.extent,
        };
        let m = model(&a, m)?;
        let mut k = fit_kernel_file_with(&profile, &spec, &m, a.taps.taps, a.tap_extent)
            .with_context(|| format!("fitting a kernel to {}", pp.display()))?;
        if let Some(t) = &table {
            k.transmission =
                Some(ssskit::kernel::transmission::fit_table(t).context("--transmission")?);
        }
        if let Some(out) = &a.out.out {
            k.write(out)?;
            // Read back what was written: the file must load as is (a
            // device or a pipe, written in place, has nothing to read back).
            if !ssskit::io::writes_in_place(out) {
                KernelFile::read(out)?;
            }
        }
        if !a.quiet {
            summary(&k);
        }
        k
    };
    if let Some(lang) = lang {
        let source = a.kernel.kernel.as_ref().or(a.profile.profile.as_ref());
        let text = emit(&kernel, lang).with_context(|| {
            format!(
                "--emit: the kernel of {}",
                source.map_or("?".into(), |p| p.display().to_string())
            )
        })?;
        out!("{}", text)?;
    } else if a.kernel.kernel.is_some() && !a.quiet {
        summary(&kernel);
    }
    Ok(())
}

fn summary(k: &KernelFile) {
    let m = &k.metrics;
    let f = |v: [f64; 3]| format!("{:.3e} {:.3e} {:.3e}", v[0], v[1], v[2]);
    eprintln!(
        "{} ({}): {} passes, kernel_rms {}, norm1_error {}, asymmetry {}, {:.3} s",
        k.model.name,
        k.material.as_ref().map(|m| m.name.as_str()).unwrap_or("?"),
        m.passes,
        f(m.kernel_rms),
        f(m.norm1_error),
        f(m.asymmetry),
        m.fit_seconds
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_manual_preset_flag_value_names_a_library_preset() {
        for p in PresetArg::value_variants() {
            let known = ssskit::kernel::manual::preset(&args::flag_value(p)).is_ok();
            assert_eq!(known, *p != PresetArg::DeonSkin, "{p:?}");
        }
    }
}
