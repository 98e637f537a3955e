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
    /// Render a scene with the core and the f64 reference; write frame.png,
    /// reference.png, diff.png and metrics.json into OUT.
    Render {
        /// Scene file (TOML, see docs/scenes.md).
        #[arg(long)]
        scene: std::path::PathBuf,
        /// Output directory.
        #[arg(long)]
        out: std::path::PathBuf,
        /// Geometric error budget for the planner, px.
        #[arg(long, default_value_t = 1.0 / 256.0)]
        max_geom_err_px: f64,
        /// Pixel-value error budget for the planner, LSB.
        #[arg(long, default_value_t = 1.0)]
        max_lsb: f64,
    },
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
        Cmd::Render {
            scene,
            out,
            max_geom_err_px,
            max_lsb,
        } => {
            let run = || -> Result<String, String> {
                let budget = hilcam::planner::Budget {
                    max_geom_err_px,
                    max_lsb,
                };
                if !(max_geom_err_px > 0.0 && max_geom_err_px.is_finite()) {
                    return Err("--max-geom-err-px: must be a positive number".into());
                }
                if !(max_lsb > 0.0 && max_lsb.is_finite()) {
                    return Err("--max-lsb: must be a positive number".into());
                }
                let resolved = host_sim::scene_file::load(&scene)?;
                let o = host_sim::render_cmd::render(&resolved, &budget)?;
                host_sim::render_cmd::write(&out, &o)?;
                Ok(host_sim::render_cmd::summary(&o.metrics))
            };
            match run() {
                Ok(line) => {
                    println!("{line}");
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            }
        }
    }
}
