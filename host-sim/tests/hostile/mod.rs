//! Hostile input against the `host-sim` binary: one case per class of
//! failure a test bench cannot afford (silent wrong output, crashes, lost
//! frames, partial files, unbounded memory, errors that name nothing).
//! Every case asserts the exit status, that the message names the file and
//! the field (or flag), that no partial output exists, that nothing
//! panicked, and where it applies the peak memory, measured from /proc.

use hilcam::link::{Encoder, FrameStart, WireFormat, PROTOCOL_VERSION};
use host_sim::link::sim::{send_frames, Recorder};
use serialport::SerialPort;
use std::io::Write;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod camera;
mod flags;
mod frame;
mod outputs;
mod qemu;
mod receive;
mod render;
mod replay;
mod scene_files;
mod stream;
mod throughput;

const BIN: &str = env!("CARGO_BIN_EXE_host-sim");

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn standard() -> String {
    std::fs::read_to_string(repo().join("scenes/standard.toml")).expect("standard scene")
}

/// A fresh directory for one test.
fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("hostile").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// What a run of the binary did.
struct Ran {
    code: Option<i32>,
    stdout: String,
    stderr: String,
    /// Peak resident memory, KiB ([`reap`]).
    max_rss_kib: i64,
}

impl Ran {
    fn failed_cleanly(&self) -> bool {
        self.code == Some(1) && !self.stderr.contains("panicked")
    }
}

/// Runs `host-sim args…`, output to files (no pipe to fill), and measures
/// its peak memory ([`reap`]). `setup` runs in the child
/// before exec (resource limits).
fn run_with(args: &[&str], setup: Option<fn() -> std::io::Result<()>>) -> Ran {
    let dir = scratch(&format!(
        "run-{}",
        std::thread::current().name().unwrap_or("x").replace("::", "-")
    ));
    let (o, e) = (dir.join("stdout"), dir.join("stderr"));
    let mut cmd = Command::new(BIN);
    cmd.args(args)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&o).expect("stdout file"))
        .stderr(std::fs::File::create(&e).expect("stderr file"));
    if let Some(f) = setup {
        // SAFETY: `f` only calls async-signal-safe functions (setrlimit,
        // signal).
        unsafe {
            cmd.pre_exec(f);
        }
    }
    finish(cmd.spawn().expect("spawns"), &dir)
}

fn run(args: &[&str]) -> Ran {
    run_with(args, None)
}

/// Waits for the child, polling its peak resident memory (`VmHWM` in
/// /proc: the high-water mark of its own image since exec; `wait4`'s
/// `ru_maxrss` would include this test process's memory, which a spawned
/// child shares until exec). Returns (exit code, None if a signal ended
/// it; peak RSS in KiB, sampled every 2 ms).
fn reap(child: std::process::Child) -> (Option<i32>, i64) {
    let pid = child.id() as libc::pid_t;
    let status_path = format!("/proc/{pid}/status");
    let mut peak = 0i64;
    let mut status = 0;
    loop {
        if let Ok(s) = std::fs::read_to_string(&status_path) {
            if let Some(kb) = s
                .lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<i64>().ok())
            {
                peak = peak.max(kb);
            }
        }
        // SAFETY: pid is our child, not yet reaped; the pointer is valid.
        let r = unsafe { libc::waitpid(pid, &mut status, libc::WNOHANG) };
        if r == pid {
            break;
        }
        assert_eq!(r, 0, "waitpid");
        std::thread::sleep(Duration::from_millis(2));
    }
    std::mem::forget(child); // reaped here, not by std
    let code = libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status));
    (code, peak)
}

