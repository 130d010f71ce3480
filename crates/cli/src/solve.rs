//! `saddleflow solve`: one contact solve. (Owner: contact core.)

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`solve` is under construction")
}
