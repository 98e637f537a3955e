//! `host-sim costfit`.

/// Fit the planner's cost model: calibration scenes rendered on the M3
/// in QEMU with each arithmetic, least squares per arithmetic, and the
/// shipped scenes' predicted against measured cost. Writes costfit.json
/// and costfit.md.
#[derive(clap::Args)]
pub struct Args {
    /// Output directory.
    #[arg(long)]
    out: std::path::PathBuf,
    /// Measure only the points through the aperture, and keep the
    /// others of this calibration file (docs/cost-calibration.json).
    #[arg(long)]
    keep: Option<std::path::PathBuf>,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args { out, keep } = args;
    host_sim::qemu::Board::parse("lm3s6965evb").and_then(|b| host_sim::costfit::run(b, &out, keep.as_deref()))
}
