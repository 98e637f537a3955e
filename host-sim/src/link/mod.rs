//! The host side of the link: the streaming decoder, simulated UART and USB
//! links with fault injection, and a reader for real serial ports.

pub mod decoder;
#[cfg(feature = "cli")]
pub mod serial;
#[cfg(feature = "cli")]
pub mod sim;
