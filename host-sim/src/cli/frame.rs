//! `host-sim frame`.

/// Render a scene with the core only (the planner's choice, or
/// --variant) and write frame.png and truth.json: the camera in
/// OpenCV's conventions and the true pixel positions of every checker
/// texture's inner corners, from the f64 reference.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file.
    #[arg(long)]
    scene: std::path::PathBuf,
    /// Output directory.
    #[arg(long)]
    out: std::path::PathBuf,
    /// A variant instead of the plan, e.g. i32f32-s1 (one sample a
    /// pixel) or i32f32-s8-adaptive (see `tradeoff`).
    #[arg(long, default_value = "planned")]
    variant: String,
    /// Frame id (the sensor noise's key).
    #[arg(long, default_value_t = 0)]
    frame_id: u32,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args {
        scene,
        out,
        variant,
        frame_id,
    } = args;
    let name = variant;
    let variant = host_sim::variant::Variant::parse(&name).map_err(|e| format!("--variant: {e}"))?;
    let resolved = host_sim::scene_file::load(&scene)?;
    let t =
        host_sim::truth::frame_to(&out, &resolved, &variant, frame_id).map_err(|e| match name.as_str() {
            "planned" => format!("{}: {e}", scene.display()),
            v => format!("{}: --variant {v}: {e}", scene.display()),
        })?;
    let corners: usize = t.checker_corners.iter().map(Vec::len).sum();
    let left_out = match t.corners_left_out {
        0 => String::new(),
        n => format!(
            " ({n} more in view not listed: at most {})",
            host_sim::truth::MAX_CORNERS
        ),
    };
    Ok(format!(
        "{}: {}x{} [{}], {corners} checker corners in view in truth.json{left_out}",
        t.scene,
        t.width,
        t.height,
        t.stages.join(" ")
    ))
}
