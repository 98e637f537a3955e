//! `host-sim receive`.

use host_sim::output::Outputs;

/// `receive.json`: one entry per frame written.
#[derive(serde::Serialize)]
struct ReceivedFrame {
    file: String,
    frame_id: u32,
    width: u16,
    height: u16,
    format: String,
}

/// `receive.json`.
#[derive(serde::Serialize)]
struct ReceiveReport {
    device: String,
    asked: u64,
    received: u64,
    ending: host_sim::link::serial::Ending,
    frames: Vec<ReceivedFrame>,
    decoder: host_sim::link::decoder::Stats,
}

/// Decode frames from a real serial device or pty and write each as a
/// PNG as it arrives, then receive.json.
#[derive(clap::Args)]
pub struct Args {
    /// Device path, e.g. /dev/ttyUSB0.
    #[arg(long)]
    device: String,
    /// Baud rate.
    #[arg(long, default_value_t = 115_200)]
    baud: u32,
    /// Frames to wait for (1 to 1 000 000); the exit status says whether
    /// they all arrived.
    #[arg(long, default_value_t = 1)]
    frames: u64,
    /// Give up after this many seconds without a byte (at most 86 400).
    #[arg(long, default_value_t = 5.0)]
    timeout: f64,
    /// Give up after this many seconds in all, whatever arrives (at
    /// most 604 800).
    #[arg(long, default_value_t = 300.0)]
    deadline: f64,
    /// Output directory.
    #[arg(long)]
    out: std::path::PathBuf,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args {
        device,
        baud,
        frames,
        timeout,
        deadline,
        out,
    } = args;
    let secs = |flag: &str, v: f64, max: f64| -> Result<std::time::Duration, String> {
        if !(v > 0.0 && v <= max) {
            return Err(format!("{flag}: must lie in (0, {max}] seconds"));
        }
        Ok(std::time::Duration::from_secs_f64(v))
    };
    let limits = host_sim::link::serial::Limits {
        frames,
        idle: secs("--timeout", timeout, 86_400.0)?,
        deadline: secs("--deadline", deadline, 7.0 * 86_400.0)?,
    };
    if !(1..=1_000_000).contains(&frames) {
        return Err("--frames: must be 1 to 1000000".into());
    }
    host_sim::link::serial::check_baud(baud)?;
    let outputs = Outputs::prepare(&out)?;
    host_sim::output::graceful(true);
    let mut dec = host_sim::link::decoder::Decoder::new(1 << 20, hilcam::link::MAX_FRAME_BYTES);
    let mut written: Vec<ReceivedFrame> = Vec::new();
    let mut seen: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
    let mut on_frame = |f: host_sim::link::decoder::Frame| -> Result<(), String> {
        let fmt = f.start.format.pixel_format();
        let png =
            host_sim::frame_png::encode_png(fmt, f.start.width as usize, f.start.height as usize, &f.pixels)?;
        // A repeated id (the sender restarted) gets its own file.
        let n = seen.entry(f.start.frame_id).or_insert(0);
        *n += 1;
        let file = match *n {
            1 => format!("frame-{:05}.png", f.start.frame_id),
            k => format!("frame-{:05}-{k}.png", f.start.frame_id),
        };
        outputs.write_now(&file, &png)?;
        written.push(ReceivedFrame {
            file,
            frame_id: f.start.frame_id,
            width: f.start.width,
            height: f.start.height,
            format: fmt.name().into(),
        });
        Ok(())
    };
    let (got, ending) = host_sim::link::serial::receive(&device, baud, limits, &mut dec, &mut on_frame)?;
    // A frame the input ended inside is counted, not silently left open.
    dec.finish();
    let report = ReceiveReport {
        device: device.clone(),
        asked: frames,
        received: got,
        ending: ending.clone(),
        frames: written,
        decoder: dec.stats,
    };
    let json = serde_json::to_vec_pretty(&report).map_err(|e| e.to_string())?;
    let mut outputs = outputs;
    outputs.write("receive.json", &json)?;
    outputs.commit()?;
    let line = format!(
        "{got} of {frames} frames received from {device} ({}); decoder: {:?}",
        ending.describe(),
        dec.stats
    );
    if got >= frames {
        Ok(line)
    } else {
        Err(format!(
            "{line}\nthe frames that did arrive are in {}",
            out.display()
        ))
    }
}
