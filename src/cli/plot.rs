//! `ssskit plot`: PNG plots of profiles.

use ssskit::profile::Profile;
use ssskit::report::plot;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(clap::Subcommand)]
enum What {
    /// R_d(r) of one or more profile files: linear near the origin and log
    /// over the full range side by side (Freude 2014, figure 6.1), one row per channel.
    Profile {
        /// Profile files (JSON) to overlay.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Output PNG.
        #[arg(long)]
        out: PathBuf,
    },
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.what {
        What::Profile { files, out } => {
            let mut profiles = Vec::new();
            for f in &files {
                let p = Profile::read(f)?;
                let label = match (&p.source.model, p.source.kind.as_str()) {
                    (Some(m), _) => format!("{} {m}", p.material.name),
                    (None, k) => format!("{} {k}", p.material.name),
                };
                profiles.push((label, p));
            }
            let title = format!(
                "R_d(r): {}",
                files
                    .iter()
                    .map(|f| f
                        .file_name()
                        .unwrap_or_default()
                        .to_string_lossy()
                        .into_owned())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            plot::render(&plot::profile_panels(&profiles), 2, &title, &out)?;
            eprintln!("wrote {}", out.display());
            Ok(())
        }
    }
}
