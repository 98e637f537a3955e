//! Simulated links and seeded fault injection.
//!
//! - **UART**: 8N1, 10 bits on the line per byte: `bytes · 10 / baud` s.
//! - **USB full-speed CDC**: 12 Mbit/s raw; bulk data in 64-byte packets,
//!   at most 19 packets per 1 ms USB frame (the full-speed bulk limit of the
//!   USB 2.0 specification, table 5-9), i.e. at most 1.216 MB/s.
//!
//! Faults act on the byte stream: bit flips at a bit-error rate, dropped,
//! duplicated and inserted bytes, truncated messages (a message's tail lost
//! before its delimiter) and link cuts (a run of up to two frames lost).
//! Every fault records the offset in the original stream it touched, so that
//! each frame can be classified as hit or untouched.

use hilcam::link::{Encoder, FrameStart, WireFormat};
use rand_chacha::rand_core::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// A link model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Link {
    /// A UART at `baud`, 8N1.
    Uart {
        /// Baud rate.
        baud: u32,
    },
    /// USB full-speed CDC (bulk).
    UsbFs,
}

impl Link {
    /// `uart:BAUD` or `usb-fs`.
    pub fn parse(s: &str) -> Result<Link, String> {
        if s == "usb-fs" {
            return Ok(Link::UsbFs);
        }
        match s.strip_prefix("uart:").map(str::parse::<u32>) {
            Some(Ok(b)) if b > 0 => Ok(Link::Uart { baud: b }),
            _ => Err(format!(
                "--link: expected uart:BAUD (BAUD > 0) or usb-fs, got {s:?}"
            )),
        }
    }

    /// Seconds `bytes` take on the link.
    pub fn seconds(&self, bytes: u64) -> f64 {
        match *self {
            Link::Uart { baud } => bytes as f64 * 10.0 / baud as f64,
            Link::UsbFs => (bytes.div_ceil(64)) as f64 / 19.0 * 1e-3,
        }
    }

    /// A name for reports.
    pub fn name(&self) -> String {
        match self {
            Link::Uart { baud } => format!("uart:{baud}"),
            Link::UsbFs => "usb-fs".into(),
        }
    }
}

/// Fault settings (rates per bit, per byte or per message).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Faults {
    /// Bit-error rate.
    pub ber: f64,
    /// Probability a byte is dropped.
    pub drop: f64,
    /// Probability a byte is duplicated.
    pub dup: f64,
    /// Probability a burst of 1–16 random bytes is inserted before a byte.
    pub insert: f64,
    /// Probability a message loses its tail (1 byte up to all but its first
    /// byte) before its delimiter.
    pub truncate: f64,
    /// Probability a message is where the link is cut: from a random byte in
    /// it, up to 40 000 bytes (about two 160×120 frames) are lost.
    pub cut: f64,
    /// RNG seed.
    pub seed: u64,
}

impl Faults {
    /// `ber=1e-5,drop=1e-6,dup=..,insert=..,truncate=..,cut=..,seed=7`
    /// (any subset; `none` for no faults).
    pub fn parse(s: &str) -> Result<Faults, String> {
        let mut f = Faults::default();
        if s == "none" || s.is_empty() {
            return Ok(f);
        }
        for part in s.split(',') {
            let (k, v) = part
                .split_once('=')
                .ok_or_else(|| format!("--faults: expected key=value, got {part:?}"))?;
            if k == "seed" {
                f.seed = v
                    .parse()
                    .map_err(|_| format!("--faults: seed: not an integer: {v:?}"))?;
                continue;
            }
            let x: f64 = v
                .parse()
                .map_err(|_| format!("--faults: {k}: not a number: {v:?}"))?;
            if !(0.0..=1.0).contains(&x) {
                return Err(format!("--faults: {k}: must lie in [0, 1], got {v}"));
            }
            match k {
                "ber" => f.ber = x,
                "drop" => f.drop = x,
                "dup" => f.dup = x,
                "insert" => f.insert = x,
                "truncate" => f.truncate = x,
                "cut" => f.cut = x,
                _ => {
                    return Err(format!(
                        "--faults: unknown key {k:?} (ber, drop, dup, insert, truncate, cut, seed)"
                    ))
                }
            }
        }
        Ok(f)
    }
}

struct Rng(ChaCha8Rng);

impl Rng {
    fn unit(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: u64) -> u64 {
        if n == 0 {
            0
        } else {
            self.0.next_u64() % n
        }
    }
    /// Trials until the next success at probability `p` (≥ 1), or `u64::MAX`.
    fn gap(&mut self, p: f64) -> u64 {
        if p <= 0.0 {
            return u64::MAX;
        }
        if p >= 1.0 {
            return 1;
        }
        let u = self.unit();
        let g = ((1.0 - u).ln() / (1.0 - p).ln()).floor();
        if g.is_finite() && g < 1e18 {
            g as u64 + 1
        } else {
            u64::MAX
        }
    }
}

