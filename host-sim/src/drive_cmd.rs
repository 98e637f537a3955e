//! `host-sim drive`: the host drives a camera (the firmware in QEMU through
//! its UART, or anything speaking the protocol on a byte stream) along a
//! trajectory — `SetPose`, then `Trigger` for each pose — receives every
//! frame with its ground truth, and checks each one byte for byte against
//! the host's render of the same pose, and its truth against the pose sent.

use crate::harness::planned_frame;
use crate::qemu::{build_firmware_as, spawn_qemu, wait_qemu, Board};
use crate::client::{spawn_reader, Client};
use crate::link::decoder::{Decoder, Reply, Stats};
use crate::scene_file::{load, Resolved};
use crate::trajectory::{Pose, Trajectory};
use hilcam::link::{Command, FrameStart, Truth};
use hilcam::planner::Budget;
use hilcam::Extrinsics;
use serde::Serialize;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A frame's ground truth in SI units (each raw fixed-point value of the
/// wire divided by its power of two, to the nearest f64), with the raw
/// values beside: what the JSON sidecars hold.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TruthView {
    /// Camera time, ns.
    pub timestamp_ns: u64,
    /// The last command in effect.
    pub command: Option<u32>,
    /// `R`, row by row.
    pub rotation: [[f64; 3]; 3],
    /// `T`, metres.
    pub translation: [f64; 3],
    /// `f`, metres.
    pub focal_length: f64,
    /// `(s_x, s_y)`, metres.
    pub pitch: [f64; 2],
    /// `(o_x, o_y)`, pixels.
    pub principal_point: [f64; 2],
    /// `(k1, k2)`, camera-model.md §3.
    pub distortion: [f64; 2],
    /// Aperture diameter `D`, m.
    pub aperture: f64,
    /// Focus distance, m.
    pub focus_distance: f64,
    /// Weak perspective's mean depth `Z̄` (m) or orthographic's scale `m`
    /// (`plan.model` 1 or 2); 0 for perspective.
    pub model_scale: f64,
    /// The plan.
    pub plan: hilcam::link::WirePlan,
    /// The values as the wire carries them.
    pub raw: Truth,
}

impl From<&Truth> for TruthView {
    fn from(t: &Truth) -> Self {
        let s = |v: i64, frac: i32| v as f64 * 2f64.powi(-frac);
        TruthView {
            timestamp_ns: t.timestamp_ns,
            command: t.command,
            rotation: t.rotation.map(|row| row.map(|v| s(v, 62))),
            translation: t.translation.map(|v| s(v, 40)),
            focal_length: s(t.focal_length, 40),
            pitch: t.pitch.map(|v| s(v, 60)),
            principal_point: t.principal_point.map(|v| s(i64::from(v), 16)),
            distortion: t.distortion.map(|v| s(v, 48)),
            aperture: s(t.lens[0], 40),
            focus_distance: s(t.lens[1], 40),
            model_scale: match t.plan.model {
                1 => s(t.model_scale, 40),
                2 => s(t.model_scale, 48),
                _ => 0.0,
            },
            plan: t.plan,
            raw: *t,
        }
    }
}

/// One frame of a drive.
#[derive(Clone, Debug, Serialize)]
pub struct DriveFrame {
    /// Index in the trajectory.
    pub index: usize,
    /// The frame's id.
    pub frame_id: u32,
    /// The `Trigger` command that asked for it.
    pub command: u32,
    /// Its ground truth as received.
    pub truth: TruthView,
    /// Pixels outside the lens field (the frame's `Flags` messages).
    pub outside_field: u32,
    /// Pixels and out-of-field flags byte-identical to the host's render of
    /// the same pose and frame id.
    pub bit_exact: bool,
    /// The truth equals the host's: the pose sent, the camera, the plan.
    pub truth_matches: bool,
    /// Instructions the frame cost the device (QEMU `-icount`).
    pub instructions: Option<u64>,
    /// Camera time from processing the `Trigger` to sending the frame's
    /// first message, ns.
    pub round_trip_camera_ns: u64,
    /// Host time from sending the `Trigger` to the frame's first bytes, ms.
    pub round_trip_wall_ms: f64,
    /// Sent with its pose ([`Client::batched`]): camera time from answering
    /// the pose to answering the trigger, ns — the new pose's plan, which
    /// the camera makes between the two, and the trigger's decoding.
    pub pose_to_trigger_camera_ns: Option<u64>,
}

