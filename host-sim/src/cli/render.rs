//! `host-sim render`.

/// Render a scene with the core and the f64 reference; write frame.png,
/// reference.png, diff.png and metrics.json into OUT.
#[derive(clap::Args)]
pub struct Args {
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
    /// Budget for edge pixels differing from the reference, as a
    /// fraction of all pixels (the planner's estimate).
    #[arg(long, default_value_t = 0.0005)]
    max_edge_differing: f64,
    /// Render even when no way of rendering the scene is predicted to
    /// meet the budget (by default such a scene is refused, and nothing
    /// is written).
    #[arg(long)]
    allow_over_budget: bool,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args {
        scene,
        out,
        max_geom_err_px,
        max_lsb,
        max_edge_differing,
        allow_over_budget,
    } = args;
    let budget = hilcam::planner::Budget {
        max_geom_err_px,
        max_lsb,
        max_edge_differing,
        ..Default::default()
    };
    if !(0.0..=1.0).contains(&max_edge_differing) {
        return Err("--max-edge-differing: must lie in [0, 1]".into());
    }
    if !(max_geom_err_px > 0.0 && max_geom_err_px <= 1e3) {
        return Err("--max-geom-err-px: must lie in (0, 1000] px".into());
    }
    if !(max_lsb > 0.0 && max_lsb <= 65_535.0) {
        return Err("--max-lsb: must lie in (0, 65535]".into());
    }
    let resolved = host_sim::scene_file::load(&scene)?;
    let m = host_sim::render_cmd::render_to(&out, &resolved, &budget, allow_over_budget)
        .map_err(|e| format!("{}: {e}", scene.display()))?;
    Ok(format!(
        "{}\n{}",
        host_sim::render_cmd::summary(&m),
        host_sim::render_cmd::plan_text(&m.plan).trim_end()
    ))
}
