//! hilcam firmware: renders every shipped scene (held in flash as scene
//! data, encoded from `scenes/` at build time, built by the core at run
//! time) and streams the frames over UART0 with the link protocol. Each frame's cost — instructions, counted with SysTick under
//! QEMU `-icount` — goes in its `FrameEnd`, its ground truth in its
//! `FrameStart`. Status goes to semihosting; a panic reports there and
//! exits non-zero.
//!
//! With the `camera` feature it is a camera the host drives instead: it
//! reads commands on UART0 RX (`hilcam::link::control`), answers each, takes
//! new scenes as data, and renders the frames they ask for, forever.
#![no_std]
#![no_main]

mod board;

#[allow(clippy::all, unused_imports, dead_code)]
mod scenes {
    use hilcam::render::{Arithmetic, DistortionEval, Options, Override, RenderModel};
    include!(concat!(env!("OUT_DIR"), "/scenes.rs"));
}

/// Widest line rendered, pixels: the widest scene held, and for a driven
/// camera at least 640 (a scene loaded wider is refused).
#[cfg(feature = "camera")]
const MAX_WIDTH: usize = if scenes::MAX_WIDTH > 640 {
    scenes::MAX_WIDTH
} else {
    640
};
#[cfg(not(feature = "camera"))]
const MAX_WIDTH: usize = scenes::MAX_WIDTH;
/// Distortion-table entries a frame holds (4 bytes each): the most any
/// held scene's variant renders with. A driven camera, whose scenes come
/// over the link, holds none: it plans without tables (the polynomial is
/// always a candidate) and says so in its `Description.max_table`, so the
/// host plans its reference frames alike; a 1 024-entry table would be
/// 4 KB of its 16 KiB of RAM.
#[cfg(feature = "camera")]
const TABLE: usize = 0;
#[cfg(not(feature = "camera"))]
const TABLE: usize = scenes::TABLE;

/// The line loops compiled in: a driven camera's, every one the planner
/// picks; otherwise those the held scenes' plans use (the others cost flash
/// and never run).
#[cfg(feature = "camera")]
use hilcam::render::PlannedLines as Built;
#[cfg(not(feature = "camera"))]
use scenes::Built;

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::debug;
use hilcam::link::{Encoder, FrameStart, Stream};
use hilcam::render::{Frame, LineBuffers, Options, Timed};
use hilcam::num::scalar::Scalar;
use hilcam::scene::Scene;

/// The encoder's chunk: the link's default; a driven camera's, one line of
/// its widest (two bytes a pixel), 768 B of RAM less (a chunk message per
/// 8 lines of 160 Gray8 pixels instead of 12).
#[cfg(not(feature = "camera"))]
const CHUNK: usize = hilcam::link::DEFAULT_CHUNK;
#[cfg(feature = "camera")]
const CHUNK: usize = 2 * MAX_WIDTH;
// Lines are rendered into the chunk (`Stream`'s `place`): the longest
// held must fit it.
#[cfg(not(feature = "camera"))]
const _: () = assert!(scenes::MAX_LINE_BYTES <= CHUNK);

type Enc = Encoder<board::Uart0, CHUNK>;

/// Status text over semihosting (QEMU, probe-rs), unless the `status`
/// feature is off (the exit code is always reported through semihosting).
///
/// A status line, built in a buffer and written as one string: `{}` of an
/// integer or a name through `core::fmt` (its padding, its integer
/// formatting) cost flash no status line needs. Each line is written by a
/// function of its own, out of line: the buffer lives in its frame, not in
/// the frame that renders (the painted stack's peak).
#[cfg(feature = "status")]
struct Line {
    buf: [u8; 160],
    len: usize,
}

#[cfg(feature = "status")]
impl Line {
    fn new() -> Line {
        Line {
            buf: [0; 160],
            len: 0,
        }
    }

    /// `frame <id> <scene> <variant>: <n> instructions` (host-sim hil).
    #[inline(never)]
    fn frame(id: usize, scene: &str, variant: &str, instructions: u64) {
        Line::new()
            .text("frame ")
            .num(id as u64)
            .text(" ")
            .text(scene)
            .text(" ")
            .text(variant)
            .text(": ")
            .num(instructions)
            .text(" instructions")
            .say();
    }

    /// `stack_peak_bytes <n>` (host-sim hil and drive).
    #[inline(never)]
    fn peak(bytes: usize) {
        Line::new().text("stack_peak_bytes ").num(bytes as u64).say();
    }

