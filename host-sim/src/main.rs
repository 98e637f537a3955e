//! host-sim command line.

use clap::{Parser, Subcommand};
use host_sim::output::Outputs;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "hilcam host harness: reference models, comparisons, links"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Project a demo camera's points and compute its lens figures with the
    /// fixed-point core and the f64 reference, and print both with the errors.
    Demo,
    /// Render a scene with the core and the f64 reference; write frame.png,
    /// reference.png, diff.png and metrics.json into OUT.
    Render {
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
    },
    /// Render a scene with the core only (the planner's choice, or
    /// --variant) and write frame.png and truth.json: the camera in
    /// OpenCV's conventions and the true pixel positions of every checker
    /// texture's inner corners, from the f64 reference.
    Frame {
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
    },
    /// Render a scene, encode N frames with the core's encoder, send them
    /// through a simulated link with faults, decode, and report (stream.json,
    /// received.png).
    Stream {
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
    },
    /// Run the standard fault campaign (12 000 frames of the standard scene)
    /// and write faults.json.
    Faults {
        /// Output directory.
        #[arg(long)]
        out: std::path::PathBuf,
        /// Scale the campaign's frame counts (1 = 12 000 frames; at most 100).
        #[arg(long, default_value_t = 1.0)]
        scale: f64,
        /// The scene to send (default: the standard scene, built in).
        #[arg(long)]
        scene: Option<std::path::PathBuf>,
    },
    /// Decode frames from a real serial device or pty and write each as a
    /// PNG as it arrives, then receive.json.
    Receive {
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
    },
    /// Print a complete small frame as it goes on the wire, then a few
    /// commands and answers (docs/wire.md's examples).
    WireExample,
    /// Drive the camera firmware in QEMU (UART0 both ways) along a
    /// trajectory: SetPose and Trigger for each pose; check every frame byte
    /// for byte against the host render of that pose and its ground truth
    /// against the pose sent. Writes frame-N.png, frame-N.json (the frame's
    /// ground truth) and drive.json.
    Drive {
        /// lm3s6965evb (Cortex-M3) or mps2-an386 (Cortex-M4F).
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
    },
    /// Export a scene's camera for calibration tools: opencv.yaml (OpenCV
    /// FileStorage: camera matrix, distortion refitted in OpenCV's direction,
    /// rotation and translation), ros.yaml (ROS CameraInfo) and export.json
    /// (the fit's largest residual in px, and world points with the pixels
    /// the emulator images them at).
    Export {
        /// Scene file.
        #[arg(long)]
        scene: std::path::PathBuf,
        /// Output directory.
        #[arg(long)]
        out: std::path::PathBuf,
    },
    /// Be the camera on a serial device (a real port or a pty): obey the
    /// commands that arrive (docs/wire.md), stream the frames they ask for
    /// with their ground truth, until the other end hangs up.
    Camera {
        /// Serial device.
        #[arg(long)]
        device: String,
        /// Baud rate.
        #[arg(long, default_value_t = 115_200)]
        baud: u32,
        /// The scenes it holds, in SelectScene id order (default: every
        /// scene in scenes/, sorted by file name, as the firmware).
        #[arg(long, num_args = 1..)]
        scene: Vec<std::path::PathBuf>,
        /// Write the raw bytes it sends to this file.
        #[arg(long)]
        capture: Option<std::path::PathBuf>,
    },
    /// Decode a captured stream (--capture of drive or camera): every
    /// frame as frame-N.png with its ground truth in frame-N.json, the
    /// answers and the decoder's counts in replay.json.
    Replay {
        /// The captured bytes.
        #[arg(long)]
        capture: std::path::PathBuf,
        /// Output directory.
        #[arg(long)]
        out: std::path::PathBuf,
    },
    /// Run the firmware in QEMU, decode its UART, and compare every frame
    /// with the host render (bit-exact) and the f64 reference; writes hil.json
    /// and the frames as PNGs.
    Hil {
        /// lm3s6965evb (Cortex-M3), mps2-an386 (Cortex-M4F) or microbit
        /// (Cortex-M0, 16 KiB of RAM).
        #[arg(long)]
        board: String,
        /// Scenes to embed (default: every scene in scenes/).
        #[arg(long, num_args = 1..)]
        scene: Vec<std::path::PathBuf>,
        /// A firmware ELF built already (default: build it).
        #[arg(long)]
        elf: Option<std::path::PathBuf>,
        /// Render every scene with each of these variants (e.g.
        /// i16f16-lut256-linear; default: the planned renderer).
        #[arg(long, num_args = 1..)]
        variant: Vec<String>,
        /// Output directory.
        #[arg(long)]
        out: std::path::PathBuf,
    },
    /// Measure the speed/accuracy trade: every variant's fidelity against the
    /// f64 reference, its instructions per pixel on the M3 and the M4F in
    /// QEMU, host ns per pixel, table and flash bytes; growth with resolution
    /// and primitives; what the planner's pruning saves. Writes tradeoff.json,
    /// tradeoff.md and tradeoff.png.
    Tradeoff {
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
    },
    /// Fit the planner's cost model: calibration scenes rendered on the M3
    /// in QEMU with each arithmetic, least squares per arithmetic, and the
    /// shipped scenes' predicted against measured cost. Writes costfit.json
    /// and costfit.md.
    Costfit {
        /// Output directory.
        #[arg(long)]
        out: std::path::PathBuf,
        /// Measure only the points through the aperture, and keep the
        /// others of this calibration file (docs/cost-calibration.json).
        #[arg(long)]
        keep: Option<std::path::PathBuf>,
    },
    /// Where a frame's instructions go on a board, by pipeline stage: the
    /// firmware holding the scenes runs in QEMU with its executed blocks
    /// logged, each instruction attributed to the stage whose function
    /// inlined it (from the ELF's debug information), and to its source
    /// line. Writes profile.json and profile.md (stages, then each frame's
    /// costliest source lines).
    Profile {
        /// lm3s6965evb (Cortex-M3), mps2-an386 (Cortex-M4F) or microbit
        /// (Cortex-M0).
        #[arg(long)]
        board: String,
        /// Scenes the firmware holds, in order (default: the standard
        /// scene). A frame of 320x240 logs about 1 GB through a pipe;
        /// shallow-dof's defocus about 50 GB.
        #[arg(long, num_args = 1..)]
        scene: Vec<std::path::PathBuf>,
        /// A firmware ELF built already, holding `--scene` (default: build it).
        #[arg(long)]
        elf: Option<std::path::PathBuf>,
        /// How many of each frame's costliest functions and source lines
        /// profile.json keeps (profile.md's table shows at most 25 lines).
        #[arg(long, default_value_t = 40)]
        top: usize,
        /// Output directory.
        #[arg(long)]
        out: std::path::PathBuf,
    },
    /// Instructions of each call of a function in QEMU's block log of a
    /// firmware's run (`-d in_asm,exec,nochain -D LOG`, without
    /// -icount), by function, a library routine's (soft-float, `__aeabi_*`)
    /// counted for its caller: e.g. a driven camera's plan per pose,
    /// `--function hilcam::planner::plan --caller hilcam_firmware::options`
    Calls {
        /// QEMU's log.
        #[arg(long)]
        log: std::path::PathBuf,
        /// The firmware ELF that ran.
        #[arg(long)]
        elf: std::path::PathBuf,
        /// The function whose calls are counted (its path without hash).
        #[arg(long)]
        function: String,
        /// The functions it returns to, which end a call.
        #[arg(long, num_args = 1.., required = true)]
        caller: Vec<String>,
        /// Functions listed for the last call.
        #[arg(long, default_value_t = 12)]
        top: usize,
    },
    /// Host throughput of the default render (plan, prepare and render
    /// every frame, lines in parallel on every core, as `render` does),
    /// and on one core: frames/s and ns/pixel (medians over the frames),
    /// with the core's loops built for the processor's x86-64 level
    /// (HILCAM_X86_LEVEL=1 or 3 caps it: the baseline build, x86-64-v3).
    Throughput {
        /// Scene file.
        #[arg(long)]
        scene: std::path::PathBuf,
        /// Frames to time (1 to 10 000).
        #[arg(long, default_value_t = 20)]
        frames: u32,
    },
}