/// `drive.json`.
#[derive(Clone, Debug, Serialize)]
pub struct DriveReport {
    /// Board (or `host`).
    pub board: String,
    /// Scene.
    pub scene: String,
    /// Frames asked for.
    pub frames_requested: usize,
    /// Frames received.
    pub frames_received: usize,
    /// Frames asked for and never received.
    pub lost: usize,
    /// Frames whose id was not after the previous one's (lost frames only
    /// skip ids).
    pub out_of_order: usize,
    /// Frames of an earlier trigger that arrived after it was counted lost
    /// (skipped).
    pub late: usize,
    /// Frames byte-identical with the host render of their pose.
    pub bit_exact: usize,
    /// Frames whose ground truth matched.
    pub truth_matches: usize,
    /// Commands sent again after a silence.
    pub resent: u32,
    /// Each pose was sent with its trigger in one write ([`Client::batched`]).
    pub batched: bool,
    /// Round trip in the camera's time, ns: mean and largest.
    pub round_trip_camera_ns: [f64; 2],
    /// The same in instructions, where the camera's time counts them (QEMU
    /// `-icount shift=7`: 128 ns an instruction): mean and largest.
    pub round_trip_instructions: Option<[f64; 2]>,
    /// Round trip in host time, ms: mean and largest.
    pub round_trip_wall_ms: [f64; 2],
    /// Sent with its pose: what a new pose costs the camera before its
    /// frame (`DriveFrame::pose_to_trigger_camera_ns` in instructions, where
    /// the camera's time counts them): mean and largest.
    pub pose_to_trigger_instructions: Option<[f64; 2]>,
    /// What a frame cost the camera, instructions a pixel (QEMU `-icount`,
    /// the frames that carry a count): mean and largest. The camera's build
    /// (every loop, its `compact` copies) renders a scene at a cost of its
    /// own, not the default firmware's.
    pub instructions_per_pixel: Option<[f64; 2]>,
    /// Wall time of the whole drive, s.
    pub seconds: f64,
    /// The decoder's counts.
    pub link: Stats,
    /// The camera firmware's RAM, bytes (QEMU only): its statics, its
    /// deepest stack use after the last frame (painted stack, from the
    /// firmware's status line), and their sum.
    pub ram_bytes: Option<u64>,
    pub stack_peak_bytes: Option<u64>,
    pub ram_peak_bytes: Option<u64>,
    /// The camera firmware's flash (`.text` + `.rodata` + `.data`), bytes,
    /// and its `core::panicking` symbols: none means no panic path is
    /// linked (QEMU only).
    pub flash_bytes: Option<u64>,
    pub panic_symbols: Option<Vec<String>>,
    /// Every frame.
    pub frames: Vec<DriveFrame>,
}

/// The camera firmware as measured: from its ELF, its flash, statics and
/// panic symbols; as it reports it, the deepest stack use its status lines
/// give after each frame (`stack_peak_bytes N` over semihosting, read from
/// QEMU's stdout by a thread, which also keeps that pipe drained).
pub struct Probe {
    static_bytes: u64,
    flash_bytes: u64,
    panic_symbols: Vec<String>,
    seen: std::sync::Arc<(std::sync::atomic::AtomicUsize, std::sync::atomic::AtomicU64)>,
    /// The firmware's last lines that are not status lines (`firmware
    /// error: …`, `firmware panic at …`), and whether its output ended.
    said: std::sync::Arc<std::sync::Mutex<(Vec<String>, bool)>>,
}

impl Probe {
    /// What `elf` holds (before QEMU runs it).
    pub fn read(elf: &Path) -> Result<Probe, String> {
        let (flash_bytes, static_bytes) = crate::qemu::elf_sizes(elf)?;
        Ok(Probe {
            static_bytes,
            flash_bytes,
            panic_symbols: crate::qemu::elf_panic_symbols(elf)?,
            seen: Default::default(),
            said: Default::default(),
        })
    }

