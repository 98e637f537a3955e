//! The link protocol: frames as postcard messages, each with a CRC-32 and
//! framed with COBS, written to any `embedded_io::Write` (`docs/wire.md` is
//! the byte-level specification).
//!
//! A frame is a [`FrameStart`], [`Chunk`]s of whole lines (as many as fit the
//! encoder's chunk buffer, so the overhead stays small), and a [`FrameEnd`]
//! with the CRC-32 of all the frame's pixel bytes. Each message is
//! `COBS(postcard(message) ‖ CRC-32(postcard(message)) LE) 0x00`; a frame
//! starts with an extra `0x00`, so that a lost delimiter at the end of one
//! frame never merges into the next.
//!
//! The [`Encoder`] is fed line by line (through a [`Stream`], a frame sink,
//! the renderer feeds it directly) and holds one chunk of pixels; a message
//! is COBS-encoded and written as it is serialized, a block (≤ 255 bytes) at
//! a time ([`write_encoded`]): RAM is `CHUNK` bytes and one block, whatever
//! the frame height. No heap.

pub mod control;
pub mod encoder;
pub mod wire;

#[cfg(feature = "hal")]
pub use encoder::FrameSync;
pub use encoder::{encode_message, write_encoded, Encoder, LinkError, Reply, Stream};
pub use wire::*;
