//! The host → camera direction of the link (`docs/wire.md`, "Commands"):
//! the [`Request`]s a host sends, the answers a camera gives ([`Ack`](crate::link::wire::Ack),
//! [`Reject`](crate::link::wire::Reject), [`Description`]), the [`Receiver`] that turns RX bytes into
//! requests in a fixed buffer, and the camera's command state
//! ([`Control`]: the sequence rule, and the last good state kept whenever
//! a command is refused).
//!
//! Requests are framed like every message: `COBS(postcard(request) ‖
//! CRC-32 LE) 0x00`. Memory is the receiver's `N` bytes, whatever arrives;
//! time is constant per byte.

use crate::geom::extrinsics::Extrinsics;
use crate::link::wire::{
    check_crc, is_canonical, Command, Description, Mode, Reason, Request, WireFormat, CRC32, FIELD_MAX,
    MAX_FRAME_BYTES, MAX_PENDING, MAX_REQUEST, MAX_SCENE_CHUNK, PROTOCOL_VERSION,
};
use crate::scene::data::DataError;
use crate::scene::{Item, Scene};

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
    /// there was none), borrowing the receiver's buffer until the next
    /// byte. Empty messages give `None`.
    pub fn push(&mut self, byte: u8) -> Option<Result<Request<'_>, RxError>> {
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
        if len == 0 && !overflow {
            return None;
        }
        let r = if overflow {
            Err(RxError::Oversize)
        } else {
            decode(self.buf.get_mut(..len).unwrap_or_default())
        };
        self.stats.count(r.as_ref().err().copied());
        Some(r)
    }
}

fn decode(msg: &mut [u8]) -> Result<Request<'_>, RxError> {
    let n = unstuff(msg).ok_or(RxError::Cobs)?;
    let body = check_crc(msg.get(..n).ok_or(RxError::Cobs)?).ok_or(RxError::Crc)?;
    match postcard::from_bytes::<Request>(body) {
        Ok(r) if is_canonical(&r, body) => Ok(r),
        _ => Err(RxError::Malformed),
    }
}

/// Decodes the COBS message `msg` (its bytes before the delimiter) in
/// place by `cobs`' byte-at-a-time state machine, returning the decoded
/// length, or `None` if it is not valid COBS. Each input byte gives at most
/// one output byte, and the first none, so output never overtakes input.
/// (`cobs::decode_in_place` indexes its buffer: it links a panic path into
/// the camera.)
fn unstuff(msg: &mut [u8]) -> Option<usize> {
    let mut state = cobs::DecoderState::Idle;
    let mut n = 0;
    for i in 0..msg.len() {
        let byte = *msg.get(i)?;
        if let cobs::DecodeResult::DataContinue(b) = state.feed(byte).ok()? {
            *msg.get_mut(n)? = b;
            n += 1;
        }
    }
    match state.feed(0).ok()? {
        cobs::DecodeResult::DataComplete => Some(n),
        _ => None,
    }
}

impl RxStats {
    fn count(&mut self, error: Option<RxError>) {
        let i = match error {
            None => {
                self.requests += 1;
                return;
            }
            Some(RxError::Oversize) => 0,
            Some(RxError::Cobs) => 1,
            Some(RxError::Crc) => 2,
            Some(RxError::Malformed) => 3,
        };
        if let Some(c) = self.errors.get_mut(i) {
            *c += 1;
        }
    }
}

/// The answer to a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Answer {
    /// Applied: send an [`Ack`](crate::link::wire::Ack).
    Ack,
    /// Refused: send a [`Reject`](crate::link::wire::Reject) naming the field.
    Reject(Reason, Fault),
    /// Send a [`Description`].
    Describe,
}

/// The value a refused command was refused for: a field of the command
/// (`"pose.rotation"`), or a value of the scene it loads
/// (`"primitives[3].checker.cell"`: an item of the scene's lists and its
/// key).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fault {
    /// The list item, or [`Item::Scene`] for a command's field or a
    /// scene-wide value.
    pub item: Item,
    /// The key.
    pub field: &'static str,
}

