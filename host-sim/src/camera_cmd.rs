//! `host-sim camera`: the host as the camera. It obeys the commands a
//! system under test (or `host-sim drive`) sends and streams the frames
//! they ask for, with the same core pieces the firmware uses — the
//! [`Receiver`], the command state [`Control`], the frame [`Encoder`] — and
//! the default rendering path, so its frames are the firmware's, byte for
//! byte.

use crate::client::spawn_reader;
use crate::harness::planned_frame;
use crate::scene_file::Resolved;
use hilcam::link::control::{Answer, Control, Library, Receiver};
use hilcam::link::{Mode, MAX_REQUEST};
use hilcam::planner::Budget;
use hilcam::link::{Encoder, FrameStart, DEFAULT_CHUNK};
use hilcam::scene::data::MAX_SCENE_DATA;
use serde::Serialize;
use std::io::{Read, Write};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// A `std::io::Write` as the `embedded_io::Write` the core's encoder
/// writes to.
pub struct IoWrite<W>(pub W);

impl<W: Write> embedded_io::ErrorType for IoWrite<W> {
    type Error = embedded_io::ErrorKind;
}

impl<W: Write> embedded_io::Write for IoWrite<W> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.0.write(buf).map_err(|e| kind(&e))
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        self.0.flush().map_err(|e| kind(&e))
    }
}

/// An I/O error as the encoder carries it: a hang-up
/// ([`crate::link::serial::is_hangup`]) as `BrokenPipe`.
fn kind(e: &std::io::Error) -> embedded_io::ErrorKind {
    if crate::link::serial::is_hangup(e) {
        embedded_io::ErrorKind::BrokenPipe
    } else if e.kind() == std::io::ErrorKind::TimedOut {
        embedded_io::ErrorKind::TimedOut
    } else {
        embedded_io::ErrorKind::Other
    }
}

/// Why a camera's session stopped sending.
enum Stop {
    /// The host hung up while the camera wrote.
    HungUp,
    /// Anything else: the error.
    Failed(String),
}

/// A send's error as a [`Stop`]: `what` names the message.
fn stop(what: &str, e: hilcam::link::LinkError<embedded_io::ErrorKind>) -> Stop {
    match e {
        hilcam::link::LinkError::Write(embedded_io::ErrorKind::BrokenPipe) => Stop::HungUp,
        e => Stop::Failed(format!("{what}: {e:?}")),
    }
}

/// A writer that copies everything it writes to a capture file.
pub struct Tee<W> {
    /// The writer.
    pub inner: W,
    /// The copy.
    pub capture: Option<std::fs::File>,
}

impl<W: Write> Write for Tee<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        if let Some(f) = self.capture.as_mut() {
            f.write_all(&buf[..n])?;
        }
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Runs the camera on the serial device `path` (a real port or a pty)
/// until the other end hangs up; `capture` receives the bytes it sends.
pub fn serve_device(
    path: &str,
    baud: u32,
    scenes: &[Resolved],
    capture: Option<&std::path::Path>,
) -> Result<CameraStats, String> {
    check_held(scenes).map_err(|(id, e)| format!("scene {id} ({}): {e}", scenes[id].desc.name))?;
    let (reader, writer) = crate::link::serial::open(path, baud)?;
    let capture = capture.map(crate::drive_cmd::create_capture).transpose()?;
    serve(
        reader,
        Tee {
            inner: writer,
            capture,
        },
        scenes,
    )
}

/// Checks that the host camera can show every one of `scenes` (lines of at
/// most one encoder chunk, frames within [`hilcam::link::MAX_FRAME_BYTES`],
/// what the planner can prepare) and returns them as scene data, as a
/// firmware holds them; else the first that it cannot, and why (the field
/// and the limit).
pub fn check_held(scenes: &[Resolved]) -> Result<Vec<Vec<u8>>, (usize, String)> {
    let mut held = Vec::new();
    for (id, r) in scenes.iter().enumerate() {
        held.push(r.scene_bytes().map_err(|e| (id, e))?);
    }
    let blobs: Vec<&[u8]> = held.iter().map(Vec::as_slice).collect();
    let library = Library::<MAX_SCENE_DATA>::new(&blobs, WIDEST);
    for id in 0..scenes.len() {
        if let Err((reason, f)) = library.scene(id as u32) {
            return Err((
                id,
                format!(
                    "{}: {reason:?} (this camera renders lines of at most {WIDEST} pixels and frames of at most \
                     {} MiB)",
                    f.name(),
                    hilcam::link::MAX_FRAME_BYTES >> 20
                ),
            ));
        }
    }
    Ok(held)
}

/// The host camera's widest line: one encoder chunk, two bytes a pixel at
/// most (a wider scene is refused when it is loaded).
const WIDEST: u16 = (DEFAULT_CHUNK / 2) as u16;

/// What the camera did.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct CameraStats {
    /// Requests decoded.
    pub requests: u32,
    /// Messages refused by the receiver (oversize, COBS, CRC, malformed).
    pub refused: [u32; 4],
    /// Commands applied (acknowledged), repeats included.
    pub acks: u32,
    /// Commands refused.
    pub rejects: u32,
    /// Frames sent.
    pub frames: u32,
    /// The host hung up while the camera wrote (the session's end).
    pub hung_up: bool,
}