    /// `firmware error: <what>`.
    #[inline(never)]
    fn error(what: &str) {
        Line::new().text("firmware error: ").text(what).say();
    }

    /// `firmware panic at <file>:<line>`.
    #[inline(never)]
    fn panic(file: &str, line: u32) {
        Line::new()
            .text("firmware panic at ")
            .text(file)
            .text(":")
            .num(u64::from(line))
            .say();
    }

    /// Appends a byte (past the buffer's end, none).
    fn byte(&mut self, b: u8) {
        if let Some(x) = self.buf.get_mut(self.len) {
            *x = b;
            self.len += 1;
        }
    }

    /// Appends `s`.
    #[inline(never)]
    fn text(mut self, s: &str) -> Line {
        s.bytes().for_each(|b| self.byte(b));
        self
    }

    /// Appends `v` in decimal.
    #[inline(never)]
    fn num(mut self, v: u64) -> Line {
        let mut digits = [0u8; 20];
        let (mut v, mut n) = (v, 0);
        while let Some(d) = digits.get_mut(n) {
            *d = b'0' + (v % 10) as u8;
            (v, n) = (v / 10, n + 1);
            if v == 0 {
                break;
            }
        }
        digits.iter().take(n).rev().for_each(|&d| self.byte(d));
        self
    }

    /// Writes the line and a newline over semihosting.
    #[inline(never)]
    fn say(mut self) {
        self.byte(b'\n');
        if let Some(Ok(s)) = self.buf.get(..self.len).map(core::str::from_utf8) {
            cortex_m_semihosting::hprint!(s);
        }
    }
}

/// The `-icount` shift `host-sim hil` runs QEMU with: 2^7 ns an instruction.
const ICOUNT_SHIFT: u32 = 7;

/// The device-interrupt part of the vector table. The firmware enables no
/// interrupt (the UART is polled, SysTick is a core exception), so 16
/// entries to the default handler stand for the 240 that cortex-m-rt
/// reserves without a device crate (960 B of flash).
#[link_section = ".vector_table.interrupts"]
#[no_mangle]
static __INTERRUPTS: [unsafe extern "C" fn(); 16] = [DefaultHandler; 16];

extern "C" {
    /// cortex-m-rt's default handler.
    fn DefaultHandler();
}

static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    WRAPS.store(WRAPS.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
}

/// SysTick ticks since start (24-bit counter with wraps counted).
fn ticks() -> u64 {
    loop {
        let w1 = WRAPS.load(Ordering::Relaxed);
        let cvr = SYST::get_current();
        let w2 = WRAPS.load(Ordering::Relaxed);
        if w1 == w2 {
            return ((w1 as u64) << 24) | (0x00FF_FFFF - cvr) as u64;
        }
    }
}

/// Ticks → ns of the camera's time (virtual time under `-icount`).
fn ns(ticks: u64) -> u64 {
    ticks * board::SYSTICK_PS / 1000
}

/// Ticks → instructions under `-icount shift=7`.
fn instructions(ticks: u64) -> u64 {
    ticks * board::SYSTICK_PS / (1000 << ICOUNT_SHIFT)
}

/// Stack painting: the RAM between the end of the statics (`__sheap`) and
/// the stack pointer is filled with a pattern at start; the lowest word no
/// longer holding it after the frames marks the deepest stack use.
mod stack {
    const PAINT: u32 = 0xA5A5_A5A5;
    extern "C" {
        static mut __sheap: u32;
        static _stack_start: u32;
    }

    fn bounds() -> (usize, usize) {
        // Addresses of linker symbols only; nothing is read.
        (
            core::ptr::addr_of_mut!(__sheap) as usize,
            core::ptr::addr_of!(_stack_start) as usize,
        )
    }

    /// Paints from the end of the statics to 256 bytes below the stack
    /// pointer.
    pub fn paint() {
        let (lo, _) = bounds();
        let sp = cortex_m::register::msp::read() as usize;
        let mut p = lo;
        while p + 4 <= sp.saturating_sub(256) {
            // SAFETY: free RAM between the statics and the live stack.
            unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
            p += 4;
        }
    }

    /// Deepest stack use so far, bytes (the sweep reports it at its end,
    /// the camera after each frame).
    #[cfg_attr(not(feature = "status"), allow(dead_code))]
    pub fn peak() -> usize {
        let (lo, top) = bounds();
        let mut p = lo;
        // SAFETY: reads of RAM painted by `paint`.
        while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
            p += 4;
        }
        top - p
    }
}