impl Fault {
    /// A command's field.
    pub const fn field(field: &'static str) -> Fault {
        Fault {
            item: Item::Scene,
            field,
        }
    }

    /// The name as a [`Reject`](crate::link::wire::Reject) carries it (at most [`FIELD_MAX`] bytes;
    /// the shipped keys are shorter).
    pub fn name(&self) -> heapless::String<FIELD_MAX> {
        let mut s = heapless::String::new();
        let (list, i) = match self.item {
            Item::Scene => ("", None),
            Item::Material(i) => ("materials[", Some(i)),
            Item::Primitive(i) => ("primitives[", Some(i)),
            Item::Light(i) => ("lights[", Some(i)),
        };
        let _ = s.push_str(list);
        if let Some(i) = i {
            // Up to three digits, no formatting machinery (and constant
            // divisors: no division-by-zero path).
            let digits = [(i / 100 % 10, i >= 100), (i / 10 % 10, i >= 10), (i % 10, true)];
            for (d, shown) in digits {
                if shown {
                    let _ = s.push(char::from(b'0' + d));
                }
            }
            let _ = s.push_str("].");
        }
        let _ = s.push_str(self.field);
        s
    }
}

impl From<DataError> for Fault {
    fn from(e: DataError) -> Self {
        let (item, field) = e.field();
        Fault { item, field }
    }
}

/// The scenes a camera holds: built in (encoded [`SceneData`](crate::scene::data::SceneData), e.g. in
/// flash), then the last one loaded over the link into `N` bytes (at most
/// [`crate::scene::data::MAX_SCENE_DATA`] are ever needed). Scene ids: the
/// built-in ones from 0, the loaded one after them. A scene is checked
/// against a frame holding distortion tables of at most `T` entries (the
/// camera's [`crate::render::Frame`]).
pub struct Library<'a, const N: usize, const T: usize = { crate::geom::distortion::MAX_LUT }> {
    builtin: &'a [&'a [u8]],
    upload: [u8; N],
    /// The length of the encoding being received (or received).
    total: usize,
    /// Bytes of it received.
    have: usize,
    /// A scene was loaded whole: its id (`builtin.len()`) exists, and stays
    /// in the list while another is received or after one is refused.
    loaded: bool,
    /// The upload buffer holds that scene (not the parts of another).
    intact: bool,
    max_width: u16,
}

