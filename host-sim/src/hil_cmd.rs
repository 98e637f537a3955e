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
use std::process::Command;
use std::time::{Duration, Instant};

/// A QEMU board the firmware supports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Board {
    /// TI LM3S6965 evaluation board: Cortex-M3, PL011 UART0.
    Lm3s6965evb,
    /// Arm MPS2+ AN386: Cortex-M4F, CMSDK UART0.
    Mps2An386,
    /// BBC micro:bit v1: Cortex-M0 (nRF51822), 16 KiB of RAM, its UART.
    Microbit,
}

impl Board {
    /// `lm3s6965evb`, `mps2-an386` or `microbit`.
    pub fn parse(s: &str) -> Result<Board, String> {
        match s {
            "lm3s6965evb" => Ok(Board::Lm3s6965evb),
            "mps2-an386" => Ok(Board::Mps2An386),
            "microbit" => Ok(Board::Microbit),
            _ => Err(format!(
                "--board: expected lm3s6965evb, mps2-an386 or microbit, got {s:?}"
            )),
        }
    }
    /// The firmware's opt-level on this board: the profile's "s"
    /// (firmware/Cargo.toml), but 3 for the M0's one-shot firmware, whose
    /// 16-bit products and library calls opt-level "s" leaves slower
    /// (standard scene 1 454 against 1 357 instructions a pixel, over 3×
    /// the M3's); the M0's driven camera, which plans on the device, at
    /// "z" ([`Board::rustflags`] too): at "s" it no longer fits the
    /// micro:bit's 256 KiB (30 248 B over on 2026-11-27; it fitted by 28 B
    /// when the closed-form plane came). `scripts/lib.sh` builds alike.
    pub fn opt_level(self, camera: bool) -> &'static str {
        match self {
            Board::Microbit if !camera => "3",
            Board::Microbit => "z",
            _ => "s",
        }
    }

    /// Extra `rustc` flags for the firmware on this board (the target's
    /// `RUSTFLAGS`, added to `firmware/.cargo/config.toml`'s): for the M0's
    /// driven camera, LLVM's inline threshold 40 instead of opt-level "z"'s
    /// 5, so that postcard's varint encoding (`varint_u16`, `varint_u64`)
    /// is inlined where its slice's bound is known — at "z" alone it stays
    /// out of line and links a panic path (`slice_index_fail`). Its flash,
    /// RAM and round trip are in the README ("The closed loop").
    pub fn rustflags(self, camera: bool) -> Option<(&'static str, &'static str)> {
        match self {
            Board::Microbit if camera => Some((
                "CARGO_TARGET_THUMBV6M_NONE_EABI_RUSTFLAGS",
                "-C llvm-args=-inline-threshold=40",
            )),
            _ => None,
        }
    }

    /// QEMU machine name.
    pub fn machine(self) -> &'static str {
        match self {
            Board::Lm3s6965evb => "lm3s6965evb",
            Board::Mps2An386 => "mps2-an386",
            Board::Microbit => "microbit",
        }
    }
    fn cpu(self) -> &'static str {
        match self {
            Board::Lm3s6965evb => "cortex-m3",
            Board::Mps2An386 => "cortex-m4",
            Board::Microbit => "cortex-m0",
        }
    }
    /// Rust target.
    pub fn target(self) -> &'static str {
        match self {
            Board::Lm3s6965evb => "thumbv7m-none-eabi",
            Board::Mps2An386 => "thumbv7em-none-eabihf",
            Board::Microbit => "thumbv6m-none-eabi",
        }
    }
    fn feature(self) -> &'static str {
        match self {
            Board::Lm3s6965evb => "board-lm3s6965",
            Board::Mps2An386 => "board-mps2-an386",
            Board::Microbit => "board-microbit",
        }
    }
}

/// The repository root (host-sim's parent).
pub fn repo_root() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

