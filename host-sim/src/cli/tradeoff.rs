//! `host-sim tradeoff`.

/// Measure the speed/accuracy trade: every variant's fidelity against the
/// f64 reference, its instructions per pixel on the M3 and the M4F in
/// QEMU, host ns per pixel, table and flash bytes; growth with resolution
/// and primitives; what the planner's pruning saves. Writes tradeoff.json,
/// tradeoff.md and tradeoff.png.
#[derive(clap::Args)]
pub struct Args {
    /// Output directory.
    #[arg(long)]
    out: std::path::PathBuf,
    /// A tiny sweep (a 40x30 scene, four variants, no growth or
    /// pruning runs): checks that the sweep works.
    #[arg(long)]
    tiny: bool,
    /// Boards to measure on, comma-separated (lm3s6965evb, mps2-an386),
    /// or "none" for the host only.
    #[arg(long, default_value = "lm3s6965evb,mps2-an386")]
    boards: String,
    /// Host timing repeats (the median is reported; 1 to 1000).
    #[arg(long, default_value_t = 7)]
    repeats: usize,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args {
        out,
        tiny,
        boards,
        repeats,
    } = args;
    if !(1..=1000).contains(&repeats) {
        return Err("--repeats: must be 1 to 1000".into());
    }
    let boards = if boards == "none" {
        Vec::new()
    } else {
        boards
            .split(',')
            .map(|b| host_sim::qemu::Board::parse(b).map_err(|e| e.replacen("--board:", "--boards:", 1)))
            .collect::<Result<Vec<_>, _>>()?
    };
    let cfg = if tiny {
        host_sim::tradeoff::Config::tiny(boards, repeats)
    } else {
        host_sim::tradeoff::Config::full(boards, repeats)
    };
    host_sim::tradeoff::run(&cfg, &out)
}
