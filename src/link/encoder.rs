//! The camera's side of sending: a message COBS-encoded as it is
//! serialized ([`write_encoded`]), and the frame [`Encoder`] fed line by
//! line through a [`Stream`] (a frame sink).

use crate::link::control::Answer;
use crate::link::wire::{
    crc_update, Ack, Chunk, Description, FlagsOut, FrameEnd, FrameStart, Reject, WireFormat, CRC32,
};
use crate::render::{FrameInfo, FrameSink};
use postcard::ser_flavors::crc::CrcModifier;
use postcard::ser_flavors::{Cobs, Slice};
use serde::Serialize;

/// What went wrong while encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkError<E> {
    /// The writer failed.
    Write(E),
    /// The chunk buffer holds nothing (`CHUNK` is 0).
    BufferTooSmall,
    /// A line does not fit the chunk buffer.
    LineTooLong,
    /// A line of the wrong length, a line past the frame's height, or a
    /// frame ended before all its lines.
    Sequence,
    /// Serialization failed (cannot happen with a correctly sized buffer).
    Encode,
}

/// Encodes one message (a [`Message`](crate::link::wire::Message), or a [`crate::link::Request`])
/// into `wire` (COBS, CRC appended, delimiter included) and returns the
/// encoded bytes.
pub fn encode_message<'w, T: Serialize + ?Sized>(msg: &T, wire: &'w mut [u8]) -> Option<&'w mut [u8]> {
    let cobs = Cobs::try_new(Slice::new(wire)).ok()?;
    postcard::serialize_with_flavor(msg, CrcModifier::new(cobs, CRC32.digest())).ok()
}

/// What the encoder keeps of an open frame.
#[derive(Clone, Copy)]
struct Open {
    frame_id: u32,
    width: u16,
    height: u16,
    line_bytes: usize,
    /// Pixels flagged outside the field so far.
    outside: u32,
}

/// One kind of [`Message`], encoded on its own: `Tagged(tag, value)` has
/// the bytes of the `Message` variant `tag` holding `value` (postcard writes
/// a variant index below 128 as that one byte, then the fields). A sender
/// then holds the serializers of what it sends, not of every kind.
#[derive(Serialize)]
struct Tagged<'a, T: Serialize>(u8, &'a T);

/// The messages of a frame (tags 0 to 2 of [`Message`], the same bytes):
/// what the encoder sends through one serializer.
#[derive(Serialize)]
enum FrameMessage<'a> {
    FrameStart(&'a FrameStart),
    Chunk(&'a Chunk<'a>),
    FrameEnd(&'a FrameEnd),
}

/// A message a camera sends outside frames: [`Ack`], [`Reject`],
/// [`Description`].
pub trait Reply: Serialize {
    /// Its [`Message`](crate::link::wire::Message) tag.
    const TAG: u8;
}

impl Reply for Ack {
    const TAG: u8 = 3;
}

impl Reply for Reject<'_> {
    const TAG: u8 = 4;
}

impl Reply for Description {
    const TAG: u8 = 5;
}

/// Writes `msg` encoded as [`encode_message`] encodes it (the same bytes),
/// COBS-encoding it while it is serialized and writing each COBS block as
/// it completes: no buffer for the whole message. Returns the bytes
/// written. A write error may leave a partial message on the link (its
/// receiver drops it: no delimiter, or a bad CRC).
#[inline(never)]
pub fn write_encoded<W: embedded_io::Write, T: Serialize + ?Sized>(
    writer: &mut W,
    msg: &T,
) -> Result<u64, LinkError<W::Error>> {
    let mut failed = None;
    let stream = CobsStream {
        writer,
        failed: &mut failed,
        block: [0; 255],
        fill: 1,
        written: 0,
        crc: CRC32.digest(),
    };
    let r = postcard::serialize_with_flavor(msg, stream);
    match (r, failed) {
        (_, Some(e)) => Err(LinkError::Write(e)),
        (Ok(n), None) => Ok(n),
        (Err(_), None) => Err(LinkError::Encode),
    }
}

/// A postcard flavor that appends the CRC-32 of its bytes (as postcard's
/// `CrcModifier`), COBS-encodes them into blocks and writes each block to
/// `writer` when it is complete: a block is its code byte (`fill`: one more
/// than its non-zero bytes) and up to 254 non-zero bytes, ended by a zero
/// (implied) or by being full (code 255). Byte slices (a frame's pixels)
/// go through at once: the CRC over the slice, the runs between zeros
/// copied.
struct CobsStream<'w, W: embedded_io::Write> {
    writer: &'w mut W,
    /// The first write error (the serializer only sees that it failed).
    failed: &'w mut Option<W::Error>,
    block: [u8; 255],
    /// Bytes of `block` in use, its code byte included (1 to 255).
    fill: usize,
    written: u64,
    crc: crc::Digest<'static, u32>,
}

