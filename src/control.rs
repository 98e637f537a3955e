//! The host → camera direction of the link (`docs/wire.md`, "Commands"):
//! the [`Request`]s a host sends, the answers a camera gives ([`Ack`],
//! [`Reject`], [`Description`]), the [`Receiver`] that turns RX bytes into
//! requests in a fixed buffer, and the camera's command state
//! ([`Control`]: the sequence rule, and the last good state kept whenever
//! a command is refused).
//!
//! Requests are framed like every message: `COBS(postcard(request) ‖
//! CRC-32 LE) 0x00`. Memory is the receiver's `N` bytes, whatever arrives;
//! time is constant per byte.

use crate::extrinsics::Extrinsics;
use crate::link::{check_crc, is_canonical, WireFormat, PROTOCOL_VERSION};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};

/// The largest encoded request a camera must accept, bytes (COBS, CRC and
/// delimiter included): the receiver buffer the shipped cameras use. The
/// largest request (`SetPose`, 12 f64) encodes to at most 108 bytes.
pub const MAX_REQUEST: usize = 128;

/// Most frames one `Trigger` may ask for, and most frames pending at once.
pub const MAX_PENDING: u32 = 65_535;

/// A command with its envelope.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Request {
    /// [`PROTOCOL_VERSION`]; a camera refuses any other.
    pub version: u8,
    /// Sequence number: a camera applies a command only if it follows the
    /// last one it processed (`seq = last + 1`, wrapping; any value for the
    /// first), answers a repeat of the last one again without applying it,
    /// and refuses anything else ([`Reason::OutOfOrder`]). `Describe` is
    /// answered whatever its number and does not count.
    pub seq: u32,
    /// What to do.
    pub command: Command,
}

/// What a host asks of a camera.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Tag 0: answer with a [`Description`].
    Describe,
    /// Tag 1: the pose of the next frames: `R` (rows: the camera's axes in
    /// world coordinates, orthonormal within 10⁻⁶, det +1) and `T` (the
    /// centre of projection, metres, within ±1000 m per coordinate),
    /// camera-model.md §1.
    SetPose {
        /// `R`, row by row.
        rotation: [[f64; 3]; 3],
        /// `T`, metres.
        translation: [f64; 3],
    },
    /// Tag 2: the exposure `K`, DN per W/m² (0 to 10⁹).
    SetExposure {
        /// `K`.
        k: f64,
    },
    /// Tag 3: free-running or triggered.
    SetMode(Mode),
    /// Tag 4: render `frames` more frames (1 to [`MAX_PENDING`]; triggered
    /// mode only).
    Trigger {
        /// How many.
        frames: u16,
    },
    /// Tag 5: show the camera's scene `id` (its pose, exposure and every
    /// other value as that scene gives them).
    SelectScene {
        /// The camera's scene number (`Description::scenes` of them).
        id: u32,
    },
}

/// When the camera renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Tag 0: a frame for each one a `Trigger` asked for (the mode a camera
    /// starts in).
    Triggered,
    /// Tag 1: a frame every `period_us` µs of the camera's time, or back to
    /// back if rendering takes longer (0: back to back).
    FreeRun {
        /// Frame period, µs.
        period_us: u32,
    },
}

/// A command was applied (or was a repeat of the last one applied).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ack {
    /// The command's sequence number.
    pub seq: u32,
    /// When the camera processed it, ns in its time base.
    pub timestamp_ns: u64,
}

/// A command was refused; nothing of it was applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Reject<'a> {
    /// The command's sequence number.
    pub seq: u32,
    /// Why.
    pub reason: Reason,
    /// The field at fault, as `docs/wire.md` names it (`""` if none).
    pub field: &'a str,
}

/// Why a command was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reason {
    /// Tag 0: a protocol version the camera does not speak.
    Version {
        /// The version it speaks.
        speaks: u8,
    },
    /// Tag 1: not the next sequence number.
    OutOfOrder {
        /// The number the camera expects.
        expected: u32,
    },
    /// Tag 2: a value outside its valid range (`field` names it).
    Invalid,
    /// Tag 3: not possible in the current mode (`Trigger` while free-running).
    WrongMode,
}