/// Runs the camera over `scenes` (the first shown first), reading
/// commands from `reader` and writing answers and frames to `writer`,
/// until the input ends and no frame is pending.
pub fn serve<R: Read + Send + 'static, W: Write>(
    reader: R,
    writer: W,
    scenes: &[Resolved],
) -> Result<CameraStats, String> {
    let input = spawn_reader(reader, None);
    serve_from(input, writer, scenes)
}

/// [`serve`] with the input already on a channel.
pub fn serve_from<W: Write>(
    input: mpsc::Receiver<(Instant, Vec<u8>)>,
    writer: W,
    scenes: &[Resolved],
) -> Result<CameraStats, String> {
    // The scenes as data, as a firmware holds them, each one it can show.
    let held = check_held(scenes).map_err(|(id, e)| format!("scene {id} ({}): {e}", scenes[id].desc.name))?;
    let blobs: Vec<&[u8]> = held.iter().map(Vec::as_slice).collect();
    let mut library = Library::<MAX_SCENE_DATA>::new(&blobs, WIDEST);
    let mut scene = library
        .scene(0)
        .map_err(|(_, f)| format!("scene 0: {}", f.name()))?;
    let mut control = Control::new();
    let mut rx = Receiver::<MAX_REQUEST>::new();
    let mut enc = Encoder::<_, DEFAULT_CHUNK>::new(IoWrite(writer)).map_err(|e| format!("encoder: {e:?}"))?;
    let t0 = Instant::now();
    let now_ns = || t0.elapsed().as_nanos() as u64;
    let mut frame_id = 0u32;
    let mut stats = CameraStats::default();
    let (mut open, mut hung_up, mut cut) = (true, false, false);
    loop {
        if hung_up {
            break;
        }
        // Wait for input only as long as no frame is due.
        let got = match control.mode {
            _ if !open => Err(mpsc::RecvTimeoutError::Disconnected),
            Mode::Triggered if control.pending == 0 => input.recv_timeout(Duration::from_millis(50)),
            Mode::FreeRun { .. } => input.recv_timeout(Duration::from_millis(1)),
            Mode::Triggered => input.try_recv().map_err(|e| match e {
                mpsc::TryRecvError::Empty => mpsc::RecvTimeoutError::Timeout,
                mpsc::TryRecvError::Disconnected => mpsc::RecvTimeoutError::Disconnected,
            }),
        };
        match got {
            Ok((_, bytes)) => {
                for b in bytes {
                    let Some(r) = rx.push(b) else { continue };
                    let Ok(req) = r else { continue };
                    let seq = req.seq;
                    let answer = control.handle(&req, &mut scene, &mut library);
                    match answer {
                        Answer::Ack => stats.acks += 1,
                        Answer::Reject(..) => stats.rejects += 1,
                        Answer::Describe => {}
                    }
                    let sent = enc.send_answer(seq, answer, control.stamp(now_ns()), || {
                        control.describe(&scene, &library, frame_id)
                    });
                    match sent.map_err(|e| stop("answering", e)) {
                        Ok(()) => {}
                        Err(Stop::HungUp) => hung_up = true,
                        Err(Stop::Failed(e)) => return Err(e),
                    }
                }
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => open = false,
        }
        if !open && control.pending == 0 {
            break;
        }
        if control.frame_due(now_ns()) {
            let name = scenes
                .get(control.scene_id as usize)
                .map_or("loaded", |r| r.desc.name.as_str());
            let (core, stages) = planned_frame(&scene, name, &Budget::default(), frame_id)?;
            let start = FrameStart::of(
                frame_id,
                control.scene_id,
                &scene,
                &stages,
                now_ns(),
                control.last_command(),
            );
            let sent = send_frame(&mut enc, start, &core);
            match sent {
                Ok(()) => {}
                Err(Stop::HungUp) => {
                    hung_up = true;
                    cut = control.mode == Mode::Triggered;
                    break;
                }
                Err(Stop::Failed(e)) => return Err(e),
            }
            frame_id = frame_id.wrapping_add(1);
            stats.frames += 1;
        }
    }
    stats.requests = rx.stats.requests;
    stats.refused = rx.stats.errors;
    stats.hung_up = hung_up;
    // A hang-up ends a session cleanly unless it left triggered frames
    // undelivered.
    let undelivered = control.pending + u32::from(cut);
    if hung_up && control.mode == Mode::Triggered && undelivered > 0 {
        return Err(format!(
            "the host hung up with {undelivered} triggered frames undelivered ({} sent)",
            stats.frames
        ));
    }
    Ok(stats)
}

/// Sends a rendered frame: its start, each line with its flags, its end.
fn send_frame<W: embedded_io::Write<Error = embedded_io::ErrorKind>>(
    enc: &mut Encoder<W, DEFAULT_CHUNK>,
    start: FrameStart,
    core: &crate::harness::Collect,
) -> Result<(), Stop> {
    enc.begin_frame(start).map_err(|e| stop("sending", e))?;
    let lines = core.pixels.chunks(start.line_bytes().max(1));
    for (line, flags) in lines.zip(core.flags.chunks(usize::from(start.width).max(1))) {
        enc.push_line(line).map_err(|e| stop("sending", e))?;
        enc.push_flags(flags).map_err(|e| stop("sending", e))?;
    }
    enc.end_frame(None).map_err(|e| stop("sending", e))?;
    Ok(())
}
