//! `host-sim profile`: where a frame's instructions go on a board, by
//! pipeline stage. Runs the firmware in QEMU with its translation blocks
//! logged (`-d in_asm,exec,nochain`: every block as translated, and each
//! execution), counts the instructions executed at each address, and
//! attributes each address to a stage from its inlined call chain in the
//! ELF's debug information (the innermost function a stage claims, see
//! [`stage_of`]), and to a source line (the innermost in this repository:
//! a `core::` helper counts for the line that inlined it). A frame is what
//! runs from one entry of the firmware's `Runner::run` to the next: its
//! preparation, its lines, and its streaming (the `link` row, which the
//! frame cost of `hil` leaves out).
//!
//! The counts are QEMU's executed guest instructions, as `hil`'s are
//! (`hil` reads them from SysTick under `-icount`, which counts the same
//! instructions); this run is without `-icount`, whose rewound blocks the
//! log would count twice.

mod elf;

pub use elf::{call_marks, flash_use, frame_marks, FlashUse, Marks, Share};
use elf::{is_library, name_of, source_of};

use crate::qemu::{build_firmware, run_qemu, spawn_qemu_with, Board};
use crate::link::decoder::Decoder;
use crate::scene_file::load;
use serde::Serialize;
use std::collections::HashMap;
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// A pipeline stage, or where else an instruction ran.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stage {
    /// Scene data read, checks, planning, frame preparation (per frame).
    Preparation,
    /// The line loop itself: chunks, the per-pixel dispatch.
    LineLoop,
    /// Distortion (the polynomial's inverse, or the table).
    Distortion,
    /// Pixel rays: `a = d·d`, `1/a`, parallel origins, the slope box.
    Rays,
    /// Ray–primitive intersection and the nearest hit.
    Intersection,
    /// The hit point, its normal and texture.
    Hit,
    /// The shader: ambient, Lambertian, specular.
    Shading,
    /// `cos⁴α` and image irradiance to DN.
    Vignetting,
    /// Pixel-area integration (the sample grid, the adaptive rule).
    Sampling,
    /// Defocus (the aperture's rays).
    Defocus,
    /// Sensor noise.
    Noise,
    /// Pixel words and bytes.
    PixelCodec,
    /// The link: framing, CRC, COBS, the UART.
    Link,
    /// The firmware around the frames: start-up, status lines, timing.
    Firmware,
}

impl Stage {
    /// Every stage, in the table's order.
    pub const ALL: [Stage; 14] = [
        Stage::Preparation,
        Stage::LineLoop,
        Stage::Distortion,
        Stage::Rays,
        Stage::Intersection,
        Stage::Hit,
        Stage::Shading,
        Stage::Vignetting,
        Stage::Sampling,
        Stage::Defocus,
        Stage::Noise,
        Stage::PixelCodec,
        Stage::Link,
        Stage::Firmware,
    ];

    /// The stage's name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Preparation => "preparation",
            Stage::LineLoop => "line loop",
            Stage::Distortion => "distortion",
            Stage::Rays => "rays",
            Stage::Intersection => "intersection",
            Stage::Hit => "hit, normal, texture",
            Stage::Shading => "shading",
            Stage::Vignetting => "vignetting, DN",
            Stage::Sampling => "sampling",
            Stage::Defocus => "defocus",
            Stage::Noise => "noise",
            Stage::PixelCodec => "pixel codec",
            Stage::Link => "link",
            Stage::Firmware => "firmware",
        }
    }
}

