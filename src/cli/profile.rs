//! `ssskit profile`: an analytic reflectance profile (dipole, photon beam
//! diffusion, normalized diffusion, directional dipole) as a profile file.

use super::args::{self, ChannelsArg, FresnelArg, GridArgs, MaterialArg, OutFile, ProfileModelArg};
use super::errors::invalid;
use ssskit::material::Material;
use ssskit::profile::analytic::{self, Options};
use ssskit::profile::GridSpec;

#[derive(clap::Args)]
#[command(
    mut_arg("material", |a| args::required()(a)
        .help("Material: a preset name or a TOML file, one semi-infinite layer")),
    mut_arg("profile_model", |a| args::required()(a).alias("model")),
    mut_arg("out", args::help("Output file: the profile, .json [default: <material>-<model>.json]")),
)]
pub struct Args {
    #[command(flatten)]
    material: MaterialArg,
    #[command(flatten)]
    model: ProfileModelArg,
    #[command(flatten)]
    grid: GridArgs,
    #[command(flatten)]
    fresnel: FresnelArg,
    #[command(flatten)]
    channels: ChannelsArg,
    #[command(flatten)]
    out: OutFile,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Some(name) = &args.material.material else {
        anyhow::bail!("give --material NAME");
    };
    let Some(model_arg) = args.model.profile_model else {
        anyhow::bail!("give --profile-model MODEL");
    };
    let Some(model) = model_arg.analytic() else {
        return Err(invalid(
            "--profile-model",
            args::flag_value(&model_arg),
            "`profile` computes the analytic models; Monte Carlo is `ssskit simulate`",
        ));
    };
    let material = Material::load(name)?;
    let default_out = std::path::PathBuf::from(format!("{}-{}.json", material.name, model.name()));
    let out = args.out.out.as_deref().unwrap_or(&default_out);
    ssskit::io::check_extension(out, &["json"], "profile")?;
    let channels = args.channels.channels()?;
    let spec = GridSpec {
        dr: args.grid.dr,
        r_max: args.grid.rmax,
        log_bins: false,
    };
    let grid = spec.grid(&material, &channels)?;
    let options = Options {
        fresnel: args.fresnel.fresnel.into(),
        channels,
    };
    let p = analytic::profile(&material, model, &grid, &options)?;
    p.validate(&out.display().to_string())?;
    p.write(out)?;
    let totals: Vec<String> = p
        .channels
        .iter()
        .zip(&p.total_rd)
        .map(|(c, t)| format!("{}={t:.5}", c.name()))
        .collect();
    eprintln!(
        "{} {}: {} bins to {:.4} mm, total R_d {} ({:.2} ms) -> {}",
        material.name,
        model.name(),
        grid.len(),
        grid.r_max(),
        totals.join(" "),
        p.elapsed_s * 1e3,
        out.display()
    );
    Ok(())
}
