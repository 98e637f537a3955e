//! The QEMU runner: the boards (`firmware/boards.toml`), the firmware
//! built for one with the scenes it holds, its ELF's sizes, and QEMU
//! started on it with UART0 on a file or a pipe.

use crate::variant::Variant;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

pub use crate::boards::Board;

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
    // A camera built without cast shadows (boards.toml camera_features)
    // holds the scenes it is sent alone: every shipped scene asks for them.
    let unshadowed = camera && !board.camera_features().split(',').any(|f| f == "shadows");
    if unshadowed {
        // Refused here, naming the key, rather than by the camera at boot.
        for p in sent.iter().chain(scenes) {
            if crate::scene_file::load(p)?.desc.environment.shadows {
                return Err(format!(
                    "{}: environment.shadows: the {} driven camera is built without cast shadows \
                     (boards.toml camera_features); set environment.shadows = false",
                    p.display(),
                    board.machine()
                ));
            }
        }
    }
    let held = match (scenes.is_empty(), unshadowed) {
        (true, true) => sent.to_vec(),
        (true, false) => board.held(shipped_scenes()?),
        (false, _) => scenes.to_vec(),
    };
    let caps = capacities(&held, sent)?;
    // The driven camera with status lines (it reports its stack peak after
    // each frame); the one-shot firmware with its default features.
    let features = camera.then_some(["--no-default-features", "--features", board.camera_features()]);
    let dir = repo_root().join("firmware");
    // Where cargo puts it: CARGO_TARGET_DIR (relative to firmware/, where
    // cargo runs) if set, else firmware/target.
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| dir.join("target"), |t| dir.join(t));
    // (None given: the shipped scenes the board holds, as the build script
    // takes an empty list; a camera without shadows, the scenes it is
    // sent.)
    let listed = if unshadowed { &held[..] } else { scenes };
    let list: Vec<String> = listed
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
        .env("HILCAM_BOARD", board.machine())
        .args(["build", "--release", "--target", board.target()])
        .args(features.into_iter().flatten())
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

/// Checks, before QEMU runs it, that `elf` is a firmware built for
/// `board`: a 32-bit ARM ELF whose `HILCAM_BOARD` symbol (written by the
/// firmware's build script) names the board. An ELF for another board
/// would run with its UART at an address the machine does not have and
/// send nothing; anything else QEMU would refuse with a register dump.
pub fn check_elf(board: Board, elf: &Path) -> Result<(), String> {
    use object::{Object, ObjectSection, ObjectSymbol};
    let data = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*data).map_err(|e| format!("{}: not an ELF file ({e})", elf.display()))?;
    if file.architecture() != object::Architecture::Arm || file.is_64() {
        return Err(format!(
            "{}: not a Cortex-M firmware (an ELF for {:?}); --elf takes a firmware built for --board {}",
            elf.display(),
            file.architecture(),
            board.machine()
        ));
    }
    let symbol = file.symbols().find(|s| s.name() == Ok("HILCAM_BOARD")).ok_or_else(|| {
        format!(
            "{}: not a hilcam firmware (no HILCAM_BOARD symbol naming its board)",
            elf.display()
        )
    })?;
    let built_for = symbol
        .section_index()
        .and_then(|i| file.section_by_index(i).ok())
        .and_then(|s| s.data_range(symbol.address(), symbol.size()).ok().flatten())
        .map(String::from_utf8_lossy)
        .ok_or_else(|| format!("{}: its HILCAM_BOARD symbol holds no name", elf.display()))?;
    if built_for != board.machine() {
        return Err(format!(
            "{}: built for board {built_for}, not --board {} (its UART would not answer on this machine)",
            elf.display(),
            board.machine()
        ));
    }
    Ok(())
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
    check_elf(board, elf)?;
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
        // QEMU's first words say why (a lockup, a fault); its register
        // dump after them is for whoever debugs the firmware.
        let stderr = String::from_utf8_lossy(&stderr);
        let why: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).take(3).collect();
        return Err(format!(
            "{}: the firmware stopped on {} ({status}): {}{}",
            elf.display(),
            board.machine(),
            why.join(" / "),
            if text.is_empty() { String::new() } else { format!("\n{text}") }
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