/// What came out of the faulty link.
pub struct Delivered {
    /// The bytes the receiver sees.
    pub stream: Vec<u8>,
    /// Offsets in the original stream that a fault touched (sorted).
    pub hits: Vec<usize>,
}

/// Sends a whole `stream` (whose messages occupy `messages`, byte ranges in
/// order) through the faults: one [`Channel::send`].
pub fn inject(stream: &[u8], messages: &[(usize, usize)], f: &Faults) -> Delivered {
    let mut out = Vec::with_capacity(stream.len() + stream.len() / 64);
    let mut hits = Vec::new();
    Channel::new(f).send(stream, messages, &mut out, &mut hits);
    Delivered { stream: out, hits }
}

/// The faulty link as a channel that a stream goes through a piece at a
/// time (a frame, say), so that memory does not grow with the stream: the
/// fault processes (bit flips, drops, duplicates, inserts, and a cut that
/// runs on into later pieces) continue from piece to piece.
pub struct Channel {
    f: Faults,
    rng: Rng,
    next_drop: u64,
    next_dup: u64,
    next_ins: u64,
    /// Next bit flip, in bits from the stream start.
    next_flip: u64,
    bit: u64,
    /// Offset of the next piece in the stream.
    offset: usize,
    /// A cut loses every byte before this offset.
    cut_until: usize,
}

impl Channel {
    /// A channel with the fault settings `f`.
    pub fn new(f: &Faults) -> Channel {
        let mut rng = Rng(ChaCha8Rng::seed_from_u64(f.seed));
        let (next_drop, next_dup, next_ins) = (rng.gap(f.drop), rng.gap(f.dup), rng.gap(f.insert));
        let next_flip = rng.gap(f.ber);
        Channel {
            f: *f,
            rng,
            next_drop,
            next_dup,
            next_ins,
            next_flip,
            bit: 0,
            offset: 0,
            cut_until: 0,
        }
    }

    /// Sends the next piece of the stream, whose messages occupy `messages`
    /// (ranges within `piece`): appends what the receiver sees to `out`, and
    /// the stream offsets a fault touched to `hits` (sorted).
    pub fn send(
        &mut self,
        piece: &[u8],
        messages: &[(usize, usize)],
        out: &mut Vec<u8>,
        hits: &mut Vec<usize>,
    ) {
        let (f, base) = (self.f, self.offset);
        let first_hit = hits.len();
        let rng = &mut self.rng;
        let mut lost = vec![false; piece.len()];
        // A cut from an earlier piece runs on.
        let carried = self.cut_until.saturating_sub(base).min(piece.len());
        for (i, l) in lost.iter_mut().enumerate().take(carried) {
            *l = true;
            hits.push(base + i);
        }
        // Message-level faults first: truncations and cuts mark bytes lost.
        for &(a, b) in messages {
            let len = b - a;
            if len >= 2 && rng.unit() < f.truncate {
                // Lose 1 .. len-2 bytes before the delimiter at b-1.
                let k = 1 + rng.below((len - 2) as u64) as usize;
                for (i, l) in lost.iter_mut().enumerate().take(b - 1).skip(b - 1 - k) {
                    *l = true;
                    hits.push(base + i);
                }
            }
            if len >= 1 && rng.unit() < f.cut {
                let from = a + rng.below(len as u64) as usize;
                let n = 1 + rng.below(40_000) as usize;
                self.cut_until = self.cut_until.max(base + from + n);
                for (i, l) in lost.iter_mut().enumerate().take(from + n).skip(from) {
                    *l = true;
                    hits.push(base + i);
                }
            }
        }
        for (i, &byte) in piece.iter().enumerate() {
            self.next_ins = self.next_ins.saturating_sub(1);
            if self.next_ins == 0 {
                let n = 1 + rng.below(16);
                for _ in 0..n {
                    out.push(rng.0.next_u32() as u8);
                }
                hits.push(base + i);
                self.next_ins = rng.gap(f.insert);
            }
            let mut b = byte;
            // Bit flips in this byte's 8 bits.
            while self.next_flip <= self.bit + 8 && self.next_flip != u64::MAX {
                let k = (self.next_flip - self.bit - 1) as u32;
                b ^= 1 << k;
                hits.push(base + i);
                self.next_flip = self.next_flip.saturating_add(rng.gap(f.ber));
            }
            self.bit += 8;
            self.next_drop = self.next_drop.saturating_sub(1);
            let dropped = self.next_drop == 0;
            if dropped {
                self.next_drop = rng.gap(f.drop);
            }
            self.next_dup = self.next_dup.saturating_sub(1);
            let dup = self.next_dup == 0;
            if dup {
                self.next_dup = rng.gap(f.dup);
            }
            if lost[i] {
                continue;
            }
            if dropped {
                hits.push(base + i);
                continue;
            }
            out.push(b);
            if dup {
                out.push(b);
                hits.push(base + i);
            }
        }
        // Earlier pieces' hits all lie before `base`: sorting this piece's
        // keeps the whole list sorted.
        hits[first_hit..].sort_unstable();
        hits.dedup();
        self.offset += piece.len();
    }
}