/// The shipped scene files (`scenes/*.toml`), sorted by name: what the
/// firmware embeds by default, in its scene-id order.
pub fn shipped_scenes() -> Result<Vec<PathBuf>, String> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(repo_root().join("scenes"))
        .map_err(|e| format!("scenes/: {e}"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    Ok(v)
}

/// Builds the firmware for `board` with `scenes` embedded (all of
/// `scenes/` when empty), rendering each with every one of `variants` (the
/// planned renderer when empty); returns the ELF path.
pub fn build_firmware(board: Board, scenes: &[PathBuf], variants: &[Variant]) -> Result<BuiltElf, String> {
    build_firmware_as(board, scenes, variants, false, &[])
}

/// The capacities a firmware holding `scenes` (and sent `sent`) is built
/// with: the most materials, primitives and lights any of them has (the
/// core's `HILCAM_MAX_*`; a scene and a frame reserve each).
pub fn capacities(scenes: &[PathBuf], sent: &[PathBuf]) -> Result<[(&'static str, usize); 3], String> {
    let mut most = [
        ("HILCAM_MAX_MATERIALS", 1),
        ("HILCAM_MAX_PRIMITIVES", 1),
        ("HILCAM_MAX_LIGHTS", 1),
    ];
    for p in scenes.iter().chain(sent) {
        let r = crate::scene_file::load(p)?;
        let n = [
            r.desc.materials.len(),
            r.desc.primitives.len(),
            r.desc.lights.len(),
        ];
        for ((_, m), n) in most.iter_mut().zip(n) {
            *m = (*m).max(n);
        }
    }
    Ok(most)
}

/// [`build_firmware`], or with `camera` the driven camera (feature
/// `camera`, without the semihosting status lines, which it has no flash
/// left for on the M3) that will also be sent the scenes `sent`. Sized
/// ([`capacities`]) for the scenes it holds and is sent.
pub fn build_firmware_as(
    board: Board,
    scenes: &[PathBuf],
    variants: &[Variant],
    camera: bool,
    sent: &[PathBuf],
) -> Result<BuiltElf, String> {
    let held = if scenes.is_empty() {
        shipped_scenes()?
    } else {
        scenes.to_vec()
    };
    let caps = capacities(&held, sent)?;
    let features = if camera {
        // Status lines: the camera reports its stack peak after each frame.
        format!("{},camera,mix32,sensor,status", board.feature())
    } else {
        board.feature().to_string()
    };
    let dir = repo_root().join("firmware");
    // Where cargo puts it: CARGO_TARGET_DIR (relative to firmware/, where
    // cargo runs) if set, else firmware/target.
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| dir.join("target"), |t| dir.join(t));
    let list: Vec<String> = scenes
        .iter()
        .map(|p| {
            std::fs::canonicalize(p)
                .map(|p| p.display().to_string())
                .map_err(|e| format!("{}: {e}", p.display()))
        })
        .collect::<Result<_, _>>()?;
    // Every build writes the same ELF: held from the build to the copy, the
    // lock keeps a command running alongside (another `hil`, a `costfit`
    // batch, a `drive`) from replacing it before this one has its own.
    std::fs::create_dir_all(&target).map_err(|e| format!("{}: {e}", target.display()))?;
    let lock_path = target.join("hilcam-firmware.lock");
    let lock = std::fs::File::create(&lock_path).map_err(|e| format!("{}: {e}", lock_path.display()))?;
    lock.lock().map_err(|e| format!("{}: {e}", lock_path.display()))?;
    let out = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .current_dir(&dir)
        .env("CARGO_PROFILE_RELEASE_OPT_LEVEL", board.opt_level(camera))
        .envs(board.rustflags(camera))
        .envs(caps.iter().map(|(k, v)| (k, v.to_string())))
        .env("HILCAM_SCENES", list.join("\n"))
        .env(
            "HILCAM_VARIANTS",
            variants.iter().map(Variant::name).collect::<Vec<_>>().join(","),
        )
        .args([
            "build",
            "--release",
            "--features",
            &features,
            "--target",
            board.target(),
        ])
        .args(camera.then_some("--no-default-features"))
        .output()
        .map_err(|e| format!("cargo build (firmware): {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "firmware build failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let built = BuiltElf::copy(&target.join(board.target()).join("release").join("hilcam-firmware"));
    // Released once this command has its copy.
    drop(lock);
    built
}

/// A firmware ELF built for one command: a private copy of what cargo
/// wrote, removed when dropped, so that QEMU runs the firmware this command
/// built even if another builds one alongside.
#[derive(Debug)]
pub struct BuiltElf(PathBuf);

impl BuiltElf {
    /// Copies `built` to `built.<pid>.<n>` beside it.
    fn copy(built: &Path) -> Result<BuiltElf, String> {
        static COPIES: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = COPIES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let mut name = built.as_os_str().to_owned();
        name.push(format!(".{}.{n}", std::process::id()));
        let copy = PathBuf::from(name);
        std::fs::copy(built, &copy).map_err(|e| format!("{} → {}: {e}", built.display(), copy.display()))?;
        Ok(BuiltElf(copy))
    }
}

impl std::ops::Deref for BuiltElf {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for BuiltElf {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// Flash and static RAM of an ELF, bytes, from its sections: flash holds
/// the vector table, code, read-only data and the initial values of `.data`;
/// RAM holds `.data`, `.bss` and `.uninit`.
pub fn elf_sizes(elf: &Path) -> Result<(u64, u64), String> {
    use object::{Object, ObjectSection};
    let data = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*data).map_err(|e| format!("{}: {e}", elf.display()))?;
    let (mut flash, mut ram) = (0, 0);
    for s in file.sections() {
        let name = s.name().unwrap_or("");
        match name {
            ".vector_table" | ".text" | ".rodata" => flash += s.size(),
            ".data" => {
                flash += s.size();
                ram += s.size();
            }
            ".bss" | ".uninit" => ram += s.size(),
            _ => {}
        }
    }
    Ok((flash, ram))
}

/// The symbols of `core::panicking` an ELF holds: its panic paths (0 when
/// nothing linked into it can panic).
pub fn elf_panic_symbols(elf: &Path) -> Result<Vec<String>, String> {
    use object::{Object, ObjectSymbol};
    let data = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*data).map_err(|e| format!("{}: {e}", elf.display()))?;
    Ok(file
        .symbols()
        .filter_map(|s| s.name().ok().map(str::to_string))
        // Legacy mangling: `_ZN4core9panicking…`; v0: `…4core…9panicking…`.
        .filter(|n| n.contains("9panicking"))
        .collect())
}

/// QEMU's binary, if installed.
pub fn qemu() -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|p| p.join("qemu-system-arm"))
            .find(|p| p.is_file())
    })
}

