//! Real serial devices (and ptys): the same decoder over the `serialport`
//! crate.

use super::decoder::{Decoder, Frame};
use std::io::Read;
use std::time::{Duration, Instant};

/// Reads from the serial device at `path` until `frames` frames are
/// delivered, the input ends, or `timeout` passes without a byte.
pub fn receive(
    path: &str,
    baud: u32,
    frames: u64,
    timeout: Duration,
    dec: &mut Decoder,
) -> Result<Vec<Frame>, String> {
    let mut port = serialport::new(path, baud)
        .timeout(Duration::from_millis(100))
        .open()
        .map_err(|e| format!("{path}: {e}"))?;
    read_frames(&mut port, frames, timeout, dec)
}

/// Reads frames from any reader that times out (`TimedOut`/`WouldBlock`) when
/// idle.
pub fn read_frames<R: Read + ?Sized>(
    r: &mut R,
    frames: u64,
    timeout: Duration,
    dec: &mut Decoder,
) -> Result<Vec<Frame>, String> {
    let mut out = Vec::new();
    let mut buf = [0u8; 4096];
    let mut last = Instant::now();
    while (out.len() as u64) < frames {
        match r.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => {
                last = Instant::now();
                dec.push(&buf[..n], &mut |f| out.push(f));
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                if last.elapsed() > timeout {
                    break;
                }
            }
            Err(e) => return Err(format!("serial read: {e}")),
        }
    }
    Ok(out)
}
