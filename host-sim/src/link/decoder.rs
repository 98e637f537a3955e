//! The streaming frame decoder: reassembles frames from any byte stream,
//! checks every message's CRC-32 and every frame's, resynchronises at the
//! next `0x00` after any error, and counts what it dropped and why. It never
//! panics, whatever the bytes (a fuzz target and a proptest check it).

use hilcam::link::{
    check_crc, is_canonical, FrameEnd, FrameStart, Message, WireFormat, CRC32, PROTOCOL_VERSION,
};
use hilcam::link::{Ack, Description, Reason};
use serde::Serialize;
use std::io::Read;

/// A delivered frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Its start message.
    pub start: FrameStart,
    /// All its pixel bytes.
    pub pixels: Vec<u8>,
    /// Its end message (CRC, pixels outside the field, device cost).
    pub end: FrameEnd,
    /// A byte a pixel, `FLAG_OUTSIDE_FIELD` where the frame's `Flags`
    /// messages said the pixel is outside the lens field; empty when none
    /// is.
    pub flags: Vec<u8>,
}

/// The flags a frame's `Flags` messages carry for the renderer's `flags`
/// (a byte a pixel): the out-of-field bit alone, and nothing when no pixel
/// has it — what [`Frame::flags`] holds for a frame rendered with them.
pub fn wire_flags(flags: &[u8]) -> Vec<u8> {
    let out = hilcam::render::FLAG_OUTSIDE_FIELD;
    if flags.iter().all(|f| f & out == 0) {
        return Vec::new();
    }
    flags.iter().map(|f| f & out).collect()
}

/// What the decoder saw, and dropped, and why.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Stats {
    /// Bytes fed in.
    pub bytes: u64,
    /// Messages that decoded and passed their CRC.
    pub messages_ok: u64,
    /// Empty messages (consecutive delimiters; frame starts send one).
    pub empty_messages: u64,
    /// Messages whose COBS encoding was invalid.
    pub bad_cobs: u64,
    /// Messages whose CRC-32 did not match (or too short to carry one).
    pub bad_crc: u64,
    /// Messages with a good CRC that did not parse, or parsed but were not
    /// the canonical encoding (trailing bytes, over-long varints).
    pub bad_message: u64,
    /// Messages longer than the decoder accepts (discarded to the next
    /// delimiter).
    pub oversize: u64,
    /// Chunks or ends that belonged to no open frame.
    pub orphans: u64,
    /// Frames delivered.
    pub frames_delivered: u64,
    /// Frames dropped because a chunk was missing or out of place.
    pub frames_dropped_gap: u64,
    /// Frames dropped because the next frame started before their end.
    pub frames_dropped_unfinished: u64,
    /// Frames dropped because the whole-frame CRC did not match.
    pub frames_dropped_crc: u64,
    /// Frames dropped because their flags messages did not add up to the
    /// `FrameEnd`'s count (one was lost), or one was malformed.
    pub frames_dropped_flags: u64,
    /// Frames refused at their start (size, version, or Gray16 `bits`
    /// outside 9 to 16).
    pub frames_refused: u64,
    /// Frames dropped because a Gray16 value was `2^bits` or more.
    pub frames_dropped_value: u64,
    /// Frames the input ended inside ([`Decoder::finish`]).
    pub frames_cut: u64,
    /// Answers to commands received (acks, rejects, descriptions).
    pub replies: u64,
}

/// A camera's answer to a command, as received.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub enum Reply {
    /// Applied.
    Ack(Ack),
    /// Refused.
    Reject {
        /// The command's sequence number.
        seq: u32,
        /// Why.
        reason: Reason,
        /// The field at fault.
        field: String,
    },
    /// The camera's description.
    Description(Description),
}

struct Assembly {
    start: FrameStart,
    pixels: Vec<u8>,
    broken: bool,
    flags: Vec<u8>,
    /// Lines whose `Flags` message arrived (a second one drops the frame).
    flagged: Vec<bool>,
    outside: u32,
    bad_flags: bool,
}

/// Whether every value of a frame's `pixels` is within its format: a
/// Gray16 value below `2^bits`.
fn values_in_range(format: WireFormat, pixels: &[u8]) -> bool {
    match format {
        WireFormat::Gray16 { bits } if bits < 16 => pixels
            .chunks_exact(2)
            .all(|p| u16::from_le_bytes([p[0], p[1]]) >> bits == 0),
        _ => true,
    }
}

/// The decoder. Feed it bytes with [`Decoder::push`].
pub struct Decoder {
    msg: Vec<u8>,
    overflow: bool,
    max_message: usize,
    max_frame: usize,
    open: Option<Assembly>,
    /// Counts so far.
    pub stats: Stats,
    /// When true, the CRC-32 of every good message's body is kept in
    /// `received` (to tell, in tests and campaigns, which messages arrived).
    pub record: bool,
    /// See `record`.
    pub received: Vec<u32>,
    /// Answers to commands, in arrival order (the caller drains them).
    pub replies: std::collections::VecDeque<Reply>,
}