impl<'a, const N: usize, const T: usize> Library<'a, N, T> {
    /// A camera holding `builtin` scenes, rendering lines of at most
    /// `max_width` pixels (wider scenes are refused).
    pub const fn new(builtin: &'a [&'a [u8]], max_width: u16) -> Self {
        Library {
            builtin,
            upload: [0; N],
            total: 0,
            have: 0,
            loaded: false,
            intact: false,
            max_width,
        }
    }

    /// Scenes held: the built-in ones and, once one was loaded, that one.
    pub fn count(&self) -> u32 {
        self.builtin.len() as u32 + u32::from(self.loaded)
    }

    /// The encoding of scene `id` (`None` for the loaded scene's id while
    /// its bytes are being replaced).
    pub fn get(&self, id: u32) -> Option<&[u8]> {
        match self.builtin.get(id as usize) {
            Some(b) => Some(b),
            None if self.intact && id as usize == self.builtin.len() => self.upload.get(..self.total),
            None => None,
        }
    }

    /// Builds scene `id` and checks that this camera can render it.
    #[inline(never)]
    pub fn scene(&self, id: u32) -> Result<Scene, (Reason, Fault)> {
        let bytes = self.encoding(id)?;
        // Built and checked in the value returned: no scene-sized copy.
        let mut scene = crate::scene::data::load_as(bytes, refusal);
        if let Ok(s) = &scene {
            if let Err(f) = check::<T>(s, self.max_width) {
                scene = Err((Reason::Unsupported, f));
            }
        }
        scene
    }

    /// Builds scene `id`, checks it and shows it in `shown`; refused, leaves
    /// `shown` as it was.
    fn show(&self, id: u32, shown: &mut Scene) -> Result<(), (Reason, Fault)> {
        self.replace(self.encoding(id)?, shown)
    }

    /// The encoding of scene `id`, or the refusal naming `scene.id`: an id
    /// outside the list is `Invalid`; the loaded scene's while another
    /// scene's parts replace its bytes is `Unsupported` (it cannot be built
    /// again, though a camera showing it goes on showing it).
    fn encoding(&self, id: u32) -> Result<&[u8], (Reason, Fault)> {
        match self.get(id) {
            Some(b) => Ok(b),
            None if id < self.count() => Err((Reason::Unsupported, Fault::field("scene.id"))),
            None => Err((Reason::Invalid, Fault::field("scene.id"))),
        }
    }

    /// Builds the scene encoded in `bytes` and checks it against this
    /// camera; then shows it in `shown`, else leaves `shown` as it was. Out
    /// of line: the one scene under construction lives in this call's
    /// stack frame, not in the camera loop's while it renders.
    #[inline(never)]
    fn replace(&self, bytes: &[u8], shown: &mut Scene) -> Result<(), (Reason, Fault)> {
        // The one scene under construction: built, checked by reference and
        // moved from in place. (Built as `Library::scene` builds, it would
        // take a second scene-sized slot here: 1.4 KB more at the camera's
        // peak, measured.)
        let next = crate::scene::data::load_as(bytes, refusal);
        let checked = match &next {
            Ok(s) => check::<T>(s, self.max_width).map_err(|f| (Reason::Unsupported, f)),
            Err(e) => Err(*e),
        };
        checked?;
        if let Ok(s) = next {
            *shown = s;
        }
        Ok(())
    }

    /// Takes a part of a scene being loaded; once it is complete, builds
    /// and checks the scene, shows it in `shown` and returns `true`. A
    /// refused part leaves the parts before it in place, and `shown` as it
    /// was.
    fn load(
        &mut self,
        total: u16,
        offset: u16,
        bytes: &[u8],
        shown: &mut Scene,
    ) -> Result<bool, (Reason, Fault)> {
        let invalid = |f: &'static str| (Reason::Invalid, Fault::field(f));
        let (total, offset) = (usize::from(total), usize::from(offset));
        if offset == 0 {
            if total == 0 || total > N {
                return Err(invalid("load.total"));
            }
        } else if offset != self.have || total != self.total {
            return Err(invalid("load.offset"));
        }
        let end = offset + bytes.len();
        if bytes.is_empty() || bytes.len() > MAX_SCENE_CHUNK || end > total {
            return Err(invalid("load.bytes"));
        }
        let slot = self.upload.get_mut(offset..end).ok_or(invalid("load.bytes"))?;
        // (Not `copy_from_slice`: see `link`'s line copy.)
        slot.iter_mut().zip(bytes).for_each(|(d, s)| *d = *s);
        if offset == 0 {
            // A new scene's parts replace the loaded one's bytes; its id
            // stays in the list (`encoding`).
            self.intact = false;
            self.total = total;
        }
        self.have = end;
        if end < total {
            return Ok(false);
        }
        self.replace(self.upload.get(..total).unwrap_or_default(), shown)?;
        (self.loaded, self.intact) = (true, true);
        Ok(true)
    }
}

/// Why a scene's data is refused.
fn refusal(e: DataError) -> (Reason, Fault) {
    use crate::scene::Problem;
    match e {
        // A stage left out of the build, or more items than it holds.
        DataError::NotBuilt { .. } => (Reason::Unsupported, e.into()),
        DataError::Scene(s) if s.problem == Problem::TooMany => (Reason::Unsupported, e.into()),
        _ => (Reason::Invalid, e.into()),
    }
}

