//! `host-sim hil`: the firmware in QEMU. Builds (or is given) the firmware
//! ELF, runs it in qemu-system-arm with UART0 on a binary-clean serial file
//! and `-icount`, decodes the frames, and compares each to the host-side core
//! render of the same scene (they must be byte-identical) and to the f64
//! reference.

use crate::frame_png::encode_png;
use crate::harness::{decode_all, Collect};
use crate::link::decoder::Decoder;
use crate::reference::render::{RefFrame, RefScene};
use crate::scene_file::{load, Resolved};
use crate::variant::{FrameUser, Variant};
use hilcam::planner::{Budget, Plan};
use hilcam::render::Frame;
use hilcam::num::scalar::Scalar;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::qemu::{build_firmware, shipped_scenes, Board};
use crate::qemu::{elf_panic_symbols, elf_sizes, run_qemu};

/// One frame's result.
#[derive(Clone, Debug, Serialize)]
pub struct HilFrame {
    /// Scene name.
    pub scene: String,
    /// Rendering variant (`i32f32-planned`: the planned renderer).
    pub variant: String,
    /// Size.
    pub width: u16,
    /// Size.
    pub height: u16,
    /// Format.
    pub format: String,
    /// Byte-identical to the host-side core render.
    pub bit_exact: bool,
    /// Instructions the frame cost on the device (QEMU `-icount`; not cycles).
    pub instructions: Option<u64>,
    /// Instructions per pixel.
    pub instructions_per_pixel: Option<f64>,
    /// Largest |firmware − reference| in LSB.
    pub max_abs_lsb: u32,
    /// Fraction of pixels equal to the reference.
    pub exact_fraction: f64,
}

/// `hil.json`.
#[derive(Clone, Debug, Serialize)]
pub struct HilReport {
    /// Board.
    pub board: String,
    /// Frames received.
    pub frames: Vec<HilFrame>,
    /// Every frame received and byte-identical to the host render.
    pub bit_exact: bool,
    /// Instructions per pixel of the standard scene (if it was rendered).
    pub instructions_per_pixel: Option<f64>,
    /// Static RAM (.data + .bss + .uninit), bytes.
    pub ram_bytes: u64,
    /// Deepest stack use, bytes (the firmware paints its free RAM at start
    /// and reports the lowest word overwritten).
    pub stack_peak_bytes: Option<u64>,
    /// `ram_bytes + stack_peak_bytes`: all the RAM the firmware used.
    pub ram_peak_bytes: Option<u64>,
    /// Flash (vector table, code, read-only data, .data image), bytes.
    pub flash_bytes: u64,
    /// The ELF's `core::panicking` symbols (its panic paths): none in the
    /// default firmware.
    pub panic_symbols: Vec<String>,
    /// Where the flash goes: the largest symbols, `.text` by source file.
    pub flash_use: crate::profile::FlashUse,
    /// Largest |firmware − reference| over all frames, LSB.
    pub max_abs_lsb: u32,
    /// Wall-clock seconds QEMU ran.
    pub qemu_seconds: f64,
}

/// The host-side core render of a frame: its bytes.
struct HostBytes;

impl FrameUser for HostBytes {
    /// Pixels, and the flags the wire carries ([`crate::link::decoder::wire_flags`]).
    type Out = (Vec<u8>, Vec<u8>);
    fn use_frame<S: Scalar>(self, _: &Plan, _: &Frame<S>, core: Collect) -> Self::Out {
        let flags = crate::link::decoder::wire_flags(&core.flags);
        (core.pixels, flags)
    }
}

/// Runs the firmware on `board` and checks its frames (the planned
/// renderer, or each of `variants`). Writes the frames as PNGs into `out`.
pub fn hil(board: Board, elf: Option<PathBuf>, scenes: &[PathBuf], out: &Path) -> Result<HilReport, String> {
    hil_variants(board, elf, scenes, &[], out)
}

