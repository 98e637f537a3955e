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

use hilcam::link::{Encoder, FrameStart};
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

/// Sends `stream` (whose messages occupy `messages`, byte ranges in order)
/// through the faults.
pub fn inject(stream: &[u8], messages: &[(usize, usize)], f: &Faults) -> Delivered {
    let mut rng = Rng(ChaCha8Rng::seed_from_u64(f.seed));
    let mut lost = vec![false; stream.len()];
    let mut hits = Vec::new();
    // Message-level faults first: truncations and cuts mark bytes lost.
    for &(a, b) in messages {
        let len = b - a;
        if len >= 2 && rng.unit() < f.truncate {
            // Lose 1 .. len-2 bytes before the delimiter at b-1.
            let k = 1 + rng.below((len - 2) as u64) as usize;
            for (i, l) in lost.iter_mut().enumerate().take(b - 1).skip(b - 1 - k) {
                *l = true;
                hits.push(i);
            }
        }
        if len >= 1 && rng.unit() < f.cut {
            let from = a + rng.below(len as u64) as usize;
            let n = 1 + rng.below(40_000) as usize;
            let to = (from + n).min(stream.len());
            for (i, l) in lost.iter_mut().enumerate().take(to).skip(from) {
                *l = true;
                hits.push(i);
            }
        }
    }
    let mut out = Vec::with_capacity(stream.len() + stream.len() / 64);
    let (mut next_drop, mut next_dup, mut next_ins) = (rng.gap(f.drop), rng.gap(f.dup), rng.gap(f.insert));
    let mut next_flip = rng.gap(f.ber); // in bits from the stream start
    let mut bit: u64 = 0;
    for (i, &byte) in stream.iter().enumerate() {
        next_ins = next_ins.saturating_sub(1);
        if next_ins == 0 {
            let n = 1 + rng.below(16);
            for _ in 0..n {
                out.push(rng.0.next_u32() as u8);
            }
            hits.push(i);
            next_ins = rng.gap(f.insert);
        }
        let mut b = byte;
        // Bit flips in this byte's 8 bits.
        while next_flip <= bit + 8 && next_flip != u64::MAX {
            let k = (next_flip - bit - 1) as u32;
            b ^= 1 << k;
            hits.push(i);
            next_flip = next_flip.saturating_add(rng.gap(f.ber));
        }
        bit += 8;
        next_drop = next_drop.saturating_sub(1);
        let dropped = next_drop == 0;
        if dropped {
            next_drop = rng.gap(f.drop);
        }
        next_dup = next_dup.saturating_sub(1);
        let dup = next_dup == 0;
        if dup {
            next_dup = rng.gap(f.dup);
        }
        if lost[i] {
            continue;
        }
        if dropped {
            hits.push(i);
            continue;
        }
        out.push(b);
        if dup {
            out.push(b);
            hits.push(i);
        }
    }
    hits.sort_unstable();
    hits.dedup();
    Delivered { stream: out, hits }
}

/// A `Vec<u8>` as an `embedded_io::Write` that remembers where each write
/// (each message) begins and ends.
#[derive(Default)]
pub struct Recorder {
    /// Everything written.
    pub bytes: Vec<u8>,
    /// Byte range of each write.
    pub writes: Vec<(usize, usize)>,
}

impl embedded_io::ErrorType for Recorder {
    type Error = core::convert::Infallible;
}

impl embedded_io::Write for Recorder {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        let a = self.bytes.len();
        self.bytes.extend_from_slice(buf);
        self.writes.push((a, self.bytes.len()));
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

/// Encodes `n` frames: frame `k` is `base` with a per-frame pattern added to
/// every byte (so that no two frames are alike), all with `start`'s header.
pub fn send_frames(base: &[u8], start: FrameStart, n: u32, cost: Option<u64>) -> Result<Sent, String> {
    let mut enc =
        Encoder::<Recorder, HOST_CHUNK, { hilcam::link::wire_size(HOST_CHUNK) }>::new(Recorder::default())
            .map_err(|e| format!("encoder: {e:?}"))?;
    let line = start.line_bytes();
    let mut frames = Vec::with_capacity(n as usize);
    for k in 0..n {
        let pixels: Vec<u8> = base
            .iter()
            .enumerate()
            .map(|(i, b)| b.wrapping_add((k.wrapping_mul(37) as usize).wrapping_add(i / line * 13) as u8))
            .collect();
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