/// Whether this camera renders `scene`: lines of at most `max_width`
/// pixels, and the frame the planner picks prepares.
#[inline(never)]
fn check<const T: usize>(scene: &Scene, max_width: u16) -> Result<(), Fault> {
    use crate::render::RenderError as E;
    let (w, h) = scene.camera.intrinsics.size();
    if w > max_width {
        return Err(Fault::field("camera.width"));
    }
    // Frames a receiver takes ([`MAX_FRAME_BYTES`]).
    // (In u64: 65 535² × 2 bytes does not fit a 32-bit usize.)
    if u64::from(w) * u64::from(h) * scene.format.bytes_per_pixel() as u64 > MAX_FRAME_BYTES as u64 {
        return Err(Fault::field("camera.height"));
    }
    crate::planner::check::<T>(scene).map_err(|e| {
        Fault::field(match e {
            E::FieldTooWide => "camera.focal_length",
            E::DistortionOutOfRange | E::TableTooLarge => "camera.distortion",
            E::NotBuilt if scene.noise.is_some() => "noise",
            E::NotBuilt | E::OutsideFormat if scene.sampling.is_some() => "sampling",
            E::NotBuilt | E::OutsideFormat => "camera.aperture",
            E::BufferTooSmall => "camera.width",
            E::Degenerate => "primitives",
        })
    })
}

/// The camera's command state: the sequence rule, the mode and the frames
/// promised. The scene is the caller's; a refused command leaves it as it
/// was.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Control {
    last: Option<Last>,
    /// The mode.
    pub mode: Mode,
    /// Frames promised and not yet begun (triggered mode).
    pub pending: u32,
    /// The scene shown.
    pub scene_id: u32,
    due_ns: u64,
    /// Commands that changed the scene ([`Control::revision`]).
    revision: u32,
}

/// The last command processed: what a repeat of it must match, and what
/// it was answered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Last {
    seq: u32,
    /// CRC-32 of the command's encoding: a repeat is the same command.
    digest: u32,
    answer: Answer,
    /// When it was first answered ([`Control::stamp`]), ns.
    at_ns: Option<u64>,
}

