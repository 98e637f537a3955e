//! The boards: UART0 as an `embedded_io::Write` (and polled RX), and the
//! SysTick clock.
//!
//! Register access is MMIO, so this is the one place with `unsafe`: volatile
//! reads and writes of fixed, documented device addresses.

use core::convert::Infallible;

#[cfg(feature = "board-lm3s6965")]
mod regs {
    /// PL011 UART0 of the LM3S6965.
    pub const BASE: usize = 0x4000_C000;
    /// Data register.
    pub const DATA: usize = BASE;
    /// Flag register; bit 5 = transmit FIFO full, bit 4 = receive FIFO
    /// empty.
    pub const STATUS: usize = BASE + 0x018;
    pub const TX_FULL: u32 = 1 << 5;
    /// Bit set in `STATUS` while a received byte waits.
    pub const RX_READY: u32 = 1 << 4;
    /// `RX_READY` is set when no byte waits (PL011's RXFE).
    pub const RX_READY_INVERTED: bool = true;
    /// SysTick clock period on lm3s6965evb, ns (12.5 MHz).
    pub const SYSTICK_NS: u64 = 80;
    pub fn init() {}
}

#[cfg(feature = "board-mps2-an386")]
mod regs {
    /// CMSDK APB UART0 of the MPS2+ AN386.
    pub const BASE: usize = 0x4000_4000;
    /// Data register.
    pub const DATA: usize = BASE;
    /// State register; bit 0 = transmit buffer full, bit 1 = receive
    /// buffer full.
    pub const STATUS: usize = BASE + 0x004;
    pub const TX_FULL: u32 = 1;
    pub const RX_READY: u32 = 1 << 1;
    pub const RX_READY_INVERTED: bool = false;
    const CTRL: usize = BASE + 0x008;
    const BAUDDIV: usize = BASE + 0x010;
    /// SysTick clock period on mps2-an386, ns (25 MHz).
    pub const SYSTICK_NS: u64 = 40;
    /// The CMSDK UART needs a divider of at least 16, and TX and RX
    /// enabled.
    pub fn init() {
        // SAFETY: documented registers of the CMSDK UART0 at a fixed address.
        unsafe {
            core::ptr::write_volatile(BAUDDIV as *mut u32, 16);
            core::ptr::write_volatile(CTRL as *mut u32, 0b11);
        }
    }
}

#[cfg(not(any(feature = "board-lm3s6965", feature = "board-mps2-an386")))]
compile_error!("pick a board: --features board-lm3s6965 or board-mps2-an386");

pub use regs::SYSTICK_NS;

/// UART0, blocking: waits while the transmitter is full (the CMSDK UART drops
/// bytes otherwise).
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
    // SAFETY: documented UART registers at a fixed address.
    unsafe {
        let status = core::ptr::read_volatile(regs::STATUS as *const u32);
        if (status & regs::RX_READY != 0) == regs::RX_READY_INVERTED {
            return None;
        }
        Some(core::ptr::read_volatile(regs::DATA as *const u32) as u8)
    }
}

impl embedded_io::ErrorType for Uart0 {
    type Error = Infallible;
}

impl embedded_io::Write for Uart0 {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        for &b in buf {
            // SAFETY: documented UART registers at a fixed address.
            unsafe {
                while core::ptr::read_volatile(regs::STATUS as *const u32) & regs::TX_FULL != 0 {}
                core::ptr::write_volatile(regs::DATA as *mut u32, b as u32);
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}