    /// Reads `stdout` (QEMU's) on a thread.
    pub fn spawn(self, stdout: impl Read + Send + 'static) -> Probe {
        use std::io::BufRead;
        use std::sync::atomic::Ordering;
        let (s, said) = (self.seen.clone(), self.said.clone());
        std::thread::spawn(move || {
            for line in std::io::BufReader::new(stdout).lines().map_while(Result::ok) {
                if let Some(n) = line
                    .strip_prefix("stack_peak_bytes ")
                    .and_then(|v| v.trim().parse::<u64>().ok())
                {
                    s.1.fetch_max(n, Ordering::Relaxed);
                    s.0.fetch_add(1, Ordering::Relaxed);
                } else if line.starts_with("firmware ") {
                    if let Ok(mut said) = said.lock() {
                        if said.0.len() == 4 {
                            said.0.remove(0);
                        }
                        said.0.push(line);
                    }
                }
            }
            if let Ok(mut said) = said.lock() {
                said.1 = true;
            }
        });
        self
    }

    /// The firmware's last error or panic lines, once its output has ended
    /// (1 s at most): what a camera that closed the link said.
    pub fn last_words(&self) -> Vec<String> {
        let t = Instant::now();
        loop {
            match self.said.lock() {
                Ok(s) if s.1 || t.elapsed() >= Duration::from_secs(1) => return s.0.clone(),
                Err(_) => return Vec::new(),
                _ => std::thread::sleep(Duration::from_millis(10)),
            }
        }
    }

    /// The deepest stack use once `frames` status lines have arrived (or
    /// after 5 s), `None` if none did.
    pub fn stack_peak(&self, frames: usize) -> Option<u64> {
        use std::sync::atomic::Ordering;
        let t = Instant::now();
        while self.seen.0.load(Ordering::Relaxed) < frames && t.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(10));
        }
        (self.seen.0.load(Ordering::Relaxed) > 0).then(|| self.seen.1.load(Ordering::Relaxed))
    }
}

impl DriveReport {
    /// Every frame arrived, in order, bit-exact, with its truth.
    pub fn passed(&self) -> bool {
        self.frames_received == self.frames_requested
            && self.lost == 0
            && self.out_of_order == 0
            && self.bit_exact == self.frames_requested
            && self.truth_matches == self.frames_requested
    }
}

/// The pose of a resolved scene, as the core holds it.
pub fn scene_pose(r: &Resolved) -> Result<Pose, String> {
    let scene = r.core_scene()?;
    let e = scene.camera().extrinsics();
    Ok(Pose {
        rotation: e.rotation().map(|row| row.map(|v| v.to_num())),
        translation: e.translation().to_f64(),
    })
}

