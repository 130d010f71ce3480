//! `saddleflow`: the command-line front end. Thin: every command parses its arguments, calls
//! library code and prints its result. Direct physics commands print exactly one JSON object on
//! stdout; logs and progress go to stderr.

use clap::{Parser, Subcommand};

mod cluster;
mod constriction;
mod critical;
mod flow;
mod guard;
mod leakage;
mod pipeline;
mod solve;
mod surface_cmd;
mod tradeoff;

#[derive(Parser)]
#[command(
    name = "saddleflow",
    version,
    about = "Contact mechanics of and Reynolds flow through saddle points"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Solve one contact problem at a fixed mean pressure and print a JSON summary.
    Solve(solve::Args),
    /// Solve the Reynolds thin-film equation on a gap field read from HDF5.
    Flow(flow::Args),
    /// Locate the percolation threshold (L_c, a_p) of the hard-wall contact and print a JSON
    /// summary.
    Critical(critical::Args),
    /// Self-affine random surfaces (generate) and statistics of height files (stats).
    #[command(subcommand)]
    Surface(surface_cmd::Command),
    /// Leakage against load on a height file: contact, gap, flux along x and y, percolation.
    Leakage(leakage::Args),
    /// The last constriction of a height file near its fluid percolation load, and β.
    Constriction(constriction::Args),
    /// Error against cost of every headline number across fidelity presets (reads the cache):
    /// figure, tables and the README's trade table.
    Tradeoff(tradeoff::Args),
    #[command(flatten)]
    Pipeline(pipeline::Command),
}

fn main() -> std::process::ExitCode {
    guard::install_signal_handlers();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Solve(args) => solve::run(args),
        Command::Flow(args) => flow::run(args),
        Command::Critical(args) => critical::run(args),
        Command::Surface(cmd) => surface_cmd::run(cmd),
        Command::Leakage(args) => leakage::run(args),
        Command::Constriction(args) => constriction::run(args),
        Command::Tradeoff(args) => tradeoff::run(args),
        Command::Pipeline(cmd) => pipeline::run(cmd),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