impl Decoder {
    /// Accepts messages up to `max_message` bytes (encoded) and frames up to
    /// `max_frame` pixel bytes.
    pub fn new(max_message: usize, max_frame: usize) -> Decoder {
        Decoder {
            msg: Vec::with_capacity(max_message.min(1 << 16)),
            overflow: false,
            max_message,
            max_frame,
            open: None,
            stats: Stats::default(),
            record: false,
            received: Vec::new(),
            replies: Default::default(),
        }
    }

    /// The id of the frame being assembled, if one is open.
    pub fn open_frame(&self) -> Option<u32> {
        self.open.as_ref().map(|a| a.start.frame_id)
    }

    /// Feeds bytes; calls `deliver` for every frame completed intact.
    pub fn push(&mut self, bytes: &[u8], deliver: &mut impl FnMut(Frame)) {
        self.stats.bytes += bytes.len() as u64;
        let mut rest = bytes;
        while !rest.is_empty() {
            match rest.iter().position(|b| *b == 0) {
                Some(i) => {
                    let (part, tail) = rest.split_at(i);
                    self.append(part);
                    self.end_of_message(deliver);
                    rest = &tail[1..];
                }
                None => {
                    self.append(rest);
                    rest = &[];
                }
            }
        }
    }

    fn append(&mut self, part: &[u8]) {
        if self.overflow {
            return;
        }
        if self.msg.len() + part.len() > self.max_message {
            self.overflow = true;
            self.msg.clear();
        } else {
            self.msg.extend_from_slice(part);
        }
    }

    fn end_of_message(&mut self, deliver: &mut impl FnMut(Frame)) {
        if self.overflow {
            self.overflow = false;
            self.stats.oversize += 1;
            self.msg.clear();
            return;
        }
        if self.msg.is_empty() {
            self.stats.empty_messages += 1;
            return;
        }
        let mut buf = std::mem::take(&mut self.msg);
        match cobs::decode_in_place(&mut buf) {
            Err(_) => self.stats.bad_cobs += 1,
            Ok(n) => self.message(&buf[..n], deliver),
        }
        buf.clear();
        self.msg = buf;
    }