impl<W: embedded_io::Write> CobsStream<'_, W> {
    /// COBS-encodes one byte.
    #[inline(always)]
    fn cobs(&mut self, data: u8) -> postcard::Result<()> {
        if data == 0 {
            return self.emit();
        }
        if let Some(slot) = self.block.get_mut(self.fill) {
            *slot = data;
        }
        self.fill += 1;
        if self.fill == self.block.len() {
            self.emit()?;
        }
        Ok(())
    }

    /// Writes the block so far and starts the next one. Inline: at
    /// opt-level "s" (the firmware's) a call a block cost a dark Gray16
    /// frame, a block every few bytes, 9 M3 instructions a pixel of the
    /// whole run (a QEMU profile; the frame cost, which measures the
    /// renderer, does not count the link). A call with the `compact`
    /// feature (the driven camera's, bound by flash).
    #[cfg_attr(not(feature = "compact"), inline(always))]
    fn emit(&mut self) -> postcard::Result<()> {
        let n = self.fill;
        if let Some(code) = self.block.first_mut() {
            *code = n as u8;
        }
        let block = self.block.get(..n).unwrap_or_default();
        if let Err(e) = self.writer.write_all(block) {
            *self.failed = Some(e);
            return Err(postcard::Error::SerializeBufferFull);
        }
        self.written += n as u64;
        self.fill = 1;
        Ok(())
    }
}

impl<W: embedded_io::Write> postcard::ser_flavors::Flavor for CobsStream<'_, W> {
    type Output = u64;

    fn try_push(&mut self, data: u8) -> postcard::Result<()> {
        self.crc.update(&[data]);
        self.cobs(data)
    }

    fn try_extend(&mut self, data: &[u8]) -> postcard::Result<()> {
        crc_update(&mut self.crc, data);
        let mut rest = data;
        while !rest.is_empty() {
            // The non-zero bytes that fit the block, copied in one pass.
            let mut run = 0;
            for (d, s) in self.block.iter_mut().skip(self.fill).zip(rest) {
                if *s == 0 {
                    break;
                }
                *d = *s;
                run += 1;
            }
            self.fill += run;
            rest = rest.get(run..).unwrap_or_default();
            if self.fill == self.block.len() {
                self.emit()?;
            } else if let Some((_, tail)) = rest.split_first() {
                // A zero ends the block.
                self.emit()?;
                rest = tail;
            }
        }
        Ok(())
    }

    fn finalize(mut self) -> postcard::Result<u64> {
        let crc = self.crc.clone().finalize();
        for b in crc.to_le_bytes() {
            self.cobs(b)?;
        }
        self.emit()?;
        if let Err(e) = self.writer.write_all(&[0]) {
            *self.failed = Some(e);
            return Err(postcard::Error::SerializeBufferFull);
        }
        Ok(self.written + 1)
    }
}

/// The frame encoder: writes frames to `W`, fed line by line, holding one
/// chunk (`CHUNK` bytes of pixels); messages are encoded as they are
/// written ([`write_encoded`]).
pub struct Encoder<W: embedded_io::Write, const CHUNK: usize> {
    writer: W,
    chunk: [u8; CHUNK],
    fill: usize,
    /// The open frame: its id, height and line bytes (all the encoder
    /// needs of its header, which it does not keep).
    frame: Option<Open>,
    crc: crc::Digest<'static, u32>,
    line: u16,
    chunk_first_line: u16,
    offset: u32,
    /// Bytes written to the link so far.
    pub bytes_written: u64,
    /// Pixel bytes sent so far.
    pub pixel_bytes: u64,
}

impl<W: embedded_io::Write, const CHUNK: usize> Encoder<W, CHUNK> {
    /// An encoder over `writer` (`CHUNK` at least 1).
    pub fn new(writer: W) -> Result<Self, LinkError<W::Error>> {
        if CHUNK == 0 {
            return Err(LinkError::BufferTooSmall);
        }
        Ok(Encoder {
            writer,
            chunk: [0; CHUNK],
            fill: 0,
            frame: None,
            crc: CRC32.digest(),
            line: 0,
            chunk_first_line: 0,
            offset: 0,
            bytes_written: 0,
            pixel_bytes: 0,
        })
    }

    /// The writer.
    pub fn writer(&mut self) -> &mut W {
        &mut self.writer
    }

    /// Gives the writer back.
    pub fn into_inner(self) -> W {
        self.writer
    }

    fn send(&mut self, msg: &FrameMessage<'_>) -> Result<(), LinkError<W::Error>> {
        self.bytes_written += write_encoded(&mut self.writer, msg)?;
        Ok(())
    }