/// A `std::io::Write` behind a faulty link: each write is one message
/// through a [`Channel`] (what survives is written on at once).
pub struct FaultyWriter<W> {
    /// The writer behind the faults.
    pub inner: W,
    channel: Channel,
    /// Bytes any fault touched so far.
    pub hits: usize,
}

impl<W> FaultyWriter<W> {
    /// `inner` behind the faults `f`.
    pub fn new(inner: W, f: &Faults) -> Self {
        FaultyWriter {
            inner,
            channel: Channel::new(f),
            hits: 0,
        }
    }
}

impl<W: std::io::Write> std::io::Write for FaultyWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let (mut out, mut hits) = (Vec::with_capacity(buf.len() + 16), Vec::new());
        self.channel.send(buf, &[(0, buf.len())], &mut out, &mut hits);
        self.hits += hits.len();
        self.inner.write_all(&out)?;
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// A `Vec<u8>` as an `embedded_io::Write` that remembers where each
/// message (or lone delimiter) begins and ends: each range ends with its
/// `0x00` delimiter, however the encoder split its writes (it writes a
/// message a COBS block at a time).
#[derive(Default)]
pub struct Recorder {
    /// Everything written.
    pub bytes: Vec<u8>,
    /// Byte range of each message, delimiter included.
    pub writes: Vec<(usize, usize)>,
    /// Where the message being written began.
    open: usize,
}

impl Recorder {
    /// Forgets everything written.
    pub fn clear(&mut self) {
        self.bytes.clear();
        self.writes.clear();
        self.open = 0;
    }
}

impl embedded_io::ErrorType for Recorder {
    type Error = core::convert::Infallible;
}

impl embedded_io::Write for Recorder {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        for &b in buf {
            self.bytes.push(b);
            if b == 0 {
                self.writes.push((self.open, self.bytes.len()));
                self.open = self.bytes.len();
            }
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// The chunk buffer of the host-side sender: the firmware's, so that the
/// efficiency measured here is the device's.
pub const HOST_CHUNK: usize = hilcam::link::DEFAULT_CHUNK;

/// Frames encoded into one stream.
pub struct Sent {
    /// The stream.
    pub stream: Vec<u8>,
    /// Each message's (or lone delimiter's) byte range.
    pub messages: Vec<(usize, usize)>,
    /// Each frame's id, byte range in the stream, and pixels.
    pub frames: Vec<(u32, (usize, usize), Vec<u8>)>,
    /// Pixel bytes sent.
    pub pixel_bytes: u64,
}

/// Keeps every value of `pixels` within `format`: a Gray16 value below
/// `2^bits`, as a camera sends them (a receiver drops a frame with one
/// beyond).
pub fn within_format(format: WireFormat, pixels: &mut [u8]) {
    if let WireFormat::Gray16 { bits } = format {
        let mask = u16::MAX >> (16 - bits.clamp(1, 16));
        for p in pixels.chunks_exact_mut(2) {
            let v = u16::from_le_bytes([p[0], p[1]]) & mask;
            p.copy_from_slice(&v.to_le_bytes());
        }
    }
}

/// Frame `k` of a test stream: `base` (lines of `line` bytes) with a
/// per-frame pattern added to every byte, so that no two frames are alike,
/// its values kept within `format` ([`within_format`]).
pub fn frame_pixels(base: &[u8], line: usize, k: u32, format: WireFormat) -> Vec<u8> {
    let mut px: Vec<u8> = base
        .iter()
        .enumerate()
        .map(|(i, b)| b.wrapping_add((k.wrapping_mul(37) as usize).wrapping_add(i / line.max(1) * 13) as u8))
        .collect();
    within_format(format, &mut px);
    px
}

/// Encodes `n` frames in memory: frame `k` is `base` with a per-frame pattern added to
/// every byte (so that no two frames are alike; [`within_format`]), all
/// with `start`'s header.
pub fn send_frames(base: &[u8], start: FrameStart, n: u32, cost: Option<u64>) -> Result<Sent, String> {
    let mut enc =
        Encoder::<Recorder, HOST_CHUNK>::new(Recorder::default()).map_err(|e| format!("encoder: {e:?}"))?;
    let line = start.line_bytes();
    let mut frames = Vec::with_capacity(n as usize);
    for k in 0..n {
        let pixels = frame_pixels(base, line, k, start.format);
        let begin = enc.writer().bytes.len();
        enc.begin_frame(FrameStart { frame_id: k, ..start })
            .map_err(|e| format!("encoder: {e:?}"))?;
        for l in pixels.chunks_exact(line) {
            enc.push_line(l).map_err(|e| format!("encoder: {e:?}"))?;
        }
        enc.end_frame(cost).map_err(|e| format!("encoder: {e:?}"))?;
        let end = enc.writer().bytes.len();
        frames.push((k, (begin, end), pixels));
    }
    let pixel_bytes = enc.pixel_bytes;
    let rec = enc.into_inner();
    Ok(Sent {
        stream: rec.bytes,
        messages: rec.writes,
        frames,
        pixel_bytes,
    })
}
