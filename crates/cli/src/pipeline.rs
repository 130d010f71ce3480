//! Pipeline commands: run, run-stage, status, gc, graph. (Owner: orchestrator.)

#[derive(clap::Subcommand)]
pub enum Command {
    /// Run the pipeline (under construction).
    Run,
}

pub fn run(_cmd: Command) -> anyhow::Result<()> {
    anyhow::bail!("pipeline commands are under construction")
}