/// Waits (up to 30 s) until process `pid` has `path` open, so that what a
/// test writes to a pty is not flushed by the port's opening.
fn wait_open(pid: u32, path: &str) {
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(30) {
        let open = std::fs::read_dir(format!("/proc/{pid}/fd"))
            .map(|d| {
                d.filter_map(|e| e.ok())
                    .any(|e| std::fs::read_link(e.path()).is_ok_and(|l| l == Path::new(path)))
            })
            .unwrap_or(false);
        if open {
            // The port is configured right after it is opened.
            std::thread::sleep(Duration::from_millis(100));
            return;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    panic!("{path} never opened by {pid}");
}

/// Every entry in `dir` (hidden ones too), or none if it does not exist.
fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
                .filter(|n| n != host_sim::output::MANIFEST)
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

fn write_scene(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write scene");
    p
}

/// `render` of `text` must fail naming the file and every one of `fields`,
/// writing nothing; what ran, for a test's further checks.
fn refused(test: &str, text: &str, fields: &[&str]) -> Ran {
    let dir = scratch(test);
    let scene = write_scene(&dir, "scene.toml", text);
    let out = dir.join("out");
    let r = run(&[
        "render",
        "--scene",
        scene.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(
        r.failed_cleanly(),
        "{test}: exit {:?}: {}{}",
        r.code,
        r.stdout,
        r.stderr
    );
    assert!(
        r.stderr.contains("scene.toml"),
        "{test}: the file is not named: {}",
        r.stderr
    );
    for f in fields {
        assert!(r.stderr.contains(f), "{test}: {f} is not named: {}", r.stderr);
    }
    assert!(
        !out.exists(),
        "{test}: something was written: {:?}",
        entries(&out)
    );
    r
}

/// `host-sim receive --device PTY --out DIR/out EXTRA…` started on a fresh
/// pty pair, once it has the port open: (the child, the pty's master side
/// to write to, its slave side, the test's directory).
fn start_receive(
    test: &str,
    extra: &[&str],
) -> (
    std::process::Child,
    serialport::TTYPort,
    serialport::TTYPort,
    PathBuf,
) {
    let dir = scratch(test);
    let (master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("pty name");
    let child = Command::new(BIN)
        .args(["receive", "--device", &path, "--out"])
        .arg(dir.join("out"))
        .args(extra)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(dir.join("stdout")).expect("file"))
        .stderr(std::fs::File::create(dir.join("stderr")).expect("file"))
        .spawn()
        .expect("spawns");
    wait_open(child.id(), &path);
    (child, master, slave, dir)
}

/// Waits for a child whose stdout and stderr go to files in `dir`.
fn finish(child: std::process::Child, dir: &Path) -> Ran {
    let (code, rss) = reap(child);
    Ran {
        code,
        stdout: std::fs::read_to_string(dir.join("stdout")).unwrap_or_default(),
        stderr: std::fs::read_to_string(dir.join("stderr")).unwrap_or_default(),
        max_rss_kib: rss,
    }
}

/// `receive` on a pty: the sender writes `stream` and hangs up (after
/// `hold`, default 300 ms); returns the run and the output dir.
fn receive(test: &str, stream: Vec<u8>, extra: &[&str], hold: Option<Duration>) -> (Ran, PathBuf) {
    let (child, mut master, slave, dir) = start_receive(test, extra);
    master.write_all(&stream).expect("write");
    master.flush().expect("flush");
    std::thread::sleep(hold.unwrap_or(Duration::from_millis(300)));
    drop(master);
    drop(slave);
    (finish(child, &dir), dir.join("out"))
}

fn header(format: WireFormat) -> FrameStart {
    FrameStart {
        version: PROTOCOL_VERSION,
        frame_id: 0,
        width: 16,
        height: 4,
        format,
        scene_id: 1,
        exposure: 1 << 32,
        truth: Default::default(),
    }
}

/// A 640×480 render of the standard scene (about 60 KB of PNGs).
fn vga_scene(dir: &Path) -> PathBuf {
    let s = standard()
        .replacen("width = 160", "width = 640", 1)
        .replacen("height = 120", "height = 480", 1)
        .replacen("pitch = 12e-6", "pitch = 3e-6", 1);
    write_scene(dir, "vga.toml", &s)
}

/// The peak memory of `command --scene S --out O` for the standard scene
/// 2048 pixels wide and 64, then 2048, lines high; each run must write
/// exactly `outputs`.
fn peaks_by_height(command: &str, outputs: &[&str]) -> (i64, i64) {
    let dir = scratch(&format!("{command}-memory"));
    let peak = |h: u32| {
        let s = standard()
            .replacen("width = 160", "width = 2048", 1)
            .replacen("height = 120", &format!("height = {h}"), 1)
            .replacen("pitch = 12e-6", "pitch = 1e-6", 1);
        let scene = write_scene(&dir, &format!("h{h}.toml"), &s);
        let out = dir.join(format!("out{h}"));
        let r = run(&[
            command,
            "--scene",
            scene.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        assert_eq!(r.code, Some(0), "{}", r.stderr);
        assert_eq!(entries(&out), outputs);
        r.max_rss_kib
    };
    let (short, tall) = (peak(64), peak(2048));
    eprintln!("{command} peak RSS: 2048x64 {short} KiB, 2048x2048 {tall} KiB");
    (short, tall)
}
