//! `saddleflow flow`: Reynolds flow on a gap field. (Owner: reynolds.)

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`flow` is under construction")
}
