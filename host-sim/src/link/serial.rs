//! Real serial devices (and ptys): the same decoder over the `serialport`
//! crate.

use super::decoder::{Decoder, Frame};
use serde::Serialize;
use std::io::Read;
use std::time::{Duration, Instant};

/// How long to read for.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Frames wanted.
    pub frames: u64,
    /// Stop after this long without a byte.
    pub idle: Duration,
    /// Stop after this long in all, whatever arrives.
    pub deadline: Duration,
}

/// Why reading stopped.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Ending {
    /// Every frame asked for arrived.
    Complete,
    /// The input ended (the sender hung up).
    Hangup,
    /// No byte for the idle timeout.
    IdleTimeout,
    /// The overall deadline passed.
    Deadline,
    /// A signal asked to stop ([`crate::output::interrupted`]).
    Interrupted,
    /// The device failed.
    ReadError(String),
    /// Handling a frame failed (e.g. writing it).
    FrameError(String),
}

impl Ending {
    /// In words.
    pub fn describe(&self) -> String {
        match self {
            Ending::Complete => "complete".into(),
            Ending::Hangup => "the input ended".into(),
            Ending::IdleTimeout => "no byte within the idle timeout".into(),
            Ending::Deadline => "the deadline passed".into(),
            Ending::Interrupted => "interrupted".into(),
            Ending::ReadError(e) => format!("read error: {e}"),
            Ending::FrameError(e) => e.clone(),
        }
    }
}

/// Both ends of a serial device: a reader and a writer.
pub type Duplex = (Box<dyn Read + Send>, Box<dyn std::io::Write + Send>);

/// Opens the serial device at `path` (a real port or a pty) for both
/// directions: a reader (which times out when idle, every 100 ms) and a
/// [`Patient`] writer.
pub fn open(path: &str, baud: u32) -> Result<Duplex, String> {
    check_baud(baud)?;
    let port = serialport::new(path, baud)
        .timeout(Duration::from_millis(100))
        .open()
        .map_err(|e| format!("{path}: {e}"))?;
    let reader = port.try_clone().map_err(|e| format!("{path}: {e}"))?;
    Ok((Box::new(reader), Box::new(Patient(port))))
}

/// The baud rates a serial device is opened at: 50 to 20 000 000.
pub fn check_baud(baud: u32) -> Result<(), String> {
    if (50..=20_000_000).contains(&baud) {
        Ok(())
    } else {
        Err(format!("--baud: {baud} is outside 50 to 20000000"))
    }
}

/// A serial device's writer that waits out back-pressure: a write or drain
/// that times out (the reader paused, CTS held off) is tried again, for as
/// long as it takes; only another error (the other end hung up) ends it.
pub struct Patient<W>(pub W);

/// Whether `e` says only "not now" (the port's timeout, a full buffer).
fn not_now(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock | std::io::ErrorKind::Interrupted
    )
}

impl<W: std::io::Write> std::io::Write for Patient<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        loop {
            match self.0.write(buf) {
                Err(e) if not_now(&e) => std::thread::sleep(Duration::from_millis(1)),
                r => return r,
            }
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        loop {
            match self.0.flush() {
                Err(e) if not_now(&e) => std::thread::sleep(Duration::from_millis(1)),
                r => return r,
            }
        }
    }
}

/// Whether `e` is the other end hanging up (a pty's or a USB port's EIO, a
/// broken pipe, a reset connection), not a fault of this end.
pub fn is_hangup(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::BrokenPipe
            | std::io::ErrorKind::ConnectionReset
            | std::io::ErrorKind::ConnectionAborted
            | std::io::ErrorKind::NotConnected
            | std::io::ErrorKind::UnexpectedEof
    ) || e.raw_os_error() == Some(5)
}

/// Reads from the serial device at `path` until the limits say stop; hands
/// every intact frame to `on_frame` as it completes.
pub fn receive(
    path: &str,
    baud: u32,
    limits: Limits,
    dec: &mut Decoder,
    on_frame: &mut dyn FnMut(Frame) -> Result<(), String>,
) -> Result<(u64, Ending), String> {
    let mut port = serialport::new(path, baud)
        .timeout(Duration::from_millis(100))
        .open()
        .map_err(|e| format!("{path}: {e}"))?;
    Ok(read_frames(&mut port, limits, dec, on_frame))
}

/// Reads frames from any reader that times out (`TimedOut`/`WouldBlock`)
/// when idle, handing each to `on_frame` as it completes; returns how many
/// arrived and why reading stopped. A read error or hang-up ends the read
/// but loses nothing already handed over.
pub fn read_frames<R: Read + ?Sized>(
    r: &mut R,
    limits: Limits,
    dec: &mut Decoder,
    on_frame: &mut dyn FnMut(Frame) -> Result<(), String>,
) -> (u64, Ending) {
    let mut got = 0u64;
    let mut failed: Option<String> = None;
    let mut buf = [0u8; 4096];
    let start = Instant::now();
    let mut last = Instant::now();
    let ending = loop {
        if let Some(e) = failed.take() {
            break Ending::FrameError(e);
        }
        if got >= limits.frames {
            break Ending::Complete;
        }
        if crate::output::interrupted() {
            break Ending::Interrupted;
        }
        if start.elapsed() > limits.deadline {
            break Ending::Deadline;
        }
        match r.read(&mut buf) {
            Ok(0) => break Ending::Hangup,
            Ok(n) => {
                last = Instant::now();
                dec.push(&buf[..n], &mut |f| {
                    if failed.is_none() && got < limits.frames {
                        match on_frame(f) {
                            Ok(()) => got += 1,
                            Err(e) => failed = Some(e),
                        }
                    }
                });
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                if last.elapsed() > limits.idle {
                    break Ending::IdleTimeout;
                }
            }
            // A pty whose other side closed reads EIO: the sender hung up.
            Err(e) if e.raw_os_error() == Some(5) => break Ending::Hangup,
            Err(e) => break Ending::ReadError(e.to_string()),
        }
    };
    (got, ending)
}