/// Function-name fragments (demangled, without hashes) and the stage they
/// claim, matched innermost frame first, so that a shared helper (a
/// product, a reciprocal) counts for the stage whose function inlined it.
/// [`MODULES`] claim what none of these does.
const FUNCTIONS: &[(&str, Stage)] = &[
    // The fast arithmetic's stages (hilcam::render::fast).
    ("fast::Mix32::undistort", Stage::Distortion),
    ("fast::rays::undistort_k", Stage::Distortion),
    ("fast::rays::fill_rays", Stage::Rays),
    ("fast::rays::Ray::new", Stage::Rays),
    ("fast::Mix32::trace_row", Stage::Rays),
    ("fast::Mix32::rays", Stage::Rays),
    // The chunk's slope box and each primitive's cull by its bounds (the
    // passes themselves are `MixShape::nearest`'s).
    ("fast::Mix32::passes", Stage::Intersection),
    ("fast::rays::Ray::mirror", Stage::Rays),
    ("fast::rays::Ray::plane_t", Stage::Intersection),
    ("fast::rays::Ray::keep", Stage::Intersection),
    ("fast::intersect::MixShape::nearest", Stage::Intersection),
    ("fast::Mix32::hit", Stage::Hit),
    ("fast::intersect::fine_normal", Stage::Hit),
    ("fast::intersect::MixChecker", Stage::Hit),
    ("fast::rays::Ray::point", Stage::Hit),
    // The closed-form plane: its w = n·d and its test where another
    // primitive was hit (intersection), its terms (shading); the run's own
    // loop is the line loop's.
    ("fast::shade::closed_w", Stage::Intersection),
    ("fast::Mix32::closed_keep", Stage::Intersection),
    ("fast::shade::closed_term", Stage::Shading),
    ("fast::shade::cube_over", Stage::Shading),
    ("fast::shade::Cube", Stage::Shading),
    ("fast::Mix32::closed_run", Stage::LineLoop),
    ("fast::Mix32::shade", Stage::Shading),
    ("fast::shade::directional_w", Stage::Shading),
    ("fast::Mix32::view", Stage::Shading),
    ("fast::shade::lobe_pf", Stage::Shading),
    ("fast::arith::cos_over_r", Stage::Shading),
    ("fast::shade::KCache", Stage::Shading),
    ("fast::Mix32::c4", Stage::Vignetting),
    ("fast::expose::vignette_", Stage::Vignetting),
    ("fast::expose::noisy", Stage::Noise),
    ("fast::expose::sigma_z", Stage::Noise),
    ("fast::expose::mul_nonneg", Stage::Noise),
    ("fast::expose::word", Stage::PixelCodec),
    ("fast::expose::put", Stage::PixelCodec),
    ("fast::expose::store", Stage::PixelCodec),
    ("fast::Mix32::line_s", Stage::Sampling),
    ("fast::Mix32::grid", Stage::Sampling),
    ("fast::Mix32::key", Stage::Sampling),
    ("fast::Mix32::radiance_s", Stage::Sampling),
    ("fast::Mix32::sampled", Stage::Sampling),
    ("fast::Mix32::line_d", Stage::Defocus),
    ("fast::intersect::MixShape::moved", Stage::Defocus),
    ("fast::Aperture", Stage::Defocus),
    ("fast::Mix32::fill", Stage::Preparation),
    ("fast::Mix32::closed_plane", Stage::Preparation),
    ("fast::Mix32::set_frame_id", Stage::Preparation),
    ("fast::Mix32::line", Stage::LineLoop),
    ("fast::Mix32::pixel", Stage::LineLoop),
    ("fast::Mix32::radiance", Stage::LineLoop),
    ("fast::Mix32::dn_word", Stage::LineLoop),
    ("fast::rays::Rays", Stage::LineLoop),
    ("render::Frame<S,_>::prepare", Stage::Preparation),
    ("render::WideFrame<S,_>::prepare", Stage::Preparation),
    ("render::cam_prim", Stage::Preparation),
    ("hilcam::render::intersect", Stage::Intersection),
    ("hilcam::render::WideFrame<S,_>::through_aperture", Stage::Defocus),
];

/// Module paths (the longest that matches) and the stage they claim where no function of
/// [`FUNCTIONS`] does (the core's stage modules, the wide arithmetic's
/// line loop, the libraries); `None`: an out-of-line helper, counted for
/// the stage that called it.
const MODULES: &[(&str, Option<Stage>)] = &[
    ("hilcam::geom::distortion::", Some(Stage::Distortion)),
    ("hilcam::render::vignetting::", Some(Stage::Vignetting)),
    ("hilcam::render::sensor::noise::", Some(Stage::Noise)),
    ("hilcam::render::sensor::sampling::", Some(Stage::Sampling)),
    ("hilcam::render::sensor::defocus::", Some(Stage::Defocus)),
    ("hilcam::fmt::", Some(Stage::PixelCodec)),
    ("hilcam::link::", Some(Stage::Link)),
    ("crc::", Some(Stage::Link)),
    ("postcard::", Some(Stage::Link)),
    ("cobs::", Some(Stage::Link)),
    ("hilcam_firmware::board::", Some(Stage::Link)),
    ("hilcam::render::", Some(Stage::LineLoop)),
    ("hilcam::render::shading::", Some(Stage::Shading)),
    ("hilcam::scene::data::", Some(Stage::Preparation)),
    ("hilcam::scene::", Some(Stage::Preparation)),
    ("hilcam::planner::", Some(Stage::Preparation)),
    ("hilcam::geom::extrinsics::", Some(Stage::Preparation)),
    ("hilcam::geom::intrinsics::", Some(Stage::Preparation)),
    ("hilcam::geom::lens::", Some(Stage::Preparation)),
    ("hilcam::geom::camera::", Some(Stage::Preparation)),
    ("hilcam::geom::projection::", Some(Stage::Preparation)),
    ("hilcam::num::", None),
    ("hilcam::num::scalar::", None),
    ("hilcam::render::fast::", None),
    ("compiler_builtins::", None),
    ("__aeabi_", None),
    ("libm::", None),
    ("core::", None),
    ("hilcam_firmware::", Some(Stage::Firmware)),
    ("cortex_m", Some(Stage::Firmware)),
];

