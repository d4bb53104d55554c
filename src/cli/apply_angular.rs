//! `ssskit apply` with a kernel that carries the angular entry and exit
//! factors: the per-pixel cosines they take, from the G-buffer's
//! view-space normals, the camera of the scale flags and the light.

use super::Args;
use anyhow::{bail, Context};
use ssskit::filter::angular::{
    angular_view, check_cosines, check_normals, factor_plan, AngularView, FactorArgs, FactorPlan,
    Light,
};
use ssskit::filter::image::{read_exr_channels, read_plane};
use ssskit::filter::{Image, Scale};
use ssskit::kernel::angular::AngularFactors;
use std::path::Path;

/// The input EXR's normal channels, read when --normals is not given.
const NORMAL_CHANNELS: [&str; 3] = ["N.X", "N.Y", "N.Z"];
/// The input EXR's N.L channel, read when neither --n-dot-l nor
/// --light-toward is given.
const N_DOT_L_CHANNEL: &str = "NdotL";

/// The factors of the kernel at `path`, whatever its kind.
pub fn kernel_factors(path: &Path) -> anyhow::Result<Option<AngularFactors>> {
    Ok(if ssskit::kernel::disk::is_disk_file(path) {
        ssskit::kernel::disk::DiskKernelFile::read(path)?.angular
    } else {
        ssskit::kernel::KernelFile::read(path)?.angular
    })
}

/// Whether a flag that only the factors use was given.
pub fn any_flag(args: &Args) -> Option<&'static str> {
    if args.normals.is_some() {
        Some("--normals")
    } else if args.n_dot_l.is_some() {
        Some("--n-dot-l")
    } else if !args.light_toward.is_empty() {
        Some("--light-toward")
    } else if args.entry_weighted {
        Some("--entry-weighted")
    } else {
        None
    }
}

/// The cosines the kernel's factors take around the pass, or None (the
/// kernel carries none, --no-factors, or no normals: said in one line).
pub fn view<'a>(
    args: &Args,
    factors: Option<&'a AngularFactors>,
    image: &Image,
    scale: &Scale,
) -> anyhow::Result<Option<AngularView<'a>>> {
    let (w, h) = (image.width, image.height);
    // The normals are read only where the factors may be used.
    let normals = match factors {
        Some(_) if !args.factors.no_factors => normals(args, w, h)?,
        _ => None,
    };
    let plan = factor_plan(
        factors.is_some(),
        &FactorArgs {
            first_given: any_flag(args),
            has_normals: normals.is_some(),
            leave_out: args.factors.no_factors,
            normals_hint: "--normals IMAGE",
        },
    )?;
    if plan == FactorPlan::WithoutNormals {
        crate::cli::errors::warn(&format!(
            "the kernel carries angular entry and exit factors, but {} has no normals ({}) \
             and --normals is not given: applied without them (--no-factors says so)",
            args.input.display(),
            NORMAL_CHANNELS.join(", ")
        ));
    }
    let (FactorPlan::With, Some(f), Some(normals)) = (plan, factors, normals) else {
        return Ok(None);
    };
    let what = args
        .normals
        .as_deref()
        .unwrap_or(&args.input)
        .display()
        .to_string();
    check_normals(&what, &normals, w, h)?;
    let light = light(args, w, h)?;
    eprintln!(
        "angular factors: {}the exit factor at N.V after the pass",
        if matches!(light, Light::EntryWeighted) {
            "the input already entry-weighted (--entry-weighted), "
        } else {
            "the entry factor at N.L before the pass, "
        }
    );
    // The normals and N.L were checked, each naming its own file.
    Ok(Some(angular_view(f, &normals, light, (w, h), scale)?))
}

/// The view-space normals: --normals (R, G, B), else the input EXR's
/// [`NORMAL_CHANNELS`]; None when neither holds them.
fn normals(args: &Args, w: usize, h: usize) -> anyhow::Result<Option<[Vec<f64>; 3]>> {
    let (path, names) = match &args.normals {
        Some(p) => (p.as_path(), ["R", "G", "B"]),
        None => {
            if !super::is_exr(&args.input) || !has_channels(&args.input, &NORMAL_CHANNELS)? {
                return Ok(None);
            }
            (args.input.as_path(), NORMAL_CHANNELS)
        }
    };
    let mut planes: [Vec<f64>; 3] = Default::default();
    for (c, name) in names.iter().enumerate() {
        let p =
            read_plane(path, Some(name)).with_context(|| format!("the normals' channel {name}"))?;
        if (p.width, p.height) != (w, h) {
            bail!(
                "{}: the normals are {}x{}, the input {w}x{h}",
                path.display(),
                p.width,
                p.height
            );
        }
        planes[c] = p.data;
    }
    Ok(Some(planes))
}

/// The light of the entry factor: --entry-weighted, --light-toward,
/// --n-dot-l, else the input EXR's [`N_DOT_L_CHANNEL`].
fn light(args: &Args, w: usize, h: usize) -> anyhow::Result<Light> {
    if args.entry_weighted {
        return Ok(Light::EntryWeighted);
    }
    if !args.light_toward.is_empty() {
        let v = &args.light_toward;
        if v.len() != 3 {
            bail!(
                "--light-toward: invalid value {v:?}: three finite numbers, not all 0, expected \
                 (the view-space direction toward the light)"
            );
        }
        let v = [v[0], v[1], v[2]];
        ssskit::filter::angular::unit_direction(v)?;
        return Ok(Light::Toward(v));
    }
    let (path, channel) = match &args.n_dot_l {
        Some(p) => (p.as_path(), None),
        None if super::is_exr(&args.input) && has_channels(&args.input, &[N_DOT_L_CHANNEL])? => {
            (args.input.as_path(), Some(N_DOT_L_CHANNEL))
        }
        None => bail!(
            "the kernel's entry factor needs the light: give --light-toward X,Y,Z, --n-dot-l \
             IMAGE or --entry-weighted (or --no-factors to leave the factors out)"
        ),
    };
    let p = read_plane(path, channel)?;
    if (p.width, p.height) != (w, h) {
        bail!(
            "{}: N.L is {}x{}, the input {w}x{h}",
            path.display(),
            p.width,
            p.height
        );
    }
    let what = match channel {
        Some(c) => format!("{} (channel {c})", path.display()),
        None => format!("{} (--n-dot-l)", path.display()),
    };
    check_cosines("N.L", &p.data, w, h).with_context(|| what)?;
    Ok(Light::Cosines(p.data))
}

/// Whether the EXR at `path` has every channel of `names`.
fn has_channels(path: &Path, names: &[&str]) -> anyhow::Result<bool> {
    let (_, channels) = read_exr_channels(path)?;
    Ok(names
        .iter()
        .all(|n| channels.iter().any(|(c, _)| c.as_str() == *n)))
}
