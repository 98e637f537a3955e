//! The capture reader `host-sim replay` uses (`read_capture`) on arbitrary
//! bytes, read in pieces of arbitrary size: it must not panic, must reach
//! the end of its input, and every frame it hands on must be whole and
//! within its format (the pixels its header says, a flag a pixel, CRC
//! matching, Gray16 values below 2^bits); its counts must match what it
//! handed on.
#![no_main]

use hilcam::link::WireFormat;
use host_sim::link::decoder::{read_capture, Decoder};
use libfuzzer_sys::fuzz_target;

/// A reader that gives at most `piece` bytes a read.
struct Pieces<'a> {
    data: &'a [u8],
    piece: usize,
}

impl std::io::Read for Pieces<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.piece.min(buf.len()).min(self.data.len());
        let (now, rest) = self.data.split_at(n);
        buf[..n].copy_from_slice(now);
        self.data = rest;
        Ok(n)
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((piece, data)) = data.split_first() else {
        return;
    };
    let mut dec = Decoder::new(1 << 16, 1 << 20);
    let (mut frames, mut replies) = (0u64, 0u64);
    let r = read_capture(
        Pieces {
            data,
            piece: *piece as usize + 1,
        },
        &mut dec,
        &mut |f| -> Result<(), ()> {
            let s = &f.start;
            assert_eq!(f.pixels.len(), s.frame_bytes());
            assert_eq!(f.flags.len(), s.width as usize * s.height as usize);
            assert_eq!(hilcam::link::CRC32.checksum(&f.pixels), f.end.crc);
            if let WireFormat::Gray16 { bits } = s.format {
                assert!((9..=16).contains(&bits));
                for v in f.pixels.chunks_exact(2) {
                    assert!(u32::from(u16::from_le_bytes([v[0], v[1]])) < 1 << bits);
                }
            }
            frames += 1;
            Ok(())
        },
        &mut |_| replies += 1,
    );
    assert!(r.is_ok());
    assert!(dec.open_frame().is_none());
    assert_eq!(frames, dec.stats.frames_delivered);
    assert_eq!(replies, dec.stats.replies);
});
