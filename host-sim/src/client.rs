//! The host's client of a camera: one implementation of the protocol's
//! host side (docs/wire.md) that `host-sim drive`, the Python package and
//! the tests use.
//!
//! ```no_run
//! use host_sim::client::Client;
//! use std::time::Duration;
//!
//! // The firmware on a board's UART, or `host-sim camera --port PTY`.
//! let mut cam = Client::open("/dev/ttyACM0", 921_600)?;
//! let d = cam.describe()?;
//! cam.look_at([0.0, -2.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])?;
//! cam.set_exposure(4.0)?;
//! cam.trigger(1)?;
//! if let Some(a) = cam.next_frame(Duration::from_secs(5))? {
//!     let f = a.frame;
//!     assert_eq!(f.pixels.len(), d.width as usize * d.height as usize * f.start.format.bytes_per_pixel());
//!     println!("frame {} at {} ns", f.start.frame_id, f.start.truth.timestamp_ns);
//! }
//! # Ok::<(), host_sim::client::ClientError>(())
//! ```

use crate::link::decoder::{Decoder, Frame, Reply, Stats};
use hilcam::link::{encode_message, Ack, Command, Description, Mode, Reason, Request};
use hilcam::link::{MAX_REQUEST, MAX_SCENE_CHUNK, PROTOCOL_VERSION};
use std::collections::{HashMap, VecDeque};
use std::io::{Read, Write};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Why an operation failed.
#[derive(Clone, Debug, PartialEq)]
pub enum ClientError {
    /// The camera refused the command; nothing of it was applied.
    Refused {
        /// The command, by name (`SetPose`, `Trigger`, ...).
        command: &'static str,
        /// Its sequence number.
        seq: u32,
        /// The camera's reason.
        reason: Reason,
        /// The field at fault as docs/wire.md names it (`""`: none).
        field: String,
    },
    /// The link failed: closed, silent after every resend, or answering
    /// out of turn; or a value was refused before it was sent.
    Link(String),
}

impl std::fmt::Display for ClientError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ClientError::Refused {
                command,
                seq,
                reason,
                field,
            } if field.is_empty() => write!(f, "{command} (command {seq}) refused: {reason:?}"),
            ClientError::Refused {
                command,
                seq,
                reason,
                field,
            } => write!(f, "{command} (command {seq}) refused: {reason:?}, field {field}"),
            ClientError::Link(e) => f.write_str(e),
        }
    }
}

impl std::error::Error for ClientError {}

impl From<String> for ClientError {
    fn from(e: String) -> Self {
        ClientError::Link(e)
    }
}

/// A command's name, for errors.
fn name(c: &Command) -> &'static str {
    match c {
        Command::Describe => "Describe",
        Command::SetPose { .. } => "SetPose",
        Command::SetExposure { .. } => "SetExposure",
        Command::SetMode(_) => "SetMode",
        Command::Trigger { .. } => "Trigger",
        Command::SelectScene { .. } => "SelectScene",
        Command::LoadScene { .. } => "LoadScene",
    }
}

/// Bytes from the camera, with the time they arrived.
type Batch = (Instant, Vec<u8>);

/// Reads `r` on a thread until it ends, sending what arrives (and
/// appending it to `capture`, the raw wire bytes, when given).
pub fn spawn_reader(
    mut r: impl Read + Send + 'static,
    mut capture: Option<std::fs::File>,
) -> mpsc::Receiver<Batch> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut buf = vec![0u8; 1 << 14];
        loop {
            match r.read(&mut buf) {
                Ok(0) => return,
                Ok(n) => {
                    if let Some(f) = capture.as_mut() {
                        if f.write_all(&buf[..n]).is_err() {
                            capture = None;
                        }
                    }
                    if tx.send((Instant::now(), buf[..n].to_vec())).is_err() {
                        return;
                    }
                }
                // Serial ports time out when idle: keep reading.
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::Interrupted
                            | std::io::ErrorKind::TimedOut
                            | std::io::ErrorKind::WouldBlock
                    ) => {}
                Err(_) => return,
            }
        }
    });
    rx
}