/// The stage of an address from its call chain (innermost function
/// first, names demangled without hashes): the innermost function
/// `FUNCTIONS` claims, else the innermost `MODULES` claims (`None`:
/// a helper, its caller's), else a bare symbol's caller's, else
/// [`Stage::Firmware`].
pub fn stage_of(chain: &[String]) -> Option<Stage> {
    // Without spaces: demanglers write `Frame<S,_>` or `Frame<S, _>`.
    let chain: Vec<String> = chain.iter().map(|f| f.replace(' ', "")).collect();
    let claim = |f: &String, k: &str| f.contains(&k.replace(' ', ""));
    let function = chain
        .iter()
        .find_map(|f| FUNCTIONS.iter().find(|(k, _)| claim(f, k)).map(|(_, s)| *s));
    if let Some(s) = function {
        return Some(s);
    }
    // The longest module path that claims a frame: a stage module wins
    // over the module holding it.
    let module = chain.iter().find_map(|f| {
        (MODULES.iter().filter(|(k, _)| claim(f, k)))
            .max_by_key(|(k, _)| k.len())
            .map(|(_, s)| *s)
    });
    match module {
        Some(s) => s,
        // A bare symbol (`__clzsi2`, `fmax`, an exception handler): the
        // compiler's runtime or libm, counted for its caller (an interrupt
        // for what it interrupted, as -icount counts it).
        None if chain.iter().all(|f| !f.contains("::")) => None,
        None => Some(Stage::Firmware),
    }
}

/// One translated block: its instructions' stages (`None`: a helper's,
/// counted for the stage that ran before it) and innermost functions.
struct Block {
    /// Instructions by stage.
    stages: Vec<(Option<Stage>, u64)>,
    /// Instructions by function (index into [`Symbols::names`]) and stage.
    functions: Vec<(usize, Option<Stage>, u64)>,
    /// Instructions by source line (index into [`Symbols::lines`]).
    lines: Vec<(usize, u64)>,
    /// The stage of the block's last instruction (where a call leaves).
    last: Option<Stage>,
    /// Instructions by function as [`Window::by_caller`] counts them: an
    /// instruction of a library routine (no frame of its inlined chain
    /// in the repository's files) as `None`, for the caller.
    own: Vec<(Option<usize>, u64)>,
    /// The function of the block's last instruction outside a library
    /// routine, if any (the caller of a routine run next).
    last_own: Option<usize>,
}

/// One window of the run: instructions by stage and by function.
#[derive(Default)]
pub struct Window {
    /// A marked call's, a frame in `profile` (else what runs between them).
    pub frame: bool,
    /// Instructions by stage.
    pub stages: HashMap<Stage, u64>,
    /// Instructions by function (index into [`Symbols::names`]) and stage.
    functions: HashMap<(usize, Stage), u64>,
    /// Instructions by source line (index into [`Symbols::lines`]).
    lines: HashMap<usize, u64>,
    /// Instructions by function (index into [`Symbols::names`]), a library
    /// routine's (`compiler_builtins`' soft-float, `__aeabi_*`, `libm`)
    /// counted for the function that called it.
    by_caller: HashMap<usize, u64>,
}

/// A run's instructions, in windows: before the first frame, then one a
/// frame.
pub struct Trace {
    /// The windows.
    pub windows: Vec<Window>,
    /// Function names.
    pub names: Vec<String>,
    /// Source lines (`file:line`).
    pub lines: Vec<String>,
}

