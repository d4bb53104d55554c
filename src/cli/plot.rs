//! `ssskit plot` (FOUNDATION STUB: being built).

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'plot' is not built yet")
}
