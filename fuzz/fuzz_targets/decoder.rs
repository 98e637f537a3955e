//! The wire decoder on arbitrary bytes, fed in arbitrary pieces: it must not
//! panic, and it must never deliver a frame whose CRC does not match its
//! pixels or whose size does not match its header.
#![no_main]

use host_sim::link::decoder::Decoder;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (split, bytes) = match data.split_first() {
        Some((s, rest)) => (*s as usize + 1, rest),
        None => return,
    };
    let mut dec = Decoder::new(1 << 16, 1 << 20);
    for piece in bytes.chunks(split) {
        dec.push(piece, &mut |f| {
            assert_eq!(f.pixels.len(), f.start.frame_bytes());
            assert_eq!(hilcam::link::CRC32.checksum(&f.pixels), f.end.crc);
        });
    }
});