/// Drives a camera through `poses` of the scene `r`, which it sends as
/// data first (`LoadScene`: the camera needs no firmware made for it);
/// writes a PNG
/// and a JSON sidecar (its ground truth) per frame and `drive.json` into
/// `out`. `instr_ns`: ns of camera time an instruction, where it is fixed
/// (128 under QEMU `-icount shift=7`).
pub fn drive<W: Write>(
    driver: &mut Client<W>,
    board: &str,
    r: &Resolved,
    poses: &[Pose],
    instr_ns: Option<f64>,
    probe: Option<&Probe>,
    out: &Path,
) -> Result<DriveReport, String> {
    let mut outputs = crate::output::Outputs::prepare(out)?;
    let t_all = Instant::now();
    let d = driver.load_scene_file(r).map_err(|e| e.to_string())?;
    let (w, h) = (r.desc.camera.width, r.desc.camera.height);
    let expect = |reply: Reply, what: &str| match reply {
        Reply::Ack(a) => Ok(a),
        other => Err(format!("{what}: {other:?}")),
    };
    let mut scene = r.core_scene()?;
    // The camera plans within the distortion table its frame holds; the
    // host's render of its frames plans with the same budget.
    let budget = Budget {
        max_table_entries: d.max_table as usize,
        ..Budget::default()
    };
    let mut frames = Vec::new();
    let (mut lost, mut out_of_order, mut late) = (0, 0, 0);
    let mut next_id = d.next_frame;
    for (k, pose) in poses.iter().enumerate() {
        let set_pose = Command::SetPose {
            rotation: pose.rotation,
            translation: pose.translation,
        };
        let trigger = Command::Trigger { frames: 1 };
        let (posed, (ack, sent)) = if driver.batched {
            let [posed, triggered] = driver.commands([set_pose, trigger])?;
            (posed.0, triggered)
        } else {
            (driver.command(set_pose)?.0, driver.command(trigger)?)
        };
        let posed = expect(posed, &format!("SetPose {k}"))?;
        let ack = expect(ack, &format!("Trigger {k}"))?;
        // This trigger's frame: the first whose last command is the
        // trigger (an older frame, already counted lost, is skipped).
        let a = loop {
            match driver.next_frame(driver.frame_timeout)? {
                Some(a)
                    if a.frame
                        .start
                        .truth
                        .command
                        .is_some_and(|c| c.wrapping_sub(ack.seq) > u32::MAX / 2) =>
                {
                    late += 1
                }
                other => break other,
            }
        };
        let Some(a) = a else {
            lost += 1;
            continue;
        };
        let f = &a.frame;
        // Ids only move forward (by more than one past a lost frame).
        if f.start.frame_id.wrapping_sub(next_id) > u32::MAX / 2 {
            out_of_order += 1;
        }
        next_id = f.start.frame_id.wrapping_add(1);
        // The host's render of the same pose and frame id, and the header
        // the camera should have sent with it.
        let e =
            Extrinsics::from_matrix(pose.rotation, pose.translation).map_err(|e| format!("pose {k}: {e}"))?;
        scene.set_pose(e).map_err(|e| format!("pose {k}: {e}"))?;
        let (host, stages) = planned_frame(&scene, &r.desc.name, &budget, f.start.frame_id)?;
        let want = FrameStart::of(
            f.start.frame_id,
            d.scene_id,
            &scene,
            &stages,
            f.start.truth.timestamp_ns,
            Some(ack.seq),
        );
        let bit_exact = host.pixels == f.pixels && crate::link::decoder::wire_flags(&host.flags) == f.flags;
        let truth_matches = want == f.start;
        let png = crate::frame_png::encode_png(r.format, w as usize, h as usize, &f.pixels)?;
        let df = DriveFrame {
            index: k,
            frame_id: f.start.frame_id,
            command: ack.seq,
            truth: TruthView::from(&f.start.truth),
            outside_field: f.end.outside,
            bit_exact,
            truth_matches,
            instructions: f.end.cost,
            round_trip_camera_ns: f.start.truth.timestamp_ns.saturating_sub(ack.timestamp_ns),
            round_trip_wall_ms: a.first_byte.saturating_duration_since(sent).as_secs_f64() * 1e3,
            pose_to_trigger_camera_ns: driver
                .batched
                .then(|| ack.timestamp_ns.saturating_sub(posed.timestamp_ns)),
        };
        outputs.write(&format!("frame-{k:05}.png"), &png)?;
        let json = serde_json::to_vec_pretty(&df).map_err(|e| e.to_string())?;
        outputs.write(&format!("frame-{k:05}.json"), &json)?;
        frames.push(df);
    }
    let counts = Counts {
        lost,
        out_of_order,
        late,
        seconds: t_all.elapsed().as_secs_f64(),
    };
    let report = report(driver, (board, r, poses.len()), frames, counts, (instr_ns, probe));
    let json = serde_json::to_vec_pretty(&report).map_err(|e| e.to_string())?;
    outputs.write("drive.json", &json)?;
    outputs.commit()?;
    Ok(report)
}

/// A drive's frames lost, out of order and late, and its time.
struct Counts {
    lost: usize,
    out_of_order: usize,
    late: usize,
    seconds: f64,
}

