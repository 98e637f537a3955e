//! `host-sim drive`.

/// Drive the camera firmware in QEMU (UART0 both ways) along a
/// trajectory: SetPose and Trigger for each pose; check every frame byte
/// for byte against the host render of that pose and its ground truth
/// against the pose sent. Writes frame-N.png, frame-N.json (the frame's
/// ground truth) and drive.json.
#[derive(clap::Args)]
pub struct Args {
    /// A board of firmware/boards.toml: lm3s6965evb (Cortex-M3),
    /// mps2-an386 (M4F), microbit (M0, 16 KiB of RAM), mps2-an505 (M33),
    /// mps2-an500 (M7).
    #[arg(long, default_value = "lm3s6965evb")]
    board: String,
    /// The scene, sent to the camera as data (LoadScene) before the
    /// poses: any scene file, shipped or not.
    #[arg(long, default_value = "scenes/standard.toml")]
    scene: std::path::PathBuf,
    /// Frames (poses sampled evenly over the trajectory).
    #[arg(long, default_value_t = 30)]
    frames: usize,
    /// Keyframes: JSON lines {"t", "position", "quaternion": [w, x, y,
    /// z]} or CSV t,x,y,z,qw,qx,qy,qz (default: a small loop around the
    /// scene's pose).
    #[arg(long)]
    poses: Option<std::path::PathBuf>,
    /// Write the raw bytes the camera sent to this file.
    #[arg(long)]
    capture: Option<std::path::PathBuf>,
    /// Drive the camera on this serial device (a real port or a pty)
    /// instead of the firmware in QEMU.
    #[arg(long)]
    device: Option<String>,
    /// Baud rate of --device.
    #[arg(long, default_value_t = 115_200)]
    baud: u32,
    /// Send each pose and its trigger in one write, as a system under
    /// test that fires both at once (default: the trigger after the
    /// pose's answer).
    #[arg(long)]
    batched: bool,
    /// Output directory.
    #[arg(long)]
    out: std::path::PathBuf,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args {
        board,
        scene,
        frames,
        poses,
        capture,
        device,
        baud,
        batched,
        out,
    } = args;
    if frames == 0 {
        return Err("--frames: at least 1".into());
    }
    use host_sim::drive_cmd::{drive_target, Target};
    let target = match device {
        Some(path) => Target::Device { path, baud },
        None => Target::Qemu(host_sim::qemu::Board::parse(&board)?),
    };
    let r = drive_target(
        &target,
        &scene,
        poses.as_deref(),
        frames,
        capture.as_deref(),
        batched,
        &out,
    )?;
    let s = format!(
        "{} {}: {} of {} frames received, {} bit-exact ({} pixels outside the lens field, flagged), \
         {} with matching ground truth, {} lost, \
         {} out of order, {} commands resent; round trip (Trigger -> first byte) mean {:.0} / max {:.0} \
         instructions, mean {:.1} / max {:.1} ms wall; {:.1} s",
        r.board,
        r.scene,
        r.frames_received,
        r.frames_requested,
        r.bit_exact,
        r.frames.iter().map(|f| u64::from(f.outside_field)).sum::<u64>(),
        r.truth_matches,
        r.lost,
        r.out_of_order,
        r.resent,
        r.round_trip_instructions.map_or(f64::NAN, |v| v[0]),
        r.round_trip_instructions.map_or(f64::NAN, |v| v[1]),
        r.round_trip_wall_ms[0],
        r.round_trip_wall_ms[1],
        r.seconds
    );
    let s = match r.instructions_per_pixel {
        Some([mean, max]) => {
            format!("{s}; a frame mean {mean:.1} / max {max:.1} instructions a pixel")
        }
        None => s,
    };
    let s = match r.pose_to_trigger_instructions {
        Some([mean, max]) => {
            format!("{s}; pose to its trigger's answer (the plan) mean {mean:.0} / max {max:.0} instructions")
        }
        None => s,
    };
    let s = match r.ram_peak_bytes {
        Some(ram) => format!("{s}; camera peak RAM {ram} B (painted stack + static)"),
        None => s,
    };
    let s = match (r.flash_bytes, &r.panic_symbols) {
        (Some(flash), Some(p)) => format!("{s}, flash {flash} B, {} panic symbols", p.len()),
        _ => s,
    };
    if r.passed() {
        Ok(s)
    } else {
        Err(format!("{s}\nthe drive failed (see drive.json)"))
    }
}