impl Trace {
    /// Reads QEMU's `-d in_asm,exec,nochain` log of `elf`'s run. A frame
    /// starts at each execution of a block that begins at one of
    /// `marks.starts` and ends at the next block in one of its callers.
    /// Each block is attributed once, when it first runs; a helper's
    /// instructions count for the stage of the block that ran before it
    /// (its caller: helpers are leaves or call helpers).
    pub fn read(log: impl BufRead, elf: &Path, marks: &Marks) -> Result<Trace, String> {
        let mut syms = Symbols::new(elf)?;
        let mut windows = vec![Window::default()];
        // Each translation's instruction addresses, and its attribution
        // once it has run; the translation current at each address (a
        // block translated anew replaces the old one from then on).
        let mut listed: Vec<(Vec<u32>, Option<Block>)> = Vec::new();
        let mut current: HashMap<u32, usize> = HashMap::new();
        let mut open = false;
        let mut context = Stage::Firmware;
        // The function a library routine's instructions count for.
        let mut caller = None;
        for line in log.split(b'\n') {
            let line = line.map_err(|e| format!("QEMU log: {e}"))?;
            if line.starts_with(b"IN:") {
                open = false;
            } else if let Some(rest) = line.strip_prefix(b"0x") {
                // "0x00000084:  4808       ldr ...": an instruction of the
                // block being listed.
                let Some(pc) = hex(rest.split(|b| *b == b':').next().unwrap_or(&[])) else {
                    continue;
                };
                match (open, listed.last_mut()) {
                    (true, Some((pcs, _))) => pcs.push(pc),
                    _ => {
                        listed.push((vec![pc], None));
                        current.insert(pc, listed.len() - 1);
                        open = true;
                    }
                }
            } else if line.starts_with(b"Trace ") {
                // "Trace 0: 0x7eff88000500 [00800400/00000084/00000110/ff000200] Reset"
                open = false;
                let pc = line
                    .split(|b| *b == b'[')
                    .nth(1)
                    .and_then(|f| f.split(|b| *b == b'/').nth(1))
                    .and_then(hex)
                    .ok_or_else(|| format!("QEMU log: unreadable line {:?}", String::from_utf8_lossy(&line)))?;
                if marks.starts.contains(&pc) {
                    windows.push(Window {
                        frame: true,
                        ..Window::default()
                    });
                } else if windows.last().is_some_and(|w| w.frame)
                    && marks.callers.iter().any(|(a, b)| (*a..*b).contains(&pc))
                {
                    // Back in the caller: the frame is over.
                    windows.push(Window::default());
                }
                let (pcs, block) = current
                    .get(&pc)
                    .and_then(|k| listed.get_mut(*k))
                    .ok_or_else(|| format!("QEMU log: block {pc:#x} executed before it was listed"))?;
                let block = block.get_or_insert_with(|| syms.block(pcs));
                let Some(w) = windows.last_mut() else {
                    continue;
                };
                for (s, n) in &block.stages {
                    *w.stages.entry(s.unwrap_or(context)).or_insert(0) += n;
                }
                for (f, s, n) in &block.functions {
                    *w.functions.entry((*f, s.unwrap_or(context))).or_insert(0) += n;
                }
                for (l, n) in &block.lines {
                    *w.lines.entry(*l).or_insert(0) += n;
                }
                for (f, n) in &block.own {
                    if let Some(f) = f.or(caller) {
                        *w.by_caller.entry(f).or_insert(0) += n;
                    }
                }
                if let Some(s) = block.last {
                    context = s;
                }
                if block.last_own.is_some() {
                    caller = block.last_own;
                }
            }
        }
        Ok(Trace {
            windows,
            names: syms.names.list,
            lines: syms.lines.list,
        })
    }

    /// The frames' windows, in order.
    pub fn frames(&self) -> Vec<&Window> {
        self.windows.iter().filter(|w| w.frame).collect()
    }

    /// The functions of window `w` that cost the most, by stage: `(name,
    /// stage, instructions)`, at most `n`.
    pub fn top_functions(&self, w: &Window, n: usize) -> Vec<(String, Stage, u64)> {
        let mut v: Vec<(String, Stage, u64)> = w
            .functions
            .iter()
            .map(|((f, s), c)| (self.names.get(*f).cloned().unwrap_or_default(), *s, *c))
            .collect();
        v.sort_by(|a, b| b.2.cmp(&a.2).then(a.0.cmp(&b.0)));
        v.truncate(n);
        v
    }

    /// The functions of window `w` that cost the most, each with the
    /// library routines it called ([`Window::by_caller`]): `(name,
    /// instructions)`, at most `n`.
    pub fn top_callers(&self, w: &Window, n: usize) -> Vec<(String, u64)> {
        top(w.by_caller.iter().map(|(f, c)| (self.names.get(*f).cloned().unwrap_or_default(), *c)), n)
    }

    /// The source lines of window `w` that cost the most: `(file:line,
    /// instructions)`, at most `n`.
    pub fn top_lines(&self, w: &Window, n: usize) -> Vec<(String, u64)> {
        top(w.lines.iter().map(|(l, c)| (self.lines.get(*l).cloned().unwrap_or_default(), *c)), n)
    }
}

/// The `n` largest counts of `named`, largest first (ties by name).
fn top(named: impl Iterator<Item = (String, u64)>, n: usize) -> Vec<(String, u64)> {
    let mut v: Vec<(String, u64)> = named.collect();
    v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    v.truncate(n);
    v
}

