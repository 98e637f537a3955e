//! `host-sim camera`.

/// Be the camera on a serial device (a real port or a pty): obey the
/// commands that arrive (docs/wire.md), stream the frames they ask for
/// with their ground truth, until the other end hangs up.
#[derive(clap::Args)]
pub struct Args {
    /// Serial device.
    #[arg(long)]
    device: String,
    /// Baud rate.
    #[arg(long, default_value_t = 115_200)]
    baud: u32,
    /// The scenes it holds, in SelectScene id order (default: the shipped
    /// scenes, built into the binary, sorted by file name, as the
    /// firmware).
    #[arg(long, num_args = 1..)]
    scene: Vec<std::path::PathBuf>,
    /// Write the raw bytes it sends to this file.
    #[arg(long)]
    capture: Option<std::path::PathBuf>,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args {
        device,
        baud,
        scene,
        capture,
    } = args;
    host_sim::link::serial::check_baud(baud)?;
    let scenes = if scene.is_empty() {
        host_sim::shipped::shipped()?
    } else {
        scene
            .iter()
            .map(|p| host_sim::scene_file::load(p))
            .collect::<Result<Vec<_>, _>>()?
    };
    // A scene it cannot hold, named by its file, before the port opens.
    host_sim::camera_cmd::check_held(&scenes).map_err(|(id, e)| match scene.get(id) {
        Some(p) => format!("{}: {e}", p.display()),
        None => format!("scenes/{}.toml (built in): {e}", host_sim::shipped::SHIPPED[id].0),
    })?;
    let s = host_sim::camera_cmd::serve_device(&device, baud, &scenes, capture.as_deref())?;
    Ok(format!(
        "camera on {device}: {} requests ({} acknowledged, {} refused), {} frames sent; \
         {:?} messages refused (oversize, COBS, CRC, malformed)",
        s.requests, s.acks, s.rejects, s.frames, s.refused
    ))
}
