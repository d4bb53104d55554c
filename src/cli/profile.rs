//! `ssskit profile`: an analytic reflectance profile (dipole, photon beam
//! diffusion, normalized diffusion, directional dipole) as a profile file.

use clap::ValueEnum;
use ssskit::material::{Channel, Material};
use ssskit::profile::analytic::{self, Model, Options};
use ssskit::profile::fresnel::FresnelMode;
use ssskit::profile::GridSpec;
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ModelArg {
    /// Standard dipole (Jensen et al. 2001), closed-form total.
    Dipole,
    /// Photon beam diffusion (Habel et al. 2013), multiple + single scattering.
    Pbd,
    /// Normalized diffusion (Christensen and Burley 2015).
    Burley,
    /// Directional dipole (Frisvad et al. 2014) at normal incidence.
    DirectionalDipole,
}

impl From<ModelArg> for Model {
    fn from(m: ModelArg) -> Model {
        match m {
            ModelArg::Dipole => Model::Dipole,
            ModelArg::Pbd => Model::Pbd,
            ModelArg::Burley => Model::Burley,
            ModelArg::DirectionalDipole => Model::DirectionalDipole,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum FresnelArg {
    /// Polynomial fits of the Fresnel moments (d'Eon and Irving 2011).
    Fit,
    /// Numerical integration of the exact Fresnel reflectance.
    Exact,
}

impl From<FresnelArg> for FresnelMode {
    fn from(f: FresnelArg) -> FresnelMode {
        match f {
            FresnelArg::Fit => FresnelMode::Fit,
            FresnelArg::Exact => FresnelMode::Exact,
        }
    }
}

#[derive(clap::Args)]
pub struct Args {
    /// Material preset name or TOML file (must be one semi-infinite layer).
    #[arg(long)]
    material: String,
    /// Profile model.
    #[arg(long, value_enum)]
    model: ModelArg,
    /// Radial bin width in mm (default: min MFP / 20, Freude 2014, table 6.1).
    #[arg(long, allow_negative_numbers = true)]
    dr: Option<f64>,
    /// Largest radius in mm (default: 32 max MFP, Freude 2014, table 6.1).
    #[arg(long, allow_negative_numbers = true)]
    rmax: Option<f64>,
    /// Fresnel moments: polynomial fits or exact integration.
    #[arg(long, value_enum, default_value = "fit")]
    fresnel: FresnelArg,
    /// Channels to compute, e.g. "rgb" or "g".
    #[arg(long, default_value = "rgb")]
    channels: String,
    /// Output profile (JSON).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    ssskit::io::check_extension(&args.out, &["json"], "profile")?;
    let material = Material::load(&args.material)?;
    let channels = Channel::parse_list(&args.channels)?;
    let spec = GridSpec {
        dr: args.dr,
        r_max: args.rmax,
        log_bins: false,
    };
    let grid = spec.grid(&material, &channels)?;
    let options = Options {
        fresnel: args.fresnel.into(),
        channels,
    };
    let p = analytic::profile(&material, args.model.into(), &grid, &options)?;
    p.validate(&args.out.display().to_string())?;
    p.write(&args.out)?;
    let totals: Vec<String> = p
        .channels
        .iter()
        .zip(&p.total_rd)
        .map(|(c, t)| format!("{}={t:.5}", c.name()))
        .collect();
    eprintln!(
        "{} {}: {} bins to {:.4} mm, total R_d {} ({:.2} ms) -> {}",
        material.name,
        Model::from(args.model).name(),
        grid.len(),
        grid.r_max(),
        totals.join(" "),
        p.elapsed_s * 1e3,
        args.out.display()
    );
    Ok(())
}
