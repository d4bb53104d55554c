//! `ssskit diff` (FOUNDATION STUB: being built).

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'diff' is not built yet")
}
