//! host-sim command line: parses the command and runs it (`cli/`, one
//! module a command).

mod cli;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = cli::Cli::parse();
    if let Err(e) = host_sim::output::install_signal_handler() {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    match cli.run() {
        Ok(line) => {
            if !line.is_empty() {
                println!("{line}");
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