/// What a camera is and does now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Description {
    /// [`PROTOCOL_VERSION`].
    pub version: u8,
    /// Scenes the camera holds (`SelectScene` ids 0 to `scenes − 1`).
    pub scenes: u32,
    /// The scene it shows.
    pub scene_id: u32,
    /// Frame size, pixels.
    pub width: u16,
    /// Frame size, pixels.
    pub height: u16,
    /// Pixel format.
    pub format: WireFormat,
    /// Its mode.
    pub mode: Mode,
    /// Frames promised and not yet begun (triggered mode).
    pub pending: u32,
    /// The last command it processed (the next must be this + 1).
    pub last_command: Option<u32>,
    /// The id its next frame will carry.
    pub next_frame: u32,
    /// The largest encoded request it accepts, bytes.
    pub max_request: u32,
}

/// Why received bytes did not make a request (the receiver skips to the
/// next `0x00`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RxError {
    /// Longer than the receiver's buffer.
    Oversize,
    /// Invalid COBS.
    Cobs,
    /// CRC-32 mismatch, or too short to hold one.
    Crc,
    /// A good CRC around a body that is not the canonical encoding of a
    /// [`Request`].
    Malformed,
}

/// What the receiver saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RxStats {
    /// Bytes pushed.
    pub bytes: u64,
    /// Requests decoded.
    pub requests: u32,
    /// Messages refused, by [`RxError`] kind: oversize, COBS, CRC, malformed.
    pub errors: [u32; 4],
}

/// Turns bytes received into [`Request`]s, in a buffer of `N` bytes (at
/// least [`MAX_REQUEST`] for every request to fit). Never panics, never
/// allocates; each byte costs constant time except a delimiter, which
/// decodes at most `N` bytes.
pub struct Receiver<const N: usize> {
    buf: [u8; N],
    len: usize,
    overflow: bool,
    /// Counts so far.
    pub stats: RxStats,
}

impl<const N: usize> Default for Receiver<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Receiver<N> {
    /// An empty receiver.
    pub const fn new() -> Self {
        Receiver {
            buf: [0; N],
            len: 0,
            overflow: false,
            stats: RxStats {
                bytes: 0,
                requests: 0,
                errors: [0; 4],
            },
        }
    }

    /// Feeds one byte; at a delimiter, returns the request it ended (or why
    /// there was none). Empty messages give `None`.
    pub fn push(&mut self, byte: u8) -> Option<Result<Request, RxError>> {
        self.stats.bytes += 1;
        if byte != 0 {
            match self.buf.get_mut(self.len) {
                Some(slot) if !self.overflow => {
                    *slot = byte;
                    self.len += 1;
                }
                _ => self.overflow = true,
            }
            return None;
        }
        let (len, overflow) = (self.len, self.overflow);
        self.len = 0;
        self.overflow = false;
        if overflow {
            return Some(self.count(Err(RxError::Oversize)));
        }
        if len == 0 {
            return None;
        }
        let r = self.decode(len);
        Some(self.count(r))
    }

    fn decode(&mut self, len: usize) -> Result<Request, RxError> {
        let msg = self.buf.get_mut(..len).ok_or(RxError::Oversize)?;
        let n = cobs::decode_in_place(msg).map_err(|_| RxError::Cobs)?;
        let body = check_crc(msg.get(..n).ok_or(RxError::Cobs)?).ok_or(RxError::Crc)?;
        match postcard::from_bytes::<Request>(body) {
            Ok(r) if is_canonical(&r, body) => Ok(r),
            _ => Err(RxError::Malformed),
        }
    }

    fn count(&mut self, r: Result<Request, RxError>) -> Result<Request, RxError> {
        match r {
            Ok(_) => self.stats.requests += 1,
            Err(e) => {
                let i = match e {
                    RxError::Oversize => 0,
                    RxError::Cobs => 1,
                    RxError::Crc => 2,
                    RxError::Malformed => 3,
                };
                if let Some(c) = self.stats.errors.get_mut(i) {
                    *c += 1;
                }
            }
        }
        r
    }
}

/// The answer to a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Answer {
    /// Applied: send an [`Ack`].
    Ack,
    /// Refused: send a [`Reject`] naming `field`.
    Reject(Reason, &'static str),
    /// Send a [`Description`].
    Describe,
}

/// The camera's command state: the sequence rule, the mode and the frames
/// promised. The scene is the caller's; a refused command leaves it as it
/// was.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Control {
    last: Option<(u32, Answer)>,
    /// The mode.
    pub mode: Mode,
    /// Frames promised and not yet begun (triggered mode).
    pub pending: u32,
    /// The scene shown.
    pub scene_id: u32,
    due_ns: u64,
}

impl Default for Control {
    fn default() -> Self {
        Self::new()
    }
}