/// CRC-32 of `c`'s postcard encoding (at most [`MAX_REQUEST`] bytes).
fn digest(c: &Command) -> u32 {
    let mut buf = [0u8; MAX_REQUEST];
    match postcard::to_slice(c, &mut buf) {
        Ok(b) => CRC32.checksum(b),
        // Nothing that decoded from a request fails to encode back.
        Err(_) => 0,
    }
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
            revision: 0,
        }
    }

    /// How many commands changed the scene (wrapping): a pose, an
    /// exposure, a scene selected, a scene loaded whole. What a frame is
    /// planned from changes only with it, so a camera plans when it moves
    /// (once a change, not once a frame, and not between a trigger and its
    /// frame).
    pub fn revision(&self) -> u32 {
        self.revision
    }

    /// The last command processed.
    pub fn last_command(&self) -> Option<u32> {
        self.last.map(|l| l.seq)
    }

    /// The time stamp of the answer to the command just handled: `now_ns`
    /// for a new command, and for a repeat the first answer's, so that a
    /// repeat's answer is the same bytes.
    pub fn stamp(&mut self, now_ns: u64) -> u64 {
        match &mut self.last {
            Some(l) => *l.at_ns.get_or_insert(now_ns),
            None => now_ns,
        }
    }

    /// Processes `req` against `scene` (the scene shown) and the camera's
    /// `library`. Returns the answer to send.
    pub fn handle<const N: usize, const T: usize>(
        &mut self,
        req: &Request,
        scene: &mut Scene,
        library: &mut Library<'_, N, T>,
    ) -> Answer {
        if req.version != PROTOCOL_VERSION {
            return Answer::Reject(
                Reason::Version {
                    speaks: PROTOCOL_VERSION,
                },
                Fault::field("version"),
            );
        }
        if req.command == Command::Describe {
            return Answer::Describe;
        }
        let d = digest(&req.command);
        match self.last {
            // A repeat: the same number and the same command.
            Some(l) if l.seq == req.seq && l.digest == d => return l.answer,
            // The last command's number on another command, or a number out
            // of turn: nothing applied.
            Some(l) if l.seq.wrapping_add(1) != req.seq => {
                return Answer::Reject(
                    Reason::OutOfOrder {
                        expected: l.seq.wrapping_add(1),
                    },
                    Fault::field("seq"),
                )
            }
            _ => {}
        }
        let answer = match self.apply(&req.command, scene, library) {
            Ok(changed) => {
                self.revision = self.revision.wrapping_add(u32::from(changed));
                Answer::Ack
            }
            Err((reason, fault)) => Answer::Reject(reason, fault),
        };
        self.last = Some(Last {
            seq: req.seq,
            digest: d,
            answer,
            at_ns: None,
        });
        answer
    }

    /// Applies `c`; whether it changed the scene ([`Control::revision`]).
    fn apply<const N: usize, const T: usize>(
        &mut self,
        c: &Command,
        scene: &mut Scene,
        library: &mut Library<'_, N, T>,
    ) -> Result<bool, (Reason, Fault)> {
        let invalid = |f: &'static str| (Reason::Invalid, Fault::field(f));
        match *c {
            Command::Describe => Ok(false),
            Command::SetPose {
                rotation,
                translation,
            } => {
                let pose = Extrinsics::from_matrix(rotation, translation).map_err(|e| match e {
                    crate::Error::NotFinite(crate::Field::Translation)
                    | crate::Error::OutOfRange(crate::Field::Translation) => invalid("pose.translation"),
                    _ => invalid("pose.rotation"),
                })?;
                scene.set_pose(pose).map_err(|_| invalid("pose.translation"))?;
                Ok(true)
            }
            Command::SetExposure { k } => {
                scene.set_exposure(k).map_err(|_| invalid("exposure.k"))?;
                Ok(true)
            }
            Command::SetMode(m) => {
                self.mode = m;
                self.pending = 0;
                self.due_ns = 0;
                Ok(false)
            }
            Command::Trigger { frames } => {
                if self.mode != Mode::Triggered {
                    return Err((Reason::WrongMode, Fault::field("mode")));
                }
                let total = self.pending + u32::from(frames);
                if frames == 0 || total > MAX_PENDING {
                    return Err(invalid("trigger.frames"));
                }
                self.pending = total;
                Ok(false)
            }
            Command::SelectScene { id } => {
                library.show(id, scene)?;
                self.scene_id = id;
                Ok(true)
            }
            Command::LoadScene { total, offset, bytes } => {
                let whole = library.load(total, offset, bytes, scene)?;
                if whole {
                    self.scene_id = library.count() - 1;
                }
                Ok(whole)
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

    /// The [`Description`] of a camera showing `scene` from `library`,
    /// whose next frame will be `next_frame`.
    pub fn describe<const N: usize, const T: usize>(
        &self,
        scene: &Scene,
        library: &Library<'_, N, T>,
        next_frame: u32,
    ) -> Description {
        let (width, height) = scene.camera.intrinsics.size();
        Description {
            version: PROTOCOL_VERSION,
            scenes: library.count(),
            scene_id: self.scene_id,
            width,
            height,
            format: WireFormat::from(scene.format),
            mode: self.mode,
            pending: self.pending,
            last_command: self.last_command(),
            next_frame,
            max_request: MAX_REQUEST as u32,
            max_scene: N as u32,
            max_table: T as u32,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::unstuff;
    use proptest::prelude::*;

    proptest! {
        /// In place, the same bytes as `cobs::decode` into another buffer,
        /// and the same refusals, on any run of non-zero bytes.
        #[test]
        fn unstuff_agrees_with_cobs_decode(msg in proptest::collection::vec(1u8..=255, 1..600)) {
            let mut dest = [0u8; 600];
            let theirs = cobs::decode(&msg, &mut dest).ok().map(|r| r.frame_size());
            let mut ours = msg.clone();
            let n = unstuff(&mut ours);
            prop_assert_eq!(n, theirs);
            if let Some(n) = n {
                prop_assert_eq!(&ours[..n], &dest[..n]);
            }
        }

        /// Encoded messages decode to themselves.
        #[test]
        fn unstuff_inverts_cobs_encode(body in proptest::collection::vec(any::<u8>(), 0..600)) {
            let mut enc = [0u8; 610];
            let k = cobs::encode(&body, &mut enc);
            let mut msg = enc[..k].to_vec();
            prop_assert_eq!(unstuff(&mut msg), Some(body.len()));
            prop_assert_eq!(&msg[..body.len()], &body[..]);
        }
    }
}