/// `stream --frames` at most.
const MAX_STREAM_FRAMES: u32 = 10_000_000;

/// The standard scene, built in so that `faults` works wherever the binary is.
const STANDARD_SCENE: &str = include_str!("../../scenes/standard.toml");

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

fn finish(r: Result<String, String>) -> ExitCode {
    match r {
        Ok(line) => {
            println!("{line}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Err(e) = host_sim::output::install_signal_handler() {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    match cli.cmd {
        Cmd::Demo => match host_sim::demo::run() {
            Ok((text, errs)) => {
                print!("{text}");
                if errs.max_px <= 1.0 / 256.0 && errs.max_lens_rel <= 1e-4 {
                    ExitCode::SUCCESS
                } else {
                    eprintln!("error: the core missed a target against the reference");
                    ExitCode::FAILURE
                }
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        },
        Cmd::Render {
            scene,
            out,
            max_geom_err_px,
            max_lsb,
            max_edge_differing,
            allow_over_budget,
        } => {
            let run = || -> Result<String, String> {
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
            };
            finish(run())
        }
        Cmd::Frame {
            scene,
            out,
            variant,
            frame_id,
        } => finish((|| {
            let variant =
                host_sim::variant::Variant::parse(&variant).map_err(|e| format!("--variant: {e}"))?;
            let resolved = host_sim::scene_file::load(&scene)?;
            let t = host_sim::truth::frame_to(&out, &resolved, &variant, frame_id)
                .map_err(|e| format!("{}: {e}", scene.display()))?;
            let corners: usize = t.checker_corners.iter().map(Vec::len).sum();
            Ok(format!(
                "{}: {}x{} [{}], {corners} checker corners in truth.json",
                t.scene,
                t.width,
                t.height,
                t.stages.join(" ")
            ))
        })()),
        Cmd::Stream {
            scene,
            link,
            faults,
            frames,
            out,
        } => finish((|| {
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
            let png = host_sim::frame_png::encode_png(
                resolved.format,
                report.width as usize,
                report.height as usize,
                &first,
            )?;
            outputs.write("stream.json", &json)?;
            outputs.write("received.png", &png)?;
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
        })()),
        Cmd::Faults { out, scale, scene } => finish((|| {
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
        })()),
        Cmd::Receive {
            device,
            baud,
            frames,
            timeout,
            deadline,
            out,
        } => finish((|| {
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
            if !(50..=20_000_000).contains(&baud) {
                return Err("--baud: must be 50 to 20000000".into());
            }
            let outputs = Outputs::prepare(&out)?;
            host_sim::output::graceful(true);
            let mut dec = host_sim::link::decoder::Decoder::new(1 << 20, 1 << 24);
            let mut written: Vec<ReceivedFrame> = Vec::new();
            let mut seen: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
            let mut on_frame = |f: host_sim::link::decoder::Frame| -> Result<(), String> {
                let fmt = f.start.format.pixel_format();
                let png = host_sim::frame_png::encode_png(
                    fmt,
                    f.start.width as usize,
                    f.start.height as usize,
                    &f.pixels,
                )?;
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
            let (got, ending) =
                host_sim::link::serial::receive(&device, baud, limits, &mut dec, &mut on_frame)?;
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
        })()),
        Cmd::WireExample => finish((|| {
            let frame = host_sim::stream_cmd::wire_example()?;
            let commands = host_sim::stream_cmd::command_example()?;
            Ok(format!("{frame}\n{}", commands.trim_end()))
        })()),
        Cmd::Tradeoff {
            out,
            tiny,
            boards,
            repeats,
        } => finish((|| {
            if !(1..=1000).contains(&repeats) {
                return Err("--repeats: must be 1 to 1000".into());
            }
            let boards = if boards == "none" {
                Vec::new()
            } else {
                boards
                    .split(',')
                    .map(host_sim::hil_cmd::Board::parse)
                    .collect::<Result<Vec<_>, _>>()?
            };
            let cfg = if tiny {
                host_sim::tradeoff::Config::tiny(boards, repeats)
            } else {
                host_sim::tradeoff::Config::full(boards, repeats)
            };
            host_sim::tradeoff::run(&cfg, &out)
        })()),
        Cmd::Costfit { out, keep } => finish(
            host_sim::hil_cmd::Board::parse("lm3s6965evb")
                .and_then(|b| host_sim::costfit::run(b, &out, keep.as_deref())),
        ),
        Cmd::Throughput { scene, frames } => finish((|| {
            if !(1..=10_000).contains(&frames) {
                return Err("--frames: must be 1 to 10000".into());
            }
            let r = host_sim::scene_file::load(&scene)?;
            let s = r.core_scene()?;
            let budget = hilcam::planner::Budget::default();
            // A stream of frames: each planned, prepared and rendered into
            // the same buffers (`collect_into`).
            let time = |parallel: bool| -> Result<(f64, String), String> {
                let mut secs = Vec::new();
                let mut arith = String::new();
                let mut c = host_sim::harness::Collect::default();
                for _ in 0..frames {
                    let t = std::time::Instant::now();
                    let p = hilcam::planner::plan(&s, &budget);
                    let f = hilcam::render::Frame::new(&s, &p.options)
                        .map_err(|e| format!("{}: cannot render: {e:?}", scene.display()))?;
                    if parallel {
                        host_sim::harness::collect_into(&f, &mut c)?
                    } else {
                        host_sim::harness::collect_serial_into(&f, &mut c)?
                    };
                    secs.push(t.elapsed().as_secs_f64());
                    std::hint::black_box(&c);
                    arith = f.stages().arithmetic.name().to_string();
                }
                secs.sort_by(f64::total_cmp);
                Ok((secs[secs.len() / 2], arith))
            };
            let (w, h) = s.camera().intrinsics().size();
            let px = w as f64 * h as f64;
            // The plan, named: a scene scaled up may plan a grid or the
            // aperture (a blur circle is more pixels), a far slower loop.
            let p0 = hilcam::planner::plan(&s, &budget);
            let o = &p0.options;
            let mut plan = p0
                .candidates
                .get(p0.chosen)
                .map_or_else(|| "?".to_string(), |c| c.name().to_string());
            if o.samples > 1 {
                let rule = if o.adaptive { " adaptive" } else { "" };
                plan.push_str(&format!(", {n}x{n} grid{rule}", n = o.samples));
            }
            if o.aperture > 0 {
                plan.push_str(&format!(", {} aperture points", o.aperture));
            }
            let (par, arith) = time(true)?;
            let loops = host_sim::harness::x86_level().name();
            let (one, _) = time(false)?;
            Ok(format!(
                "{} {w}x{h} (plan {plan}; {arith} arithmetic, {loops} loops): {:.1} frames/s, {:.1} ns/pixel on {} \
                 threads; {:.1} frames/s, {:.1} ns/pixel on one (median of {frames} frames; plan + prepare + render)",
                r.desc.name,
                1.0 / par,
                par / px * 1e9,
                rayon::current_num_threads(),
                1.0 / one,
                one / px * 1e9
            ))
        })()),
        Cmd::Drive {
            board,
            scene,
            frames,
            poses,
            capture,
            device,
            baud,
            batched,
            out,
        } => finish((|| {
            if frames == 0 {
                return Err("--frames: at least 1".into());
            }
            use host_sim::drive_cmd::{drive_target, Target};
            let target = match device {
                Some(path) => Target::Device { path, baud },
                None => Target::Qemu(host_sim::hil_cmd::Board::parse(&board)?),
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
        })()),
        Cmd::Camera {
            device,
            baud,
            scene,
            capture,
        } => finish((|| {
            let paths = if scene.is_empty() {
                host_sim::hil_cmd::shipped_scenes()?
            } else {
                scene
            };
            let scenes = paths
                .iter()
                .map(|p| host_sim::scene_file::load(p))
                .collect::<Result<Vec<_>, _>>()?;
            let s = host_sim::camera_cmd::serve_device(&device, baud, &scenes, capture.as_deref())?;
            Ok(format!(
                "camera on {device}: {} requests ({} acknowledged, {} refused), {} frames sent; \
                 {:?} messages refused (oversize, COBS, CRC, malformed)",
                s.requests, s.acks, s.rejects, s.frames, s.refused
            ))
        })()),
        Cmd::Export { scene, out } => finish((|| {
            let r = host_sim::scene_file::load(&scene)?;
            let e = host_sim::export::export(&r)?;
            let mut o = Outputs::prepare(&out)?;
            o.write("opencv.yaml", host_sim::export::opencv_yaml(&e).as_bytes())?;
            o.write("ros.yaml", host_sim::export::ros_yaml(&e).as_bytes())?;
            o.write(
                "export.json",
                &serde_json::to_vec_pretty(&e).map_err(|e| e.to_string())?,
            )?;
            o.commit()?;
            Ok(format!(
                "{}: {} with {} coefficients, largest residual {:.2e} px over r_d <= {:.4}",
                e.camera,
                e.distortion.model,
                e.distortion.coefficients.len(),
                e.distortion.residual_px,
                e.distortion.r_max
            ))
        })()),
        Cmd::Replay { capture, out } => finish((|| {
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
        })()),
        Cmd::Profile {
            board,
            scene,
            elf,
            top,
            out,
        } => finish((|| {
            let board = host_sim::hil_cmd::Board::parse(&board)?;
            let scenes = if scene.is_empty() {
                vec![host_sim::hil_cmd::repo_root().join("scenes/standard.toml")]
            } else {
                scene
            };
            let r = host_sim::profile::profile(board, elf, &scenes, top, &out)?;
            Ok(format!(
                "{}\nprofile.json, profile.md in {}",
                host_sim::profile::table(&r),
                out.display()
            ))
        })()),
        Cmd::Calls {
            log,
            elf,
            function,
            caller,
            top,
        } => finish((|| {
            let c = host_sim::profile::calls(&log, &elf, &function, &caller, top)?;
            let mut s = String::new();
            for (k, t) in c.totals.iter().enumerate() {
                s += &format!("call {k}: {t} instructions\n");
            }
            s += "the last, by function (a library routine's instructions counted for its caller):";
            for (name, n) in c.last {
                s += &format!("\n{n:>10}  {name}");
            }
            Ok(s)
        })()),
        Cmd::Hil {
            board,
            scene,
            elf,
            variant,
            out,
        } => finish((|| {
            let board = host_sim::hil_cmd::Board::parse(&board)?;
            let variants = variant
                .iter()
                .map(|v| host_sim::variant::Variant::parse(v))
                .collect::<Result<Vec<_>, _>>()?;
            let r = host_sim::hil_cmd::hil_variants(board, elf, &scene, &variants, &out)?;
            let mut s = String::new();
            for f in &r.frames {
                s.push_str(&format!(
                    "  {:<20} {:<22} {}x{} {:<7} bit_exact={} instructions/pixel={} max_abs_lsb={}\n",
                    f.scene,
                    f.variant,
                    f.width,
                    f.height,
                    f.format,
                    f.bit_exact,
                    f.instructions_per_pixel.map_or("-".into(), |v| format!("{v:.0}")),
                    f.max_abs_lsb
                ));
            }
            s.push_str(&format!(
                "{}: {} frames, bit_exact={}, standard scene {} instructions/pixel (QEMU -icount; not cycles), \
                 flash {} B ({} panic symbols), static RAM {} B, peak stack {} B, max_abs_lsb {}",
                r.board,
                r.frames.len(),
                r.bit_exact,
                r.instructions_per_pixel.map_or("-".into(), |v| format!("{v:.0}")),
                r.flash_bytes,
                r.panic_symbols.len(),
                r.ram_bytes,
                r.stack_peak_bytes.map_or("-".into(), |v| v.to_string()),
                r.max_abs_lsb
            ));
            let kb = |v: &[host_sim::profile::Share]| {
                v.iter()
                    .take(6)
                    .map(|x| format!("{} {:.1} K", x.name, x.bytes as f64 / 1000.0))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            s.push_str(&format!(
                "\n  largest symbols: {}\n  .text by source file: {}",
                kb(&r.flash_use.largest_symbols),
                kb(&r.flash_use.text_by_file)
            ));
            if r.bit_exact {
                Ok(s)
            } else {
                Err(format!("{s}\nnot bit-exact with the host render"))
            }
        })()),
    }
}