#[entry]
fn main() -> ! {
    stack::paint();
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| fail("peripherals"));
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(0x00FF_FFFF);
    cp.SYST.clear_current();
    cp.SYST.enable_interrupt();
    cp.SYST.enable_counter();
    // QEMU raises one SysTick as soon as the counter starts from 0: let it
    // pass before counting.
    while SYST::get_current() == 0 {}
    WRAPS.store(0, Ordering::Relaxed);

    let mut enc = match Enc::new(board::Uart0::new()) {
        Ok(e) => e,
        Err(_) => fail("encoder"),
    };
    // (Lines are rendered into the encoder's chunk: `Stream`'s place.)
    let mut flags = [0u8; MAX_WIDTH];
    #[cfg(feature = "camera")]
    camera::run(&mut enc, &mut flags);
    #[cfg(not(feature = "camera"))]
    {
        let mut keys = [0u64; scenes::CORNER_KEYS];
        sweep(&mut enc, &mut flags, &mut keys);
    }
}

/// Renders every embedded scene with every variant, once, and exits.
#[cfg(not(feature = "camera"))]
fn sweep(enc: &mut Enc, flags: &mut [u8], keys: &mut [u64]) -> ! {
    for (id, blob) in scenes::BLOBS.iter().enumerate() {
        // Used in place (a scene is 4.7 KB: no copy of it).
        let loaded = hilcam::scene::data::load(blob);
        let Ok(scene) = &loaded else {
            fail("scene data");
        };
        let Some(opts) = scenes::OPTIONS.get(id) else {
            fail("plan");
        };
        // Names only in status lines (a build without them holds none).
        for v in 0..scenes::VARIANTS.len() {
            let mut run = Run {
                scene,
                enc,
                flags,
                keys,
                frame_id: (id * scenes::VARIANTS.len() + v) as u32,
                scene_id: id as u32,
                command: None,
            };
            let Some(opts) = opts.get(v) else {
                fail("plan");
            };
            let ins = scenes::render_variant(v, opts, &mut run).unwrap_or_else(|e| fail(e));
            #[cfg(feature = "status")]
            Line::frame(
                id,
                scenes::NAMES.get(id).unwrap_or(&"?"),
                scenes::VARIANTS.get(v).unwrap_or(&"?"),
                ins,
            );
            let _ = ins;
        }
    }
    #[cfg(feature = "status")]
    Line::peak(stack::peak());
    #[cfg(feature = "status")]
    cortex_m_semihosting::hprintln!("done");
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}

/// The driven camera: commands in on UART0 RX, answers and frames out.
#[cfg(feature = "camera")]
mod camera {
    use super::{board, fail, ns, ticks, Enc, Run, CHUNK, MAX_WIDTH, TABLE};
    use hilcam::link::control::{Control, Library, Receiver};
use hilcam::link::{Command, MAX_REQUEST};
    use hilcam::scene::Scene;
    use hilcam::scene::data::MAX_SCENE_DATA;

    /// Bytes read from RX between two frames at most: a flood of input
    /// delays a promised frame by at most this much decoding.
    const RX_BUDGET: usize = 4 * MAX_REQUEST;

    /// The planner's choice for the scene shown, and the
    /// [`Control::revision`] it was made at.
    struct Planned {
        opts: hilcam::render::Options,
        revision: u32,
    }

    impl Planned {
        fn of(scene: &Scene, control: &Control) -> Planned {
            Planned {
                opts: super::options(scene),
                revision: control.revision(),
            }
        }

        /// Plans again if the commands changed the scene since.
        fn refresh(&mut self, scene: &Scene, control: &Control) {
            if control.revision() != self.revision {
                *self = Planned::of(scene, control);
            }
        }
    }

