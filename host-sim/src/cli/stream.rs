//! `host-sim stream`.

use host_sim::output::Outputs;

/// `stream --frames` at most.
const MAX_STREAM_FRAMES: u32 = 10_000_000;

/// Render a scene, encode N frames with the core's encoder, send them
/// through a simulated link with faults, decode, and report (stream.json;
/// received.png, the first frame delivered intact, if one was).
#[derive(clap::Args)]
pub struct Args {
    /// Scene file.
    #[arg(long)]
    scene: std::path::PathBuf,
    /// uart:BAUD or usb-fs.
    #[arg(long, default_value = "usb-fs")]
    link: String,
    /// Faults, e.g. ber=1e-5,drop=1e-6,dup=0,insert=0,truncate=0.01,cut=0,seed=1 (or none).
    #[arg(long, default_value = "none")]
    faults: String,
    /// Frames to send (1 to 10 000 000; memory does not grow with it).
    #[arg(long, default_value_t = 100)]
    frames: u32,
    /// Output directory.
    #[arg(long)]
    out: std::path::PathBuf,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args {
        scene,
        link,
        faults,
        frames,
        out,
    } = args;
    let link = host_sim::link::sim::Link::parse(&link)?;
    let faults = host_sim::link::sim::Faults::parse(&faults)?;
    if !(1..=MAX_STREAM_FRAMES).contains(&frames) {
        return Err(format!("--frames: must be 1 to {MAX_STREAM_FRAMES}"));
    }
    let resolved = host_sim::scene_file::load(&scene)?;
    let mut outputs = Outputs::prepare(&out)?;
    let (report, first) = host_sim::stream_cmd::stream(&resolved, link, &faults, frames)
        .map_err(|e| format!("{}: {e}", scene.display()))?;
    let json = serde_json::to_vec_pretty(&report).map_err(|e| e.to_string())?;
    outputs.write("stream.json", &json)?;
    // What the receiver decoded, if anything arrived.
    if let Some(first) = &first {
        let png = host_sim::frame_png::encode_png(
            resolved.format,
            report.width as usize,
            report.height as usize,
            first,
        )?;
        outputs.write("received.png", &png)?;
    }
    outputs.commit()?;
    let o = &report.outcome.counts;
    Ok(format!(
        "{} over {}: {} B/frame on the wire, efficiency {:.4}, {:.2} ms/frame = {:.1} fps; \
         sent {} hit {} delivered intact {} corrupted accepted {} intact lost {}",
        report.scene,
        report.link,
        report.wire_bytes_per_frame.round(),
        report.link_efficiency,
        report.seconds_per_frame * 1e3,
        report.achievable_fps,
        o.frames_sent,
        o.frames_hit_by_faults,
        o.frames_delivered_intact,
        o.corrupted_frames_accepted,
        o.intact_frames_lost
    ))
}