/// `drive.json` of a drive's frames (`requested` poses of `r` on `board`),
/// its round trips in instructions where `instr_ns` converts the camera's
/// clock, and the firmware's RAM and flash where `probe` read them.
fn report<W: Write>(
    driver: &Client<W>,
    (board, r, requested): (&str, &Resolved, usize),
    frames: Vec<DriveFrame>,
    counts: Counts,
    (instr_ns, probe): (Option<f64>, Option<&Probe>),
) -> DriveReport {
    let (w, h) = (r.desc.camera.width, r.desc.camera.height);
    let stat = |v: Vec<f64>| {
        let n = v.len().max(1) as f64;
        [v.iter().sum::<f64>() / n, v.iter().cloned().fold(0.0, f64::max)]
    };
    let stack_peak = probe.and_then(|p| p.stack_peak(frames.len()));
    DriveReport {
        board: board.into(),
        scene: r.desc.name.clone(),
        frames_requested: requested,
        frames_received: frames.len(),
        lost: counts.lost,
        out_of_order: counts.out_of_order,
        late: counts.late,
        bit_exact: frames.iter().filter(|f| f.bit_exact).count(),
        truth_matches: frames.iter().filter(|f| f.truth_matches).count(),
        resent: driver.resent,
        batched: driver.batched,
        round_trip_camera_ns: stat(frames.iter().map(|f| f.round_trip_camera_ns as f64).collect()),
        round_trip_instructions: instr_ns.map(|ns| {
            stat(
                frames
                    .iter()
                    .map(|f| f.round_trip_camera_ns as f64 / ns)
                    .collect(),
            )
        }),
        round_trip_wall_ms: stat(frames.iter().map(|f| f.round_trip_wall_ms).collect()),
        pose_to_trigger_instructions: instr_ns.filter(|_| driver.batched && !frames.is_empty()).map(|ns| {
            stat(
                frames
                    .iter()
                    .filter_map(|f| f.pose_to_trigger_camera_ns)
                    .map(|v| v as f64 / ns)
                    .collect(),
            )
        }),
        instructions_per_pixel: {
            let px = f64::from(w) * f64::from(h);
            let v: Vec<f64> = frames.iter().filter_map(|f| f.instructions).map(|n| n as f64 / px).collect();
            (!v.is_empty()).then(|| stat(v))
        },
        seconds: counts.seconds,
        link: driver.stats(),
        ram_bytes: probe.map(|p| p.static_bytes),
        stack_peak_bytes: stack_peak,
        ram_peak_bytes: probe.zip(stack_peak).map(|(p, s)| p.static_bytes + s),
        flash_bytes: probe.map(|p| p.flash_bytes),
        panic_symbols: probe.map(|p| p.panic_symbols.clone()),
        frames,
    }
}

/// The largest poses file read, bytes: a million keyframes.
pub const MAX_POSES_BYTES: u64 = 64 << 20;

/// The poses of a drive: `poses_file` (JSON or CSV lines, see
/// [`Trajectory::parse`]) sampled at `frames` points, else the scene's
/// `[[trajectory]]`, else the scene's pose wobbled ([`Trajectory::wobble`]).
pub fn poses(r: &Resolved, poses_file: Option<&Path>, frames: usize) -> Result<Vec<Pose>, String> {
    let traj = match poses_file {
        Some(p) => {
            use std::io::Read;
            let at = |e: String| format!("{}: {e}", p.display());
            let mut bytes = Vec::new();
            std::fs::File::open(p)
                .and_then(|f| f.take(MAX_POSES_BYTES + 1).read_to_end(&mut bytes))
                .map_err(|e| at(e.to_string()))?;
            if bytes.len() as u64 > MAX_POSES_BYTES {
                return Err(at(format!("larger than {MAX_POSES_BYTES} bytes: not a poses file")));
            }
            let text = String::from_utf8(bytes).map_err(|e| at(format!("not UTF-8 text: {e}")))?;
            Trajectory::parse(&text).map_err(at)?
        }
        None => match &r.trajectory {
            Some(t) => t.clone(),
            None => Trajectory::wobble(&scene_pose(r)?, 1.0),
        },
    };
    Ok(traj.sample(frames))
}