    /// Sends an answer to a command between frames.
    pub fn send_reply<T: Reply>(&mut self, msg: &T) -> Result<(), LinkError<W::Error>> {
        if self.frame.is_some() {
            return Err(LinkError::Sequence);
        }
        self.bytes_written += write_encoded(&mut self.writer, &Tagged(T::TAG, msg))?;
        self.writer.flush().map_err(LinkError::Write)
    }

    /// Sends the message `answer` calls for, for the request numbered
    /// `seq`: an [`Ack`] stamped `timestamp_ns`, a [`Reject`], or the
    /// camera's [`Description`] (made only when asked for).
    pub fn send_answer(
        &mut self,
        seq: u32,
        answer: Answer,
        timestamp_ns: u64,
        describe: impl FnOnce() -> Description,
    ) -> Result<(), LinkError<W::Error>> {
        match answer {
            Answer::Ack => self.send_reply(&Ack { seq, timestamp_ns }),
            Answer::Reject(reason, fault) => self.send_reply(&Reject {
                seq,
                reason,
                field: &fault.name(),
            }),
            Answer::Describe => self.send_reply(&describe()),
        }
    }

    /// Opens a frame: a delimiter, then the [`FrameStart`] message. A frame
    /// still open is abandoned (the receiver drops it).
    pub fn begin_frame(&mut self, start: FrameStart) -> Result<(), LinkError<W::Error>> {
        if start.line_bytes() > CHUNK {
            return Err(LinkError::LineTooLong);
        }
        self.writer.write_all(&[0]).map_err(LinkError::Write)?;
        self.bytes_written += 1;
        self.send(&FrameMessage::FrameStart(&start))?;
        self.frame = Some(Open {
            frame_id: start.frame_id,
            width: start.width,
            height: start.height,
            line_bytes: start.line_bytes(),
            outside: 0,
        });
        self.crc = CRC32.digest();
        self.fill = 0;
        self.line = 0;
        self.chunk_first_line = 0;
        self.offset = 0;
        Ok(())
    }

    fn flush_chunk(&mut self) -> Result<(), LinkError<W::Error>> {
        let Some(f) = self.frame else {
            return Err(LinkError::Sequence);
        };
        if self.fill == 0 {
            return Ok(());
        }
        let data = self.chunk.get(..self.fill).ok_or(LinkError::Encode)?;
        let msg = Chunk {
            frame_id: f.frame_id,
            first_line: self.chunk_first_line,
            offset: self.offset,
            data,
        };
        // `send` would borrow all of `self` while `msg` borrows the chunk.
        self.bytes_written += write_encoded(&mut self.writer, &FrameMessage::Chunk(&msg))?;
        self.pixel_bytes += self.fill as u64;
        self.offset += self.fill as u32;
        self.fill = 0;
        self.chunk_first_line = self.line;
        Ok(())
    }

    /// Adds the next line of the open frame; sends a chunk when the next line
    /// would not fit.
    pub fn push_line(&mut self, line: &[u8]) -> Result<(), LinkError<W::Error>> {
        if self.frame.is_some_and(|f| line.len() != f.line_bytes) {
            return Err(LinkError::Sequence);
        }
        let dst = self.next_line()?;
        // (A zip, not `copy_from_slice`, whose length check the M0 camera's
        // opt-level z build keeps out of line: a panic path. A memcpy on the
        // M3; a byte loop there, its round trip 0.14 % longer.)
        dst.iter_mut().zip(line).for_each(|(d, s)| *d = *s);
        self.commit_line()
    }

    /// Where the next line of the open frame goes in the chunk (the chunk
    /// sent first if the line would not fit): a renderer writes the line
    /// there, then [`Encoder::commit_line`] adds it — no copy of it.
    pub fn next_line(&mut self) -> Result<&mut [u8], LinkError<W::Error>> {
        let f = self.open_line()?;
        if self.fill + f.line_bytes > CHUNK {
            self.flush_chunk()?;
        }
        self.chunk
            .get_mut(self.fill..self.fill + f.line_bytes)
            .ok_or(LinkError::LineTooLong)
    }

    /// The open frame, if it has a line still to come.
    fn open_line(&self) -> Result<Open, LinkError<W::Error>> {
        match self.frame {
            Some(f) if self.line < f.height => Ok(f),
            _ => Err(LinkError::Sequence),
        }
    }

    /// Adds the line written where [`Encoder::next_line`] said.
    pub fn commit_line(&mut self) -> Result<(), LinkError<W::Error>> {
        let f = self.open_line()?;
        let line = self
            .chunk
            .get(self.fill..self.fill + f.line_bytes)
            .ok_or(LinkError::Sequence)?;
        crc_update(&mut self.crc, line);
        self.fill += line.len();
        self.line += 1;
        Ok(())
    }

