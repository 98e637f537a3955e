//! The board: UART0 as an `embedded_io::Write` (and polled RX), and the
//! SysTick clock. Which board is data (`boards.toml`, `HILCAM_BOARD`): the
//! build script writes its UART's base and SysTick period (`board.rs` in
//! `OUT_DIR`) and names its UART's kind (`cfg(hilcam_uart)`).
//!
//! Register access is MMIO, so this is the one place with `unsafe`: volatile
//! reads and writes of fixed, documented device addresses.

use core::convert::Infallible;

/// A volatile read of a documented device register.
#[inline(always)]
fn read(addr: usize) -> u32 {
    // SAFETY: `addr` is one of the fixed register addresses below.
    unsafe { core::ptr::read_volatile(addr as *const u32) }
}

/// A volatile write of a documented device register.
#[inline(always)]
fn write(addr: usize, value: u32) {
    // SAFETY: `addr` is one of the fixed register addresses below.
    unsafe { core::ptr::write_volatile(addr as *mut u32, value) }
}

include!(concat!(env!("OUT_DIR"), "/board.rs"));

#[cfg(hilcam_uart = "pl011")]
mod regs {
    use super::{read, write, UART_BASE as BASE};
    /// Data register.
    const DATA: usize = BASE;
    /// Flag register; bit 5 = transmit FIFO full, bit 4 = receive FIFO
    /// empty.
    const STATUS: usize = BASE + 0x018;
    const TX_FULL: u32 = 1 << 5;
    const RX_EMPTY: u32 = 1 << 4;
    pub fn init() {}
    pub fn put(b: u8) {
        while read(STATUS) & TX_FULL != 0 {}
        write(DATA, b as u32);
    }
    pub fn get() -> Option<u8> {
        (read(STATUS) & RX_EMPTY == 0).then(|| read(DATA) as u8)
    }
}

/// The Arm CMSDK APB UART (the MPS2 boards).
#[cfg(hilcam_uart = "cmsdk")]
mod regs {
    use super::{read, write, UART_BASE as BASE};
    /// Data register.
    const DATA: usize = BASE;
    /// State register; bit 0 = transmit buffer full, bit 1 = receive
    /// buffer full.
    const STATUS: usize = BASE + 0x004;
    const TX_FULL: u32 = 1;
    const RX_FULL: u32 = 1 << 1;
    const CTRL: usize = BASE + 0x008;
    const BAUDDIV: usize = BASE + 0x010;
    /// The CMSDK UART needs a divider of at least 16, and TX and RX
    /// enabled.
    pub fn init() {
        write(BAUDDIV, 16);
        write(CTRL, 0b11);
    }
    /// Waits while the transmitter is full (the CMSDK UART drops bytes
    /// otherwise).
    pub fn put(b: u8) {
        while read(STATUS) & TX_FULL != 0 {}
        write(DATA, b as u32);
    }
    pub fn get() -> Option<u8> {
        (read(STATUS) & RX_FULL != 0).then(|| read(DATA) as u8)
    }
}

/// The nRF51822's UART (QEMU microbit).
#[cfg(hilcam_uart = "nrf51")]
mod regs {
    use super::{read, write, UART_BASE as BASE};
    /// Tasks: start the receiver, the transmitter.
    const STARTRX: usize = BASE; // offset 0x000
    const STARTTX: usize = BASE + 0x008;
    /// Events: a byte was received, a byte was sent.
    const RXDRDY: usize = BASE + 0x108;
    const TXDRDY: usize = BASE + 0x11C;
    /// 4 enables the UART.
    const ENABLE: usize = BASE + 0x500;
    const RXD: usize = BASE + 0x518;
    const TXD: usize = BASE + 0x51C;
    pub fn init() {
        write(ENABLE, 4);
        write(STARTTX, 1);
        write(STARTRX, 1);
    }
    /// Sends one byte and waits until it has left.
    pub fn put(b: u8) {
        write(TXDRDY, 0);
        write(TXD, b as u32);
        while read(TXDRDY) == 0 {}
    }
    pub fn get() -> Option<u8> {
        if read(RXDRDY) == 0 {
            return None;
        }
        write(RXDRDY, 0);
        Some(read(RXD) as u8)
    }
}


/// UART0, blocking.
pub struct Uart0(());

impl Uart0 {
    /// Initializes UART0.
    pub fn new() -> Uart0 {
        regs::init();
        Uart0(())
    }
}

/// The byte UART0 has received, if one waits (never blocks).
#[cfg_attr(not(feature = "camera"), allow(dead_code))]
pub fn read_byte() -> Option<u8> {
    regs::get()
}

impl embedded_io::ErrorType for Uart0 {
    type Error = Infallible;
}

impl embedded_io::Write for Uart0 {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        for &b in buf {
            regs::put(b);
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}