/// The camera a drive talks to.
#[derive(Clone, Debug)]
pub enum Target {
    /// The camera firmware for this board, built with the shipped scenes
    /// (sized to hold the drive's scene too) and run in QEMU with UART0 on
    /// a Unix socket.
    Qemu(Board),
    /// A camera on a serial device (a real port or a pty) whose scene 0 is
    /// the drive's scene.
    Device {
        /// The device.
        path: String,
        /// Baud rate.
        baud: u32,
    },
}

/// Drives the camera at `target` showing `scene` ([`drive`]) through the
/// poses of `poses_file` or the scene ([`poses`]), each pose with its
/// trigger in one write if `batched` ([`Client::batched`]); `capture`
/// receives the raw bytes the camera sent.
pub fn drive_target(
    target: &Target,
    scene: &Path,
    poses_file: Option<&Path>,
    frames: usize,
    capture: Option<&Path>,
    batched: bool,
    out: &Path,
) -> Result<DriveReport, String> {
    let r = load(scene)?;
    let poses = poses(&r, poses_file, frames)?;
    let run = |reader: Box<dyn Read + Send>, writer: Box<dyn Write>, name: &str, instr_ns, probe: Option<&Probe>| {
        let capture = capture.map(create_capture).transpose()?;
        let mut driver = Client::new(writer, spawn_reader(reader, capture));
        driver.batched = batched;
        drive(&mut driver, name, &r, &poses, instr_ns, probe, out)
    };
    match target {
        Target::Device { path, baud } => {
            let (reader, writer) = crate::link::serial::open(path, *baud)?;
            run(reader, writer, path, None, None)
        }
        Target::Qemu(board) => {
            // The camera firmware as built with the shipped scenes: the
            // scene driven goes over the link as data (the camera sized to
            // hold it too).
            let elf = build_firmware_as(*board, &[], &[], true, &[scene.to_path_buf()])?;
            let probe = Probe::read(&elf)?;
            let dir = tempfile_dir()?;
            let sock = dir.join("uart.sock");
            let mut child = spawn_qemu(
                *board,
                &elf,
                &format!("unix:{},server=on,wait=on", sock.display()),
            )?;
            let probe = child.stdout.take().map(|o| probe.spawn(o));
            let result = connect(&sock).and_then(|stream| {
                let reader = stream.try_clone().map_err(|e| e.to_string())?;
                run(Box::new(reader), Box::new(stream), board.machine(), Some(128.0), probe.as_ref())
            });
            // A camera that closed the link: what it said (a panic, an
            // error), once QEMU has exited.
            let status = result.is_err().then(|| wait_qemu(&mut child, Duration::from_secs(2)));
            let _ = child.kill();
            let _ = child.wait();
            let mut stderr = String::new();
            if let (Some(Ok(_)), Some(mut e)) = (&status, child.stderr.take()) {
                let _ = e.read_to_string(&mut stderr);
            }
            let _ = std::fs::remove_dir_all(&dir);
            result.map_err(|e| {
                let words = probe.as_ref().map(Probe::last_words).unwrap_or_default();
                let exit = match status {
                    // (Its message first: a fatal error's register dump
                    // follows it.)
                    Some(Ok(s)) => match stderr.lines().find(|l| !l.trim().is_empty() && !l.contains("info:")) {
                        Some(l) => format!("; QEMU exited: {s} ({})", l.trim()),
                        None => format!("; QEMU exited: {s}"),
                    },
                    _ => String::new(),
                };
                if words.is_empty() {
                    format!("{e}{exit}")
                } else {
                    format!("{e}{exit}; the firmware said: {}", words.join(" / "))
                }
            })
        }
    }
}

/// Connects to QEMU's UART socket once QEMU has made it (20 s at most).
fn connect(sock: &Path) -> Result<std::os::unix::net::UnixStream, String> {
    let t = Instant::now();
    loop {
        match std::os::unix::net::UnixStream::connect(sock) {
            Ok(s) => return Ok(s),
            Err(_) if t.elapsed() < Duration::from_secs(20) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(format!("connecting to QEMU's UART at {}: {e}", sock.display())),
        }
    }
}

/// Creates a capture file (and its directory).
pub fn create_capture(p: &Path) -> Result<std::fs::File, String> {
    if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    std::fs::File::create(p).map_err(|e| format!("{}: {e}", p.display()))
}