impl Control {
    /// Triggered, nothing pending, scene 0, no command yet.
    pub const fn new() -> Self {
        Control {
            last: None,
            mode: Mode::Triggered,
            pending: 0,
            scene_id: 0,
            due_ns: 0,
        }
    }

    /// The last command processed.
    pub fn last_command(&self) -> Option<u32> {
        self.last.map(|(s, _)| s)
    }

    /// Processes `req` against `scene` (the scene shown); `select(id)`
    /// builds scene `id` of the `scenes` the camera holds. Returns the
    /// answer to send.
    pub fn handle(
        &mut self,
        req: &Request,
        scene: &mut Scene,
        scenes: u32,
        select: impl FnOnce(u32) -> Result<Scene, &'static str>,
    ) -> Answer {
        if req.version != PROTOCOL_VERSION {
            return Answer::Reject(
                Reason::Version {
                    speaks: PROTOCOL_VERSION,
                },
                "version",
            );
        }
        if req.command == Command::Describe {
            return Answer::Describe;
        }
        match self.last {
            Some((s, answer)) if s == req.seq => return answer,
            Some((s, _)) if s.wrapping_add(1) != req.seq => {
                return Answer::Reject(
                    Reason::OutOfOrder {
                        expected: s.wrapping_add(1),
                    },
                    "seq",
                )
            }
            _ => {}
        }
        let answer = match self.apply(&req.command, scene, scenes, select) {
            Ok(()) => Answer::Ack,
            Err((reason, field)) => Answer::Reject(reason, field),
        };
        self.last = Some((req.seq, answer));
        answer
    }

    fn apply(
        &mut self,
        c: &Command,
        scene: &mut Scene,
        scenes: u32,
        select: impl FnOnce(u32) -> Result<Scene, &'static str>,
    ) -> Result<(), (Reason, &'static str)> {
        let invalid = |f: &'static str| (Reason::Invalid, f);
        match *c {
            Command::Describe => Ok(()),
            Command::SetPose {
                rotation,
                translation,
            } => {
                let pose = Extrinsics::from_matrix(rotation, translation).map_err(|e| match e {
                    crate::Error::NotFinite(crate::Field::Translation)
                    | crate::Error::OutOfRange(crate::Field::Translation) => invalid("pose.translation"),
                    _ => invalid("pose.rotation"),
                })?;
                scene.set_pose(pose).map_err(|_| invalid("pose.translation"))
            }
            Command::SetExposure { k } => scene.set_exposure(k).map_err(|_| invalid("exposure.k")),
            Command::SetMode(m) => {
                self.mode = m;
                self.pending = 0;
                self.due_ns = 0;
                Ok(())
            }
            Command::Trigger { frames } => {
                if self.mode != Mode::Triggered {
                    return Err((Reason::WrongMode, "mode"));
                }
                let total = self.pending + u32::from(frames);
                if frames == 0 || total > MAX_PENDING {
                    return Err(invalid("trigger.frames"));
                }
                self.pending = total;
                Ok(())
            }
            Command::SelectScene { id } => {
                if id >= scenes {
                    return Err(invalid("scene.id"));
                }
                *scene = select(id).map_err(|_| invalid("scene.id"))?;
                self.scene_id = id;
                Ok(())
            }
        }
    }

    /// Whether a frame is due at `now_ns` (the camera's time); if so, it is
    /// counted as begun.
    pub fn frame_due(&mut self, now_ns: u64) -> bool {
        match self.mode {
            Mode::Triggered if self.pending > 0 => {
                self.pending -= 1;
                true
            }
            Mode::Triggered => false,
            Mode::FreeRun { period_us } => {
                if now_ns < self.due_ns {
                    return false;
                }
                let period = u64::from(period_us) * 1000;
                // Back to back when late: the next frame is due a period
                // after this one begins.
                self.due_ns = now_ns.saturating_add(period);
                true
            }
        }
    }

    /// The [`Description`] of a camera showing `scene`, holding `scenes`,
    /// whose next frame will be `next_frame`.
    pub fn describe(&self, scene: &Scene, scenes: u32, next_frame: u32) -> Description {
        let (width, height) = scene.camera.intrinsics.size();
        Description {
            version: PROTOCOL_VERSION,
            scenes,
            scene_id: self.scene_id,
            width,
            height,
            format: WireFormat::from(scene.format),
            mode: self.mode,
            pending: self.pending,
            last_command: self.last_command(),
            next_frame,
            max_request: MAX_REQUEST as u32,
        }
    }
}