/// A frame and when its first message arrived.
pub struct Arrived {
    /// The frame.
    pub frame: Frame,
    /// When the batch holding its `FrameStart` arrived.
    pub first_byte: Instant,
}

/// The host's end of a link to a camera: sends requests (numbered,
/// resent on silence), collects answers and frames.
pub struct Client<W: Write> {
    writer: W,
    rx: mpsc::Receiver<Batch>,
    dec: Decoder,
    frames: VecDeque<Arrived>,
    started: HashMap<u32, Instant>,
    seq: u32,
    /// How long to wait for an answer before sending a request again.
    pub timeout: Duration,
    /// How long to wait for a triggered frame before counting it lost.
    pub frame_timeout: Duration,
    /// Requests sent again after a silence.
    pub resent: u32,
    /// `host-sim drive` sends each pose and its trigger in one write, as a system
    /// under test that fires both at once (the camera reads them in one
    /// batch); otherwise the trigger after the pose's answer.
    pub batched: bool,
}

impl<W: Write> Client<W> {
    /// A driver writing requests to `writer` and reading the camera's bytes
    /// from `rx` ([`spawn_reader`]).
    pub fn new(writer: W, rx: mpsc::Receiver<Batch>) -> Self {
        Client {
            writer,
            rx,
            dec: Decoder::new(1 << 20, hilcam::link::MAX_FRAME_BYTES),
            frames: VecDeque::new(),
            started: HashMap::new(),
            seq: 0,
            timeout: Duration::from_secs(10),
            frame_timeout: Duration::from_secs(120),
            resent: 0,
            batched: false,
        }
    }

    /// The decoder's counts.
    pub fn stats(&self) -> Stats {
        self.dec.stats
    }

    /// The sequence number the next command will carry.
    pub fn set_next_seq(&mut self, seq: u32) {
        self.seq = seq;
    }

    /// Waits until `deadline` for bytes and decodes them; false if none came.
    fn pump(&mut self, deadline: Instant) -> Result<bool, String> {
        let wait = deadline.saturating_duration_since(Instant::now());
        let (at, bytes) = match self.rx.recv_timeout(wait) {
            Ok(b) => b,
            Err(mpsc::RecvTimeoutError::Timeout) => return Ok(false),
            Err(mpsc::RecvTimeoutError::Disconnected) => return Err("the camera closed the link".into()),
        };
        let before = self.dec.open_frame();
        let mut done = Vec::new();
        self.dec.push(&bytes, &mut |f| done.push(f));
        if let Some(id) = self.dec.open_frame().filter(|id| Some(*id) != before) {
            self.started.insert(id, at);
        }
        for f in done {
            let first_byte = self.started.remove(&f.start.frame_id).unwrap_or(at);
            self.frames.push_back(Arrived { frame: f, first_byte });
        }
        Ok(true)
    }

    /// Sends `command` and waits for its answer (resending it, with the
    /// same number, after each silence of `timeout`, three times at most).
    /// Returns the answer and when the request was first sent.
    pub fn command(&mut self, command: Command) -> Result<(Reply, Instant), String> {
        let [answer] = self.commands([command])?;
        Ok(answer)
    }