fn hex(s: &[u8]) -> Option<u32> {
    u32::from_str_radix(std::str::from_utf8(s).ok()?.trim(), 16).ok()
}

/// Strings, each kept once, and their indices.
#[derive(Default)]
struct Interned {
    list: Vec<String>,
    index: HashMap<String, usize>,
}

impl Interned {
    /// `s`'s index, added if it is new.
    fn id(&mut self, s: String) -> usize {
        if let Some(k) = self.index.get(&s) {
            return *k;
        }
        self.list.push(s.clone());
        self.index.insert(s, self.list.len() - 1);
        self.list.len() - 1
    }
}

/// Call chains of addresses, innermost first, from the ELF's DWARF.
struct Symbols {
    loader: addr2line::Loader,
    /// Function names.
    names: Interned,
    /// Source lines (`file:line`).
    lines: Interned,
    /// The repository's root, which source lines are given relative to.
    root: PathBuf,
}

impl Symbols {
    /// Reads `elf`'s debug information.
    fn new(elf: &Path) -> Result<Symbols, String> {
        let loader = addr2line::Loader::new(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
        Ok(Symbols {
            loader,
            names: Interned::default(),
            lines: Interned::default(),
            root: std::fs::canonicalize(crate::qemu::repo_root()).unwrap_or_else(|_| crate::qemu::repo_root()),
        })
    }

    /// The functions at `pc`, innermost first, demangled without hashes
    /// (the symbol's name where there is no debug information).
    fn chain(&self, pc: u32) -> Vec<String> {
        let mut v = Vec::new();
        if let Ok(mut frames) = self.loader.find_frames(pc as u64) {
            while let Ok(Some(f)) = frames.next() {
                if let Some(raw) = f.function.as_ref().and_then(|n| n.raw_name().ok()) {
                    v.push(name_of(&raw));
                }
            }
        }
        if v.is_empty() {
            if let Some(s) = self.loader.find_symbol(pc as u64) {
                v.push(name_of(s));
            }
        }
        v
    }

    /// The source line at `pc`, `file:line` (relative to the repository
    /// where it lies in it): the innermost location outside the standard
    /// library and the registry's crates (for a `core::` helper inlined in
    /// the renderer, the renderer's line that called it); without one,
    /// `? in` the outermost function there.
    fn line(&self, pc: u32) -> String {
        let mut found = None;
        if let Ok(mut frames) = self.loader.find_frames(pc as u64) {
            while let Ok(Some(f)) = frames.next() {
                // (Line 0: code the compiler made up; the caller's line says
                // where it was inlined.)
                let Some((file, line)) = f.location.and_then(|l| Some((l.file?, l.line.filter(|k| *k > 0)?))) else {
                    continue;
                };
                if is_library(file) {
                    continue;
                }
                found = Some(format!("{}:{line}", source_of(file, &self.root)));
                break;
            }
        }
        // Else the function: a library's or the runtime's (`crc`,
        // `compiler_builtins`, `memcpy`).
        found.unwrap_or_else(|| format!("? in {}", self.chain(pc).last().map_or("?", String::as_str)))
    }

    /// The source file of the code at `addr`, as [`FlashUse`] names it:
    /// the innermost of the repository's files among its inlined frames,
    /// else the outermost library's, else `fallback`'s (the line table's).
    fn file_of(&self, addr: u64, fallback: Option<&str>) -> String {
        let mut name = source_of(fallback.unwrap_or("(none)"), &self.root);
        if let Ok(mut frames) = self.loader.find_frames(addr) {
            while let Ok(Some(f)) = frames.next() {
                if let Some(file) = f.location.and_then(|l| l.file) {
                    name = source_of(file, &self.root);
                    if !is_library(file) {
                        break;
                    }
                }
            }
        }
        name
    }

    /// A block's attribution.
    fn block(&mut self, pcs: &[u32]) -> Block {
        let mut stages: Vec<(Option<Stage>, u64)> = Vec::new();
        let mut functions: Vec<(usize, Option<Stage>, u64)> = Vec::new();
        let mut lines: Vec<(usize, u64)> = Vec::new();
        let mut own: Vec<(Option<usize>, u64)> = Vec::new();
        let (mut last, mut last_own) = (None, None);
        for pc in pcs {
            let line = self.line(*pc);
            // (`line` finds no location in the repository's files: a
            // library routine's instruction, not one inlined in ours.)
            let library = line.starts_with("? in ");
            let l = self.lines.id(line);
            match lines.iter_mut().find(|(x, _)| *x == l) {
                Some((_, n)) => *n += 1,
                None => lines.push((l, 1)),
            }
            let chain = self.chain(*pc);
            let s = stage_of(&chain);
            match stages.iter_mut().find(|(x, _)| *x == s) {
                Some((_, n)) => *n += 1,
                None => stages.push((s, 1)),
            }
            // The innermost of the core's functions (not a `core::` helper).
            let name = chain
                .iter()
                .find(|f| f.contains("hilcam"))
                .or(chain.first())
                .cloned()
                .unwrap_or_else(|| format!("{pc:#x}"));
            let k = self.names.id(name);
            match functions.iter_mut().find(|(x, t, _)| *x == k && *t == s) {
                Some((_, _, n)) => *n += 1,
                None => functions.push((k, s, 1)),
            }
            let o = (!library).then_some(k);
            match own.iter_mut().find(|(x, _)| *x == o) {
                Some((_, n)) => *n += 1,
                None => own.push((o, 1)),
            }
            last = s;
            if o.is_some() {
                last_own = o;
            }
        }
        Block {
            stages,
            functions,
            lines,
            last,
            own,
            last_own,
        }
    }
}

/// [`calls`]' answer.
pub struct Calls {
    /// Each call's instructions, in order.
    pub totals: Vec<u64>,
    /// The last call's costliest functions: `(name, instructions)`.
    pub last: Vec<(String, u64)>,
}

/// The calls of `function` in QEMU's `-d in_asm,exec,nochain` log of
/// `elf`'s run (`log`: a file), each ending when one of `callers` runs
/// again ([`call_marks`]): for each, its instructions, and the `top`
/// functions that cost the most in the last, a library routine's
/// instructions counted for its caller ([`Trace::top_callers`]); an error
/// if any of the last call's instructions is counted for none. For what
/// is not a frame: a driven camera's plan per pose (README, "The closed
/// loop"), its log from a `host-sim drive` whose QEMU logs its blocks.
pub fn calls(
    log: &Path,
    elf: &Path,
    function: &str,
    callers: &[String],
    top: usize,
) -> Result<Calls, String> {
    let marks = call_marks(elf, function, callers)?;
    let file = std::fs::File::open(log).map_err(|e| format!("{}: {e}", log.display()))?;
    let trace = Trace::read(std::io::BufReader::with_capacity(1 << 20, file), elf, &marks)?;
    let windows = trace.frames();
    let Some(last) = windows.last() else {
        return Err(format!("{}: no call of {function} from {callers:?}", log.display()));
    };
    let totals: Vec<u64> = windows.iter().map(|w| w.stages.values().sum()).collect();
    // Every instruction of the call counted for a function: a library
    // routine entered before any function of ours in it would be lost.
    let counted: u64 = last.by_caller.values().sum();
    if Some(&counted) != totals.last() {
        return Err(format!(
            "{}: {counted} of the last call's {:?} instructions counted for a function",
            log.display(),
            totals.last()
        ));
    }
    Ok(Calls {
        totals,
        last: trace.top_callers(last, top),
    })
}


/// One frame's profile.
#[derive(Clone, Debug, Serialize)]
pub struct FrameProfile {
    /// Scene name.
    pub scene: String,
    /// Pixels.
    pub pixels: u64,
    /// Instructions a pixel by stage (stages with none left out).
    pub stages: Vec<(Stage, f64)>,
    /// Instructions a pixel of every stage but the link and the firmware:
    /// the renderer's (with the preparation).
    pub render_per_pixel: f64,
    /// The firmware's instructions in the frame, a pixel (its clock reads,
    /// which the frame's cost counts: under 0.3 a pixel).
    pub firmware_per_pixel: f64,
    /// The frame's cost under `-icount` (what `hil` reports), a pixel.
    pub icount_per_pixel: Option<f64>,
    /// Instructions a pixel with the link and the firmware.
    pub total_per_pixel: f64,
    /// The innermost functions that cost the most (`--top` of them, 40
    /// by default), with the stage they counted for, instructions a pixel.
    pub functions: Vec<(String, Stage, f64)>,
    /// The workspace's source lines that cost the most (`--top` of them; a
    /// library helper counted for the line that inlined it), instructions
    /// a pixel.
    pub lines: Vec<(String, f64)>,
}

/// `profile.json`.
#[derive(Clone, Debug, Serialize)]
pub struct ProfileReport {
    /// Board.
    pub board: String,
    /// Frames.
    pub frames: Vec<FrameProfile>,
}

/// Profiles the planned renderer's frames of `scenes` on `board` (a
/// firmware holding them is built unless `elf` is given; then `scenes`
/// name what it holds, in order), each frame's `top` costliest functions
/// and source lines kept. Writes `profile.json` and `profile.md`;
/// fails, writing nothing, if a frame's traced instructions are more than
/// 1 % off its cost under `-icount`, or that run gives it no cost.
pub fn profile(
    board: Board,
    elf: Option<PathBuf>,
    scenes: &[PathBuf],
    top: usize,
    out: &Path,
) -> Result<ProfileReport, String> {
    if scenes.is_empty() {
        return Err("--scene: name the scenes the firmware holds, in order".into());
    }
    if top == 0 {
        return Err("--top: keep at least one function and line a frame".into());
    }
    let resolved = scenes.iter().map(|p| load(p)).collect::<Result<Vec<_>, _>>()?;
    let mut outputs = crate::output::Outputs::prepare(out)?;
    let built;
    let elf: &Path = match &elf {
        Some(e) => e,
        None => {
            built = build_firmware(board, scenes, &[])?;
            &built
        }
    };
    crate::qemu::check_elf(board, elf)?;
    let marks = frame_marks(elf)?;
    let uart = outputs.scratch("uart.bin");
    let mut child = spawn_qemu_with(
        board,
        elf,
        &format!("file:{}", uart.display()),
        &["-d", "in_asm,exec,nochain", "-D", "/dev/stderr"],
        false,
    )?;
    let log = child.stderr.take().ok_or("qemu: no log")?;
    // Its semihosting text, read as it comes (a full pipe would stall QEMU).
    let _text = crate::qemu::drain(child.stdout.take());
    // Read as QEMU writes it (a frame of 320x240 logs about 1 GB): on a
    // thread, so that a firmware that hangs is killed at the timeout.
    let reader = std::thread::spawn({
        let (marks, elf) = (marks.clone(), elf.to_path_buf());
        move || Trace::read(std::io::BufReader::with_capacity(1 << 20, log), &elf, &marks)
    });
    let status = crate::qemu::wait_qemu(&mut child, Duration::from_secs(1800));
    let trace = reader.join().map_err(|_| "QEMU log: the reader failed")?;
    let _ = std::fs::remove_file(&uart);
    let status = status?;
    let trace = trace?;
    if !status.success() {
        return Err(format!("firmware exited with {status}"));
    }
    let windows = trace.frames();
    if windows.len() != resolved.len() {
        return Err(format!(
            "{} frames traced, {} scenes held: --scene must name what the firmware holds",
            windows.len(),
            resolved.len()
        ));
    }
    // The same firmware under -icount, as `hil` runs it: each frame's cost
    // from its FrameEnd, against which the trace's count is checked. The
    // counts are deterministic; a run whose UART bytes lack a frame's cost
    // (seen twice, on the last of seven frames) is run once more, and a
    // frame still without one is an error, not a frame left unchecked.
    let mut costs: Vec<Option<u64>> = Vec::new();
    for _ in 0..2 {
        run_qemu(board, elf, &uart, Duration::from_secs(600))?;
        let bytes = std::fs::read(&uart).map_err(|e| format!("{}: {e}", uart.display()))?;
        let _ = std::fs::remove_file(&uart);
        costs.clear();
        Decoder::new(1 << 20, hilcam::link::MAX_FRAME_BYTES).push(&bytes, &mut |f| costs.push(f.end.cost));
        if costs.len() == resolved.len() && costs.iter().all(Option::is_some) {
            break;
        }
        eprintln!(
            "profile: the -icount run gave {} of {} frame costs ({} UART bytes)",
            costs.iter().flatten().count(),
            resolved.len(),
            bytes.len()
        );
    }
    if let Some(k) = (0..resolved.len()).find(|k| costs.get(*k).copied().flatten().is_none()) {
        return Err(format!(
            "{}: no frame cost from the -icount run ({} of {} frames decoded): the trace cannot be checked",
            resolved.get(k).map_or("?", |r| r.desc.name.as_str()),
            costs.len(),
            resolved.len()
        ));
    }
    let mut frames = Vec::new();
    for (k, (r, w)) in resolved.iter().zip(&windows).enumerate() {
        let px = r.desc.camera.width as u64 * r.desc.camera.height as u64;
        let per = |n: u64| n as f64 / px as f64;
        let stages: Vec<(Stage, f64)> = Stage::ALL
            .iter()
            .filter_map(|s| w.stages.get(s).map(|n| (*s, per(*n))))
            .collect();
        let total: u64 = w.stages.values().sum();
        let outside: u64 = [Stage::Link, Stage::Firmware]
            .iter()
            .filter_map(|s| w.stages.get(s))
            .sum();
        frames.push(FrameProfile {
            scene: r.desc.name.clone(),
            pixels: px,
            stages,
            render_per_pixel: per(total - outside),
            firmware_per_pixel: per(w.stages.get(&Stage::Firmware).copied().unwrap_or(0)),
            icount_per_pixel: costs.get(k).copied().flatten().map(per),
            total_per_pixel: per(total),
            functions: trace
                .top_functions(w, top)
                .into_iter()
                .map(|(f, s, n)| (f, s, per(n)))
                .collect(),
            lines: trace
                .top_lines(w, top)
                .into_iter()
                .map(|(l, n)| (l, per(n)))
                .collect(),
        });
    }
    // The trace must account for the frame's cost: its windows hold the
    // frame's instructions and nothing else's.
    for f in &frames {
        if let Some(c) = f.icount_per_pixel {
            let traced = f.render_per_pixel + f.firmware_per_pixel;
            if (traced - c).abs() > 0.01 * c {
                return Err(format!(
                    "{}: the trace counts {traced:.1} instructions a pixel, -icount {c:.1}: the profile does \
                     not account for the frame",
                    f.scene
                ));
            }
        }
    }
    let report = ProfileReport {
        board: board.machine().into(),
        frames,
    };
    outputs.write(
        "profile.json",
        &serde_json::to_vec_pretty(&report).map_err(|e| e.to_string())?,
    )?;
    outputs.write("profile.md", format!("{}\n{}", table(&report), lines_table(&report, 25)).as_bytes())?;
    outputs.commit()?;
    Ok(report)
}

/// The stages table: a row a stage, a column a frame, instructions a pixel.
pub fn table(r: &ProfileReport) -> String {
    let mut s = format!(
        "Instructions a pixel by stage on {} (QEMU's executed instructions, `host-sim profile`):\n\n| stage |",
        r.board
    );
    for f in &r.frames {
        s.push_str(&format!(" {} |", f.scene));
    }
    s.push_str("\n|---|");
    s.push_str(&"---|".repeat(r.frames.len()));
    s.push('\n');
    let cell = |v: Option<f64>| match v {
        Some(v) if v >= 0.05 => format!(" {v:.1} |"),
        Some(_) => " <0.1 |".into(),
        None => " – |".into(),
    };
    let of = |f: &FrameProfile, st: Stage| f.stages.iter().find(|(x, _)| *x == st).map(|(_, v)| *v);
    let row = |s: &mut String, name: &str, v: &dyn Fn(&FrameProfile) -> Option<f64>| {
        s.push_str(&format!("| {name} |"));
        for f in &r.frames {
            s.push_str(&cell(v(f)));
        }
        s.push('\n');
    };
    for st in Stage::ALL {
        if matches!(st, Stage::Link | Stage::Firmware) || !r.frames.iter().any(|f| of(f, st).is_some()) {
            continue;
        }
        row(&mut s, st.name(), &|f| of(f, st));
    }
    row(&mut s, "**the renderer** (the stages above)", &|f| Some(f.render_per_pixel));
    row(&mut s, "firmware (its clock reads) in the frame", &|f| of(f, Stage::Firmware));
    row(&mut s, "the frame's cost: renderer and firmware", &|f| {
        Some(f.render_per_pixel + of(f, Stage::Firmware).unwrap_or(0.0))
    });
    row(&mut s, "the frame's cost under `-icount` (`hil`)", &|f| f.icount_per_pixel);
    row(&mut s, "link (streaming: not in the frame's cost)", &|f| of(f, Stage::Link));
    s
}

/// Each frame's `n` costliest source lines (a library helper counted
/// for the line that inlined it), with the line's text where the file is
/// in the repository.
pub fn lines_table(r: &ProfileReport, n: usize) -> String {
    let root = crate::qemu::repo_root();
    let mut files: HashMap<String, Vec<String>> = HashMap::new();
    let mut s = String::new();
    for f in &r.frames {
        s.push_str(&format!(
            "Source lines of {} that cost the most on {} (instructions a pixel, the frame's window: the link's \
             streaming too):\n\n| instr./px | line | source |\n|---|---|---|\n",
            f.scene, r.board
        ));
        for (line, v) in f.lines.iter().take(n) {
            let text = line
                .rsplit_once(':')
                .and_then(|(file, k)| {
                    let k: usize = k.parse().ok()?;
                    let lines = files.entry(file.to_string()).or_insert_with(|| {
                        std::fs::read_to_string(root.join(file))
                            .map(|t| t.lines().map(str::to_string).collect())
                            .unwrap_or_default()
                    });
                    lines.get(k.checked_sub(1)?).map(|t| t.trim().replace('|', "\\|"))
                })
                .unwrap_or_default();
            s.push_str(&format!("| {v:.1} | {line} | `{text}` |\n"));
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests;