/// [`hil`] with every scene rendered with each of `variants` (the planned
/// renderer when empty). Frame `k` is scene `k / n`, variant `k % n`.
pub fn hil_variants(
    board: Board,
    elf: Option<PathBuf>,
    scenes: &[PathBuf],
    variants: &[Variant],
    out: &Path,
) -> Result<HilReport, String> {
    let variants: Vec<Variant> = if variants.is_empty() {
        vec![Variant::PLANNED]
    } else {
        variants.to_vec()
    };
    let list: Vec<PathBuf> = if scenes.is_empty() {
        board.held(shipped_scenes()?)
    } else {
        scenes.to_vec()
    };
    let resolved: Vec<Resolved> = list.iter().map(|p| load(p)).collect::<Result<_, _>>()?;
    let mut outputs = crate::output::Outputs::prepare(out)?;
    let built;
    let elf: &Path = match &elf {
        Some(e) => e,
        None => {
            built = build_firmware(board, &list, &variants)?;
            &built
        }
    };
    crate::qemu::check_elf(board, elf)?;
    let (flash, ram) = elf_sizes(elf)?;
    let uart = outputs.scratch("uart.bin");
    let t = Instant::now();
    let text = run_qemu(board, elf, &uart, Duration::from_secs(600))?;
    let qemu_seconds = t.elapsed().as_secs_f64();
    outputs.write("semihosting.txt", text.as_bytes())?;
    let bytes = std::fs::read(&uart).map_err(|e| format!("{}: {e}", uart.display()))?;
    let mut dec = Decoder::new(1 << 20, hilcam::link::MAX_FRAME_BYTES);
    let mut got = Vec::new();
    dec.push(&bytes, &mut |f| got.push(f));
    let mut frames = Vec::new();
    let nv = variants.len();
    let mut all_exact = got.len() == resolved.len() * nv;
    let mut ipp_standard = None;
    let mut references: Vec<Option<RefFrame>> = vec![None; resolved.len()];
    for f in &got {
        let k = f.start.frame_id as usize;
        let (Some(r), Some(v), Some(cached)) = (
            resolved.get(f.start.scene_id as usize),
            variants.get(k % nv),
            references.get_mut(f.start.scene_id as usize),
        ) else {
            all_exact = false;
            continue;
        };
        if k / nv != f.start.scene_id as usize {
            all_exact = false;
            continue;
        }
        // Pixels and out-of-field flags, byte for byte.
        let (host, flags) = v.render_frame(r, &Budget::default(), f.start.frame_id, HostBytes)?;
        let exact = host == f.pixels
            && flags == f.flags
            && r.desc.camera.width == f.start.width
            && r.desc.camera.height == f.start.height;
        all_exact &= exact;
        // The reference with the variant's sample pattern and, where the
        // scene has noise, the frame's id (rendered anew for each frame);
        // otherwise the scene's, rendered once.
        let own;
        let pattern = v.pattern(r);
        let reference =
            if r.desc.noise.is_some() || pattern != crate::reference::sampling::Pattern::of_scene(r) {
                let mut rs = RefScene::new(r).with_pattern(pattern);
                rs.frame_id = f.start.frame_id;
                own = rs.render();
                &own
            } else {
                cached.get_or_insert_with(|| RefScene::new(r).render())
            };
        let (mut max, mut same) = (0u32, 0usize);
        // Zipped, so a frame of the wrong size cannot index past the
        // reference (it is already not bit-exact).
        for (dn, rf) in decode_all(r.format, &f.pixels).iter().zip(&reference.dn) {
            let d = (0..r.format.channels())
                .map(|c| dn[c].abs_diff(rf[c]))
                .max()
                .unwrap_or(0);
            max = max.max(d);
            same += (d == 0) as usize;
        }
        let pixels = f.start.width as f64 * f.start.height as f64;
        let ipp = f.end.cost.map(|c| c as f64 / pixels);
        if r.desc.name == "standard" && ipp_standard.is_none() {
            ipp_standard = ipp;
        }
        let png = encode_png(
            r.format,
            f.start.width as usize,
            f.start.height as usize,
            &f.pixels,
        )?;
        let file = if nv == 1 {
            format!("{}.png", r.desc.name)
        } else {
            format!("{}-{}.png", r.desc.name, v.name())
        };
        outputs.write(&file, &png)?;
        frames.push(HilFrame {
            scene: r.desc.name.clone(),
            variant: v.name(),
            width: f.start.width,
            height: f.start.height,
            format: r.format.name().into(),
            bit_exact: exact,
            instructions: f.end.cost,
            instructions_per_pixel: ipp,
            max_abs_lsb: max,
            exact_fraction: same as f64 / pixels,
        });
    }
    let stack = text
        .lines()
        .find_map(|l| l.strip_prefix("stack_peak_bytes "))
        .and_then(|v| v.trim().parse::<u64>().ok());
    let report = HilReport {
        board: board.machine().into(),
        stack_peak_bytes: stack,
        ram_peak_bytes: stack.map(|s| s + ram),
        bit_exact: all_exact,
        instructions_per_pixel: ipp_standard,
        ram_bytes: ram,
        flash_bytes: flash,
        panic_symbols: elf_panic_symbols(elf)?,
        flash_use: crate::profile::flash_use(elf, 20)?,
        max_abs_lsb: frames.iter().map(|f| f.max_abs_lsb).max().unwrap_or(0),
        qemu_seconds,
        frames,
    };
    let json = serde_json::to_vec_pretty(&report).map_err(|e| e.to_string())?;
    outputs.write("hil.json", &json)?;
    outputs.commit()?;
    Ok(report)
}
