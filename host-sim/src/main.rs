//! host-sim command line.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "hilcam host harness: reference models, comparisons, links"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Project a demo camera's points and compute its lens figures with the
    /// fixed-point core and the f64 reference, and print both with the errors.
    Demo,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.cmd {
        Cmd::Demo => match host_sim::demo::run() {
            Ok((text, errs)) => {
                print!("{text}");
                if errs.max_px <= 1.0 / 256.0 && errs.max_lens_rel <= 1e-4 {
                    ExitCode::SUCCESS
                } else {
                    eprintln!("error: the core missed a target against the reference");
                    ExitCode::FAILURE
                }
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        },
    }
}
