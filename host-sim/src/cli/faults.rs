//! `host-sim faults`.

use host_sim::output::Outputs;

/// The standard scene, built in so that `faults` works wherever the binary is.
const STANDARD_SCENE: &str = include_str!("../../../scenes/standard.toml");

/// Run the standard fault campaign (12 000 frames of the standard scene)
/// and write faults.json.
#[derive(clap::Args)]
pub struct Args {
    /// Output directory.
    #[arg(long)]
    out: std::path::PathBuf,
    /// Scale the campaign's frame counts (1 = 12 000 frames; at most 100).
    #[arg(long, default_value_t = 1.0)]
    scale: f64,
    /// The scene to send (default: the standard scene, built in).
    #[arg(long)]
    scene: Option<std::path::PathBuf>,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args { out, scale, scene } = args;
    if !(scale > 0.0 && scale <= 100.0) {
        return Err("--scale: must lie in (0, 100]".into());
    }
    let standard = match &scene {
        Some(p) => host_sim::scene_file::load(p)?,
        None => host_sim::scene_file::parse(STANDARD_SCENE)
            .map_err(|e| format!("the built-in standard scene: {e}"))?,
    };
    let mut outputs = Outputs::prepare(&out)?;
    let report = host_sim::stream_cmd::campaign(&standard, scale, &mut |name| eprintln!("  {name}"))?;
    let json = serde_json::to_vec_pretty(&report).map_err(|e| e.to_string())?;
    outputs.write("faults.json", &json)?;
    outputs.commit()?;
    Ok(format!(
        "fault campaign: {} frames sent, {} hit by faults, {} delivered intact, \
         {} corrupted accepted, {} intact lost; {} intact messages, {} of them lost; \
         link efficiency {:.4} ({})",
        report.totals.frames_sent,
        report.totals.frames_hit_by_faults,
        report.totals.frames_delivered_intact,
        report.totals.corrupted_frames_accepted,
        report.totals.intact_frames_lost,
        report.totals.untouched_messages,
        report.totals.untouched_messages_lost,
        report.link_efficiency,
        report.frame
    ))
}
