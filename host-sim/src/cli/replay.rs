//! `host-sim replay`.

/// Decode a captured stream (--capture of drive or camera): every
/// frame as frame-N.png with its ground truth in frame-N.json, the
/// answers and the decoder's counts in replay.json.
#[derive(clap::Args)]
pub struct Args {
    /// The captured bytes.
    #[arg(long)]
    capture: std::path::PathBuf,
    /// Output directory.
    #[arg(long)]
    out: std::path::PathBuf,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args { capture, out } = args;
    let r = host_sim::drive_cmd::replay(&capture, &out)?;
    Ok(format!(
        "{}: {} frames, {} answers; {} bad messages (COBS {}, CRC {}, other {})",
        capture.display(),
        r.frames,
        r.replies.len(),
        r.link.bad_cobs + r.link.bad_crc + r.link.bad_message,
        r.link.bad_cobs,
        r.link.bad_crc,
        r.link.bad_message
    ))
}