/// QEMU running `elf` on `board` under `-icount shift=7` (the firmware
/// converts SysTick ticks to instructions with that shift), with UART0 on
/// `serial` (QEMU's `-serial` syntax), semihosting on.
pub fn spawn_qemu(board: Board, elf: &Path, serial: &str) -> Result<std::process::Child, String> {
    spawn_qemu_with(board, elf, serial, &[], true)
}

/// [`spawn_qemu`] with `extra` arguments, and without `-icount` unless
/// `icount` (`host-sim profile` logs the executed blocks, which `-icount`
/// would rewind and log twice).
pub fn spawn_qemu_with(
    board: Board,
    elf: &Path,
    serial: &str,
    extra: &[&str],
    icount: bool,
) -> Result<std::process::Child, String> {
    let qemu = qemu().ok_or("qemu-system-arm is not installed (apt-get install qemu-system-arm)")?;
    Command::new(qemu)
        .args(["-cpu", board.cpu(), "-machine", board.machine()])
        .args(["-display", "none", "-monitor", "none"])
        .args(["-serial", serial])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(if icount {
            &["-icount", "shift=7,align=off,sleep=off"][..]
        } else {
            &[]
        })
        .args(extra)
        .arg("-kernel")
        .arg(elf)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .map_err(|e| format!("qemu: {e}"))
}

/// Waits for QEMU to exit, killing it after `timeout`.
pub fn wait_qemu(child: &mut std::process::Child, timeout: Duration) -> Result<std::process::ExitStatus, String> {
    let t = Instant::now();
    loop {
        match child.try_wait().map_err(|e| format!("qemu: {e}"))? {
            Some(status) => return Ok(status),
            None if t.elapsed() > timeout => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!("qemu did not finish within {timeout:?}"));
            }
            None => std::thread::sleep(Duration::from_millis(20)),
        }
    }
}

/// Runs the ELF in QEMU ([`spawn_qemu`]); UART0 bytes go to `uart`.
/// Returns the semihosting text.
pub fn run_qemu(board: Board, elf: &Path, uart: &Path, timeout: Duration) -> Result<String, String> {
    let mut child = spawn_qemu(board, elf, &format!("file:{}", uart.display()))?;
    let (stdout, stderr) = (drain(child.stdout.take()), drain(child.stderr.take()));
    let status = wait_qemu(&mut child, timeout);
    // QEMU has exited (or been killed): the pipes are closed.
    let text = String::from_utf8_lossy(&stdout.join().unwrap_or_default()).to_string();
    let stderr = stderr.join().unwrap_or_default();
    let status = status?;
    if !status.success() {
        return Err(format!(
            "firmware exited with {status}:\n{text}{}",
            String::from_utf8_lossy(&stderr)
        ));
    }
    Ok(text)
}

/// Reads a child's pipe to its end on a thread, as the child writes it: a
/// pipe holds 64 KiB, and a firmware that wrote more semihosting text than
/// that before anyone read it would stall until [`wait_qemu`]'s timeout.
pub fn drain(pipe: Option<impl std::io::Read + Send + 'static>) -> std::thread::JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(mut p) = pipe {
            let _ = p.read_to_end(&mut bytes);
        }
        bytes
    })
}

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
        shipped_scenes()?
    } else {
        scenes.to_vec()
    };
    let resolved: Vec<Resolved> = list.iter().map(|p| load(p)).collect::<Result<_, _>>()?;
    let mut outputs = crate::output::Outputs::prepare(out)?;
    let built;
    let elf: &Path = match &elf {
        Some(e) => e,
        None => {
            built = build_firmware(board, scenes, &variants)?;
            &built
        }
    };
    let (flash, ram) = elf_sizes(elf)?;
    let uart = out.join("uart.bin");
    let _ = std::fs::remove_file(&uart);
    let t = Instant::now();
    let text = run_qemu(board, elf, &uart, Duration::from_secs(600))?;
    let qemu_seconds = t.elapsed().as_secs_f64();
    outputs.write("semihosting.txt", text.as_bytes())?;
    let bytes = std::fs::read(&uart).map_err(|e| format!("{}: {e}", uart.display()))?;
    let mut dec = Decoder::new(1 << 20, 1 << 24);
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
