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
    let l = &r.link;
    let line = format!(
        "{}: {} frames, {} answers; {} frames not delivered (refused {}, gap {}, unfinished {}, CRC {}, \
         flags {}, values out of range {}, cut off by the end {}); {} bad messages (COBS {}, CRC {}, other {})",
        capture.display(),
        r.frames,
        r.replies_total,
        l.frames_lost(),
        l.frames_refused,
        l.frames_dropped_gap,
        l.frames_dropped_unfinished,
        l.frames_dropped_crc,
        l.frames_dropped_flags,
        l.frames_dropped_value,
        l.frames_cut,
        l.bad_cobs + l.bad_crc + l.bad_message,
        l.bad_cobs,
        l.bad_crc,
        l.bad_message
    );
    // Complete and right only if every frame begun was delivered.
    if l.frames_lost() > 0 {
        return Err(format!(
            "{line}\nthe frames that were delivered are in {}",
            out.display()
        ));
    }
    Ok(line)
}