    /// Runs the camera forever (starting on scene 0, triggered).
    pub fn run(enc: &mut Enc, flags: &mut [u8]) -> ! {
        // Lines one encoder chunk holds (two bytes a pixel at most; lines
        // are rendered into it): a wider scene is refused when it is
        // loaded.
        let widest = MAX_WIDTH.min(CHUNK / 2) as u16;
        let mut library = Library::<MAX_SCENE_DATA, TABLE>::new(&super::scenes::BLOBS, widest);
        // The scene shown, used where it was built (a scene is 1.4 KB).
        let mut built = library.scene(0);
        let Ok(scene) = &mut built else {
            fail("scene 0");
        };
        let mut control = Control::new();
        let mut rx = Receiver::<MAX_REQUEST>::new();
        let mut frame_id = 0u32;
        // The plan of the scene as it stands, made again once the commands
        // read have changed it: before the next frame begins, and before a
        // trigger read in the same batch as the change is acknowledged, so
        // that no frame's round trip (the trigger's ack to the frame's
        // first message) holds the planner, however the commands arrive.
        let mut plan = Planned::of(scene, &control);
        loop {
            for _ in 0..RX_BUDGET {
                let Some(byte) = board::read_byte() else {
                    break;
                };
                let Some(Ok(req)) = rx.push(byte) else {
                    continue;
                };
                let seq = req.seq;
                if matches!(req.command, Command::Trigger { .. }) {
                    plan.refresh(scene, &control);
                }
                let answer = control.handle(&req, scene, &mut library);
                let sent = enc.send_answer(seq, answer, control.stamp(ns(ticks())), || {
                    control.describe(scene, &library, frame_id)
                });
                if sent.is_err() {
                    fail("reply");
                }
            }
            plan.refresh(scene, &control);
            if control.frame_due(ns(ticks())) {
                let mut run = Run {
                    scene,
                    enc,
                    flags,
                    keys: &mut [],
                    frame_id,
                    scene_id: control.scene_id,
                    command: control.last_command(),
                };
                if super::scenes::render_variant(0, &plan.opts, &mut run).is_err() {
                    fail("render");
                }
                // The deepest stack use so far (host-sim drive reports it).
                #[cfg(feature = "status")]
                super::Line::peak(super::stack::peak());
                frame_id = frame_id.wrapping_add(1);
            }
        }
    }
}

/// The planner's choice for a scene the camera was sent, with the default
/// budget within the frame's table. Out of line: the planner's working
/// state is not held while the frame renders. (The sweep's scenes are
/// planned at build time: `scenes::OPTIONS`.)
#[cfg(feature = "camera")]
#[inline(never)]
fn options(scene: &Scene) -> Options {
    let budget = hilcam::planner::Budget {
        max_table_entries: TABLE,
        ..hilcam::planner::Budget::default()
    };
    hilcam::planner::plan(scene, &budget).options
}

/// Renders a scene in a chosen scalar type and streams the frame.
pub trait Runner {
    /// Renders with per-pixel values in `S` and `opts`; returns the
    /// frame's cost in instructions.
    fn run<S: Scalar>(&mut self, opts: &Options) -> Result<u64, &'static str>;
}

struct Run<'a> {
    scene: &'a Scene,
    enc: &'a mut Enc,
    flags: &'a mut [u8],
    /// The sampled loop's corner keys, carried from line to line (a driven
    /// camera holds none: its RAM is spoken for).
    keys: &'a mut [u64],
    frame_id: u32,
    scene_id: u32,
    /// The last command processed (driven camera).
    command: Option<u32>,
}

impl Runner for Run<'_> {
    // Out of line, so that each scalar type's frame has its own stack frame
    // rather than all of them summed in the caller.
    #[inline(never)]
    fn run<S: Scalar>(&mut self, opts: &Options) -> Result<u64, &'static str> {
        let scene = self.scene;
        let t0 = ticks();
        let mut frame = Frame::<S, TABLE, Built>::empty();
        frame.prepare(scene, opts).map_err(|_| "frame")?;
        // The frame id on the wire keys the sensor noise (camera-model.md §9).
        frame.set_frame_id(self.frame_id);
        let t1 = ticks();
        let prepare = t1 - t0;
        // Stamped when the frame's first message is sent.
        let start = FrameStart::of(
            self.frame_id,
            self.scene_id,
            scene,
            &frame.stages(),
            ns(t1),
            self.command,
        );
        // Only rendering is counted (the preparation and the time between
        // the link's calls), not the UART's back-pressure: the timing is an
        // adapter around the link's sink.
        let mut sink = Timed::new(Stream { enc: self.enc, start }, ticks, instructions, prepare);
        frame
            .render(LineBuffers::new(&mut [], self.flags).with_keys(self.keys), &mut sink)
            .map_err(|_| "render")?;
        Ok(sink.cost())
    }
}

fn fail(what: &str) -> ! {
    #[cfg(feature = "status")]
    Line::error(what);
    let _ = what;
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // Where, not the message: formatting it would link `core::fmt`.
    #[cfg(feature = "status")]
    match info.location() {
        Some(l) => Line::panic(l.file(), l.line()),
        None => Line::panic("?", 0),
    }
    let _ = info;
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