fn tempfile_dir() -> Result<PathBuf, String> {
    let dir = std::env::temp_dir().join(format!("hilcam-drive-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    Ok(dir)
}

/// `replay.json`.
#[derive(Clone, Debug, Serialize)]
pub struct ReplayReport {
    /// Frames decoded intact.
    pub frames: usize,
    /// Answers to commands in the capture.
    pub replies_total: u64,
    /// The first [`REPLAY_REPLIES`] of them, in order.
    pub replies: Vec<Reply>,
    /// The decoder's counts (frames refused, dropped and cut among them).
    pub link: Stats,
}

/// Answers a replay lists (it counts them all).
pub const REPLAY_REPLIES: usize = 10_000;

/// One replayed frame's sidecar.
#[derive(Clone, Debug, Serialize)]
struct ReplayFrame {
    frame_id: u32,
    scene_id: u32,
    width: u16,
    height: u16,
    format: String,
    exposure: f64,
    truth: TruthView,
    instructions: Option<u64>,
}

/// Writes replayed frame `k`: its PNG and its sidecar.
fn replay_frame(outputs: &mut crate::output::Outputs, k: usize, f: &crate::link::decoder::Frame) -> Result<(), String> {
    let s = &f.start;
    let format = s.format.pixel_format();
    let png = crate::frame_png::encode_png(format, s.width as usize, s.height as usize, &f.pixels)?;
    outputs.write(&format!("frame-{k:05}.png"), &png)?;
    let side = ReplayFrame {
        frame_id: s.frame_id,
        scene_id: s.scene_id,
        width: s.width,
        height: s.height,
        format: format.name().into(),
        exposure: s.exposure as f64 / 2f64.powi(32),
        truth: TruthView::from(&s.truth),
        instructions: f.end.cost,
    };
    let json = serde_json::to_vec_pretty(&side).map_err(|e| e.to_string())?;
    outputs.write(&format!("frame-{k:05}.json"), &json)
}

/// Decodes a captured camera stream into `out`: `frame-N.png` and
/// `frame-N.json` (its header and ground truth) per frame, `replay.json`.
/// The capture is read as a stream and each frame written as it
/// completes: memory is one frame (at most the decoder's 16 MiB) and
/// [`REPLAY_REPLIES`] answers, whatever the capture's length.
pub fn replay(capture: &Path, out: &Path) -> Result<ReplayReport, String> {
    use std::os::unix::fs::FileTypeExt;
    let at = |e: std::io::Error| format!("{}: {e}", capture.display());
    let file = std::fs::File::open(capture).map_err(at)?;
    // A capture is a file or a pipe that ends; a device (a serial port,
    // /dev/zero) never does: `receive` reads devices, with its deadline.
    let kind = file.metadata().map_err(at)?.file_type();
    if !(kind.is_file() || kind.is_fifo()) {
        return Err(format!(
            "{}: not a capture file (a device or a directory); a serial port is read by `host-sim receive`",
            capture.display()
        ));
    }
    let mut outputs = crate::output::Outputs::prepare(out)?;
    let mut dec = Decoder::new(1 << 20, hilcam::link::MAX_FRAME_BYTES);
    let (mut frames, mut replies, mut replies_total) = (0usize, Vec::new(), 0u64);
    crate::link::decoder::read_capture(
        file,
        &mut dec,
        &mut |f| {
            frames += 1;
            replay_frame(&mut outputs, frames - 1, &f)
        },
        &mut |r| {
            replies_total += 1;
            if replies.len() < REPLAY_REPLIES {
                replies.push(r);
            }
        },
    )
    .map_err(|e| match e {
        crate::link::decoder::CaptureError::Read(e) => at(e),
        crate::link::decoder::CaptureError::Frame(e) => e,
    })?;
    let report = ReplayReport {
        frames,
        replies_total,
        replies,
        link: dec.stats,
    };
    let json = serde_json::to_vec_pretty(&report).map_err(|e| e.to_string())?;
    outputs.write("replay.json", &json)?;
    outputs.commit()?;
    Ok(report)
}