    /// The flags of the line just added (a byte a pixel, at least the
    /// width): if any pixel is outside the lens field, sends its
    /// [`LineFlags`](crate::link::wire::LineFlags) (the frame's [`FrameEnd`] counts them).
    pub fn push_flags(&mut self, flags: &[u8]) -> Result<(), LinkError<W::Error>> {
        let Some(f) = self.frame.as_mut() else {
            return Err(LinkError::Sequence);
        };
        let (Some(line), Some(flags)) = (self.line.checked_sub(1), flags.get(..usize::from(f.width))) else {
            return Err(LinkError::Sequence);
        };
        let n = flags
            .iter()
            .filter(|b| **b & crate::render::FLAG_OUTSIDE_FIELD != 0)
            .count() as u32;
        if n == 0 {
            return Ok(());
        }
        f.outside += n;
        let msg = FlagsOut {
            frame_id: f.frame_id,
            line,
            flags,
        };
        self.bytes_written += write_encoded(&mut self.writer, &Tagged(6, &msg))?;
        Ok(())
    }

    /// Sends the last chunk and the [`FrameEnd`]; returns the frame's CRC-32.
    pub fn end_frame(&mut self, cost: Option<u64>) -> Result<u32, LinkError<W::Error>> {
        let Some(f) = self.frame else {
            return Err(LinkError::Sequence);
        };
        if self.line != f.height {
            return Err(LinkError::Sequence);
        }
        self.flush_chunk()?;
        let crc = core::mem::replace(&mut self.crc, CRC32.digest()).finalize();
        self.send(&FrameMessage::FrameEnd(&FrameEnd {
            frame_id: f.frame_id,
            crc,
            outside: f.outside,
            cost,
        }))?;
        self.frame = None;
        self.writer.flush().map_err(LinkError::Write)?;
        Ok(crc)
    }
}

/// One frame sent through an [`Encoder`], as a [`FrameSink`] the renderer
/// feeds directly (`Frame::render(.., &mut Stream { enc, start })`): `begin`
/// sends `start` (whose size and format must be the frame's), each line a
/// chunk's worth at a time, `end` the [`FrameEnd`] with the cost.
pub struct Stream<'a, W: embedded_io::Write, const CHUNK: usize> {
    /// The encoder.
    pub enc: &'a mut Encoder<W, CHUNK>,
    /// The frame's header.
    pub start: FrameStart,
}

impl<W: embedded_io::Write, const CHUNK: usize> FrameSink for Stream<'_, W, CHUNK> {
    type Error = LinkError<W::Error>;
    fn begin(&mut self, info: &FrameInfo) -> Result<(), Self::Error> {
        let s = self.start;
        if (s.width, s.height, s.format) != (info.width, info.height, WireFormat::from(info.format)) {
            return Err(LinkError::Sequence);
        }
        self.enc.begin_frame(s)
    }
    fn line(&mut self, _y: u16, pixels: &[u8], flags: &[u8]) -> Result<(), Self::Error> {
        self.enc.push_line(pixels)?;
        self.enc.push_flags(flags)
    }
    /// In the encoder's chunk ([`Encoder::next_line`]): the firmware holds
    /// no line buffer of its own.
    fn place(&mut self, _y: u16, len: usize) -> Result<Option<&mut [u8]>, Self::Error> {
        let line = self.enc.next_line()?;
        if line.len() != len {
            return Err(LinkError::Sequence);
        }
        Ok(Some(line))
    }
    fn placed(&mut self, _y: u16, flags: &[u8]) -> Result<(), Self::Error> {
        self.enc.commit_line()?;
        self.enc.push_flags(flags)
    }
    fn end(&mut self, cost: Option<u64>) -> Result<(), Self::Error> {
        self.enc.end_frame(cost).map(|_| ())
    }
}

/// A frame strobe and frame pacing through embedded-hal 1.0: the pin is high
/// while a frame is sent (VSYNC-like), and after each frame the sender waits
/// `gap_ns` (set it to the target period minus the frame's time on the link,
/// which `host-sim stream` reports).
#[cfg(feature = "hal")]
pub struct FrameSync<P, D> {
    /// The strobe pin.
    pub pin: P,
    /// The delay source.
    pub delay: D,
    /// Pause after each frame, ns.
    pub gap_ns: u32,
}

#[cfg(feature = "hal")]
impl<P: embedded_hal::digital::OutputPin, D: embedded_hal::delay::DelayNs> FrameSync<P, D> {
    /// Raises the strobe: a frame starts.
    pub fn frame_start(&mut self) -> Result<(), P::Error> {
        self.pin.set_high()
    }

    /// Lowers the strobe and waits the gap.
    pub fn frame_end(&mut self) -> Result<(), P::Error> {
        self.pin.set_low()?;
        self.delay.delay_ns(self.gap_ns);
        Ok(())
    }
}