    /// Sends `commands` in one write, numbered in turn — as a system under
    /// test that fires them at once, so that the camera reads them in one
    /// batch — and waits for each answer in order (a command unanswered
    /// after a silence of `timeout` is sent again alone, with its number,
    /// three times at most). Returns each answer and when it was first
    /// sent.
    pub fn commands<const N: usize>(&mut self, commands: [Command; N]) -> Result<[(Reply, Instant); N], String> {
        let (mut wires, mut all) = (Vec::with_capacity(N), Vec::new());
        for command in &commands {
            let seq = self.seq;
            if *command != Command::Describe {
                self.seq = seq.wrapping_add(1);
            }
            let req = Request {
                version: PROTOCOL_VERSION,
                seq,
                command: *command,
            };
            let mut wire = [0u8; MAX_REQUEST];
            let bytes = encode_message(&req, &mut wire).ok_or("request does not fit MAX_REQUEST")?;
            all.extend_from_slice(bytes);
            wires.push((seq, bytes.to_vec()));
        }
        let sent = Instant::now();
        self.send(&all, wires.first().map_or(self.seq, |w| w.0))?;
        let mut answers = Vec::with_capacity(N);
        for ((seq, bytes), command) in wires.iter().zip(&commands) {
            answers.push((self.answer(*seq, *command, bytes)?, sent));
        }
        answers.try_into().map_err(|_| format!("{N} answers expected"))
    }

    /// Writes a request's bytes.
    fn send(&mut self, bytes: &[u8], seq: u32) -> Result<(), String> {
        self.writer
            .write_all(bytes)
            .and_then(|_| self.writer.flush())
            .map_err(|e| format!("sending command {seq}: {e}"))
    }

    /// Waits for the answer to request `seq` (`command`, sent as `bytes`),
    /// sending it again after each silence of `timeout`, three times at
    /// most.
    fn answer(&mut self, seq: u32, command: Command, bytes: &[u8]) -> Result<Reply, String> {
        for attempt in 0..4 {
            if attempt > 0 {
                self.resent += 1;
                self.send(bytes, seq)?;
            }
            let deadline = Instant::now() + self.timeout;
            loop {
                while let Some(r) = self.dec.replies.pop_front() {
                    let ours = match &r {
                        Reply::Ack(a) => a.seq == seq,
                        Reply::Reject { seq: s, .. } => *s == seq,
                        Reply::Description(_) => command == Command::Describe,
                    };
                    if ours {
                        return Ok(r);
                    }
                }
                if !self.pump(deadline)? {
                    break;
                }
            }
        }
        Err(format!("no answer to command {seq} ({command:?}) after 4 tries"))
    }

    /// Sends `data` (an encoded scene) in `LoadScene` parts; returns the
    /// answer to the last part, or the first refusal.
    pub fn load_scene(&mut self, data: &[u8]) -> Result<Reply, String> {
        let total = u16::try_from(data.len()).map_err(|_| format!("scene data of {} bytes", data.len()))?;
        let mut last = Err("empty scene data".to_string());
        for (k, part) in data.chunks(MAX_SCENE_CHUNK).enumerate() {
            let command = Command::LoadScene {
                total,
                offset: (k * MAX_SCENE_CHUNK) as u16,
                bytes: part,
            };
            match self.command(command)?.0 {
                a @ Reply::Ack(_) => last = Ok(a),
                other => return Ok(other),
            }
        }
        last
    }

    /// The next frame, waiting up to `timeout`.
    pub fn next_frame(&mut self, timeout: Duration) -> Result<Option<Arrived>, String> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(f) = self.frames.pop_front() {
                return Ok(Some(f));
            }
            if !self.pump(deadline)? {
                return Ok(None);
            }
        }
    }
}


/// A serial device's two ends, as the client holds them.
pub type SerialClient = Client<Box<dyn Write + Send>>;

impl SerialClient {
    /// Opens the camera on the serial device `path` (a real port or a pty)
    /// at `baud` and asks where its commands' sequence stands
    /// ([`Client::sync`]).
    pub fn open(path: &str, baud: u32) -> Result<SerialClient, ClientError> {
        let (reader, writer) = crate::link::serial::open(path, baud)?;
        let mut c = Client::new(writer, spawn_reader(reader, None));
        c.sync()?;
        Ok(c)
    }
}

impl<W: Write> Client<W> {
    /// The camera's description.
    pub fn describe(&mut self) -> Result<Description, ClientError> {
        match self.command(Command::Describe)?.0 {
            Reply::Description(d) => Ok(d),
            other => Err(ClientError::Link(format!("Describe answered with {other:?}"))),
        }
    }

