//! `ssskit plot`: PNG plots of profiles.

use super::args::{self, OutFile};
use ssskit::profile::Profile;
use ssskit::report::present::plot;
use std::path::PathBuf;

pub type Args = args::Group<What>;

#[derive(clap::Subcommand)]
pub enum What {
    /// R_d(r) of profile files, linear and log side by side.
    ///
    /// Linear near the origin and log over the full range side by side
    /// (Freude 2014, figure 6.1), one row per channel.
    Profile(ProfileArgs),
}

#[derive(clap::Args)]
#[command(mut_arg("out", |a| args::required()(a).help("Output file: the plot, .png")))]
pub struct ProfileArgs {
    /// Profile files (JSON) to overlay.
    #[arg(required = true, value_name = "PROFILE.json")]
    files: Vec<PathBuf>,
    #[command(flatten)]
    out: OutFile,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.what {
        What::Profile(a) => {
            let out = a.out.path()?;
            let mut profiles = Vec::new();
            for f in &a.files {
                let p = Profile::read(f)?;
                let label = match (&p.source.model, p.source.kind.as_str()) {
                    (Some(m), _) => format!("{} {m}", p.material.name),
                    (None, k) => format!("{} {k}", p.material.name),
                };
                profiles.push((label, p));
            }
            let title = format!(
                "R_d(r): {}",
                a.files
                    .iter()
                    .map(|f| f
                        .file_name()
                        .unwrap_or_default()
                        .to_string_lossy()
                        .into_owned())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            let figure = ssskit::report::eval::radial::profile_figure(&profiles);
            plot::render(&plot::profile_panels(&figure), 2, &title, out)?;
            eprintln!("wrote {}", out.display());
            Ok(())
        }
    }
}