    fn message(&mut self, bytes: &[u8], deliver: &mut impl FnMut(Frame)) {
        let Some(body) = check_crc(bytes) else {
            self.stats.bad_crc += 1;
            return;
        };
        if self.record {
            self.received.push(CRC32.checksum(body));
        }
        // The body must be exactly the canonical encoding of what it
        // decodes to: no trailing bytes, no over-long varints
        // (docs/wire.md).
        let msg: Message<'_> = match postcard::from_bytes(body) {
            Ok(m) if is_canonical(&m, body) => m,
            _ => {
                self.stats.bad_message += 1;
                return;
            }
        };
        self.stats.messages_ok += 1;
        let reply = match msg {
            Message::Ack(a) => Some(Reply::Ack(a)),
            Message::Reject(r) => Some(Reply::Reject {
                seq: r.seq,
                reason: r.reason,
                field: r.field.to_string(),
            }),
            Message::Description(d) => Some(Reply::Description(d)),
            _ => None,
        };
        if let Some(r) = reply {
            // Answers travel between (or inside) frames without touching
            // them.
            self.stats.replies += 1;
            self.replies.push_back(r);
            return;
        }
        match msg {
            Message::FrameStart(s) => {
                if self.open.take().is_some() {
                    self.stats.frames_dropped_unfinished += 1;
                }
                let bad_bits = matches!(s.format, WireFormat::Gray16 { bits } if !(9..=16).contains(&bits));
                if s.version != PROTOCOL_VERSION
                    || s.frame_bytes() > self.max_frame
                    || s.width == 0
                    || s.height == 0
                    || bad_bits
                {
                    self.stats.frames_refused += 1;
                    return;
                }
                self.open = Some(Assembly {
                    start: s,
                    pixels: Vec::with_capacity(s.frame_bytes()),
                    broken: false,
                    flags: Vec::new(),
                    flagged: vec![false; usize::from(s.height)],
                    outside: 0,
                    bad_flags: false,
                });
            }
            Message::Chunk(c) => match &mut self.open {
                Some(a) if a.start.frame_id == c.frame_id => {
                    let line = a.start.line_bytes();
                    let ok = !a.broken
                        && c.offset as usize == a.pixels.len()
                        && c.offset as usize == c.first_line as usize * line
                        && a.pixels.len() + c.data.len() <= a.start.frame_bytes()
                        && c.data.len() % line == 0;
                    if ok {
                        a.pixels.extend_from_slice(c.data);
                    } else {
                        a.broken = true;
                    }
                }
                _ => self.stats.orphans += 1,
            },
            Message::FrameEnd(e) => match self.open.take() {
                Some(a) if a.start.frame_id == e.frame_id => {
                    if a.broken || a.pixels.len() != a.start.frame_bytes() {
                        self.stats.frames_dropped_gap += 1;
                    } else if CRC32.checksum(&a.pixels) != e.crc {
                        self.stats.frames_dropped_crc += 1;
                    } else if a.bad_flags || a.outside != e.outside {
                        self.stats.frames_dropped_flags += 1;
                    } else if !values_in_range(a.start.format, &a.pixels) {
                        self.stats.frames_dropped_value += 1;
                    } else {
                        self.stats.frames_delivered += 1;
                        deliver(Frame {
                            start: a.start,
                            pixels: a.pixels,
                            end: e,
                            flags: a.flags,
                        });
                    }
                }
                other => {
                    // An end for another frame: the open one cannot finish.
                    if other.is_some() {
                        self.stats.frames_dropped_gap += 1;
                    }
                    self.stats.orphans += 1;
                }
            },
            Message::Flags(f) => match &mut self.open {
                Some(a) if a.start.frame_id == f.frame_id => {
                    let w = a.start.width as usize;
                    let line = f.line as usize;
                    let fits = line < a.start.height as usize && f.bits.len() == w.div_ceil(8);
                    // Bits past the width must be 0.
                    let tail = f
                        .bits
                        .last()
                        .is_some_and(|b| !w.is_multiple_of(8) && b >> (w % 8) != 0);
                    // A line's flags twice: the frame is dropped.
                    let again = a.flagged.get(line).is_none_or(|seen| *seen);
                    if !fits || tail || again {
                        a.bad_flags = true;
                        return;
                    }
                    a.flagged[line] = true;
                    if a.flags.is_empty() {
                        a.flags = vec![0; a.start.width as usize * a.start.height as usize];
                    }
                    for i in 0..w {
                        if f.bits[i / 8] >> (i % 8) & 1 == 1 {
                            a.flags[line * w + i] = hilcam::render::FLAG_OUTSIDE_FIELD;
                            a.outside += 1;
                        }
                    }
                }
                _ => self.stats.orphans += 1,
            },
            Message::Ack(_) | Message::Reject(_) | Message::Description(_) => {}
        }
    }
}

impl Stats {
    /// Frames begun and not delivered, whatever the reason: refused at
    /// their start, dropped, or cut off by the end of the input.
    pub fn frames_lost(&self) -> u64 {
        self.frames_refused
            + self.frames_dropped_gap
            + self.frames_dropped_unfinished
            + self.frames_dropped_crc
            + self.frames_dropped_flags
            + self.frames_dropped_value
            + self.frames_cut
    }
}

impl Decoder {
    /// The input has ended: a frame still open is counted as cut
    /// ([`Stats::frames_cut`]) and dropped. Returns whether one was.
    pub fn finish(&mut self) -> bool {
        let cut = self.open.take().is_some();
        self.stats.frames_cut += u64::from(cut);
        cut
    }
}

/// Why [`read_capture`] stopped before the end of its input.
#[derive(Debug)]
pub enum CaptureError<E> {
    /// Reading failed.
    Read(std::io::Error),
    /// The frame handler refused a frame (e.g. its file could not be
    /// written).
    Frame(E),
}

/// Reads a captured stream (a file, a pipe) to its end, as it comes: each
/// frame goes to `frame` as it completes, each answer to `reply` (in
/// order), then [`Decoder::finish`] counts a frame left open as cut. Memory
/// is the decoder's one frame and a 64 KiB buffer, whatever the input's
/// length. Stops at the first error `frame` returns.
pub fn read_capture<R: Read, E>(
    mut r: R,
    dec: &mut Decoder,
    frame: &mut impl FnMut(Frame) -> Result<(), E>,
    reply: &mut impl FnMut(Reply),
) -> Result<(), CaptureError<E>> {
    let mut buf = vec![0u8; 1 << 16];
    let mut failed = None;
    loop {
        let n = match r.read(&mut buf) {
            Ok(0) => {
                dec.finish();
                return Ok(());
            }
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(CaptureError::Read(e)),
        };
        dec.push(buf.get(..n).unwrap_or_default(), &mut |f| {
            if failed.is_none() {
                failed = frame(f).err();
            }
        });
        for r in dec.replies.drain(..) {
            reply(r);
        }
        if let Some(e) = failed.take() {
            return Err(CaptureError::Frame(e));
        }
    }
}