    /// Asks the camera for its description and numbers the next command
    /// after the last one it processed (a camera another host drove, or
    /// this one after a restart of the host).
    pub fn sync(&mut self) -> Result<Description, ClientError> {
        let d = self.describe()?;
        self.set_next_seq(d.last_command.map_or(0, |l| l.wrapping_add(1)));
        Ok(d)
    }

    /// Sends `command` and returns its acknowledgement, or the camera's
    /// refusal as [`ClientError::Refused`].
    pub fn apply(&mut self, command: Command) -> Result<Ack, ClientError> {
        match self.command(command)?.0 {
            Reply::Ack(a) => Ok(a),
            Reply::Reject { seq, reason, field } => Err(ClientError::Refused {
                command: name(&command),
                seq,
                reason,
                field,
            }),
            other => Err(ClientError::Link(format!("{} answered with {other:?}", name(&command)))),
        }
    }

    /// The pose of the next frames: `rotation` (rows: the camera's axes in
    /// world coordinates) and `translation` (the centre of projection, m),
    /// camera-model.md §1.
    pub fn set_pose(&mut self, rotation: [[f64; 3]; 3], translation: [f64; 3]) -> Result<Ack, ClientError> {
        self.apply(Command::SetPose {
            rotation,
            translation,
        })
    }

    /// The pose looking from `eye` at `target` with `up` up (m): the
    /// contract's look-at (camera-model.md §1), refused here if degenerate.
    pub fn look_at(&mut self, eye: [f64; 3], target: [f64; 3], up: [f64; 3]) -> Result<Ack, ClientError> {
        let r = hilcam::geom::extrinsics::look_at_matrix(eye, target, up)
            .map_err(|e| ClientError::Link(format!("look_at: {e}")))?;
        self.set_pose(r, eye)
    }

    /// The exposure `K`, DN per W/m² (0 to 10⁹).
    pub fn set_exposure(&mut self, k: f64) -> Result<Ack, ClientError> {
        self.apply(Command::SetExposure { k })
    }

    /// Triggered or free-running.
    pub fn set_mode(&mut self, mode: Mode) -> Result<Ack, ClientError> {
        self.apply(Command::SetMode(mode))
    }

    /// Shows the camera's scene `id` (0 to `Description::scenes − 1`).
    pub fn select_scene(&mut self, id: u32) -> Result<Ack, ClientError> {
        self.apply(Command::SelectScene { id })
    }

    /// Asks for `frames` more frames (triggered mode).
    pub fn trigger(&mut self, frames: u16) -> Result<Ack, ClientError> {
        self.apply(Command::Trigger { frames })
    }

    /// Sends `r` as data (`LoadScene` parts) and returns the camera's
    /// description once it shows it, checked against the scene's size.
    pub fn load_scene_file(&mut self, r: &crate::scene_file::Resolved) -> Result<Description, ClientError> {
        let d = self.sync()?;
        let data = r.scene_bytes()?;
        if data.len() > d.max_scene as usize {
            return Err(ClientError::Link(format!(
                "the camera takes scenes of at most {} bytes as data; {} is {} bytes",
                d.max_scene,
                r.desc.name,
                data.len()
            )));
        }
        match self.load_scene(&data)? {
            Reply::Ack(_) => {}
            Reply::Reject { seq, reason, field } => {
                return Err(ClientError::Refused {
                    command: "LoadScene",
                    seq,
                    reason,
                    field,
                })
            }
            other => return Err(ClientError::Link(format!("LoadScene answered with {other:?}"))),
        }
        let d = self.describe()?;
        let (w, h) = (r.desc.camera.width, r.desc.camera.height);
        if (d.width, d.height) != (w, h) {
            return Err(ClientError::Link(format!(
                "the camera shows {}x{} after loading the scene, which is {w}x{h}",
                d.width, d.height
            )));
        }
        Ok(d)
    }
}
