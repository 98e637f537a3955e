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
/// writing nothing.
fn refused(test: &str, text: &str, fields: &[&str]) {
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
}

// ---------------------------------------------------------------------------
// Silent wrong output

/// Arrays longer or shorter than the field holds are errors naming the
/// field (OpenCV's five distortion coefficients used to render with two).
#[test]
fn arrays_of_the_wrong_length_are_refused_naming_the_field() {
    let s = standard();
    let cases: [(&str, &str, &str, &str); 8] = [
        (
            "opencv-distortion",
            "distortion = [0.15, 0.05]",
            "distortion = [0.15, 0.05, 0.001, 0.002, 0.01]",
            "distortion",
        ),
        (
            "short-distortion",
            "distortion = [0.15, 0.05]",
            "distortion = [0.15]",
            "distortion",
        ),
        (
            "eye-4",
            "eye = [0.0, 1.2, -3.0]",
            "eye = [0.0, 1.2, -3.0, 77]",
            "eye",
        ),
        (
            "target-2",
            "target = [0.0, 0.4, 0.0]",
            "target = [0.0, 0.4]",
            "target",
        ),
        ("pitch-3", "pitch = 12e-6", "pitch = [12e-6, 12e-6, 1.0]", "pitch"),
        (
            "light-position-junk",
            "position = [2.0, 3.0, -2.0]",
            "position = [2.0, 3.0, -2.0, 5.0]",
            "position",
        ),
        (
            "colour-4",
            "ambient = 0.2",
            "ambient = [0.2, 0.2, 0.2, 0.2]",
            "ambient",
        ),
        (
            "normal-4",
            "normal = [0.0, 1.0, 0.0]",
            "normal = [0.0, 1.0, 0.0, 0.0]",
            "normal",
        ),
    ];
    for (name, from, to, field) in cases {
        assert!(s.contains(from), "{name}: standard.toml lacks {from}");
        refused(name, &s.replacen(from, to, 1), &[field, "exactly"]);
    }
    // A rotation matrix with a fourth column.
    let pose = s.lines().find(|l| l.starts_with("pose = ")).expect("pose");
    refused(
        "rotation-3x4",
        &s.replace(
            pose,
            "pose = { position = [0.0, 1.0, -3.0], rotation = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] }",
        ),
        &["rotation", "exactly 3 numbers in a row"],
    );
}

/// Two materials of one name: an error naming both, not the first winning.
#[test]
fn duplicate_material_names_are_refused_naming_both() {
    let s = standard();
    let dup = s.replacen(
        "[[materials]]",
        "[[materials]]\nname = \"floor\"\nalbedo = 0.9\n\n[[materials]]",
        1,
    );
    refused(
        "duplicate-material",
        &dup,
        &["materials[1].name", "materials[0]", "\"floor\""],
    );
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

/// Fewer frames than asked for: the exit status says so, and the frames
/// that did arrive are on disk (written as they came), with receive.json.
#[test]
fn receive_fails_when_frames_are_missing_and_keeps_those_that_came() {
    let start = header(WireFormat::Gray8);
    let sent = send_frames(&[9u8; 64], start, 2, None).expect("encodes");
    let (r, out) = receive(
        "receive-missing",
        sent.stream,
        &["--frames", "3", "--timeout", "1"],
        None,
    );
    assert!(r.failed_cleanly(), "exit {:?}: {}", r.code, r.stderr);
    assert!(r.stderr.contains("2 of 3 frames"), "{}", r.stderr);
    assert_eq!(
        entries(&out),
        ["frame-00000.png", "frame-00001.png", "receive.json"]
    );
    let json = std::fs::read_to_string(out.join("receive.json")).expect("receive.json");
    // The pty reports the hang-up as silence or as EIO, by timing.
    assert!(
        json.contains("\"received\": 2") && (json.contains("hangup") || json.contains("idle_timeout")),
        "{json}"
    );
}

/// A corrupted frame among intact ones (a flipped bit, a truncated chunk,
/// garbage between frames): every intact frame is written, no corrupted
/// one, and the status says one is missing.
#[test]
fn receive_keeps_every_intact_frame_of_a_damaged_stream() {
    let start = header(WireFormat::Gray8);
    let base: Vec<u8> = (0..64).map(|i| i as u8).collect();
    let sent = send_frames(&base, start, 6, None).expect("encodes");
    let mut stream = Vec::new();
    for (id, (a, b), _) in &sent.frames {
        let mut f = sent.stream[*a..*b].to_vec();
        match id {
            1 => f[20] ^= 0x10,                          // a flipped bit
            3 => f.truncate(f.len() - 9),                // the end cut short
            4 => stream.extend_from_slice(&[0x55; 300]), // garbage before it
            _ => {}
        }
        stream.extend_from_slice(&f);
    }
    let (r, out) = receive(
        "receive-damaged",
        stream,
        &["--frames", "6", "--timeout", "1"],
        None,
    );
    assert!(r.failed_cleanly(), "exit {:?}: {}", r.code, r.stderr);
    // Frames 1 (bad CRC) and 3 (no end) are dropped; the garbage and
    // frame 3's tail end at frame 4's opening delimiter, and decoding
    // resumes there.
    assert!(r.stderr.contains("4 of 6 frames"), "{}", r.stderr);
    assert_eq!(
        entries(&out),
        [
            "frame-00000.png",
            "frame-00002.png",
            "frame-00004.png",
            "frame-00005.png",
            "receive.json"
        ]
    );
}

/// Odd scene paths: a directory, an empty file, bytes that are not UTF-8,
/// a file that does not exist: each an error naming the path.
#[test]
fn odd_scene_paths_are_errors_naming_them() {
    let dir = scratch("odd-paths");
    let empty = write_scene(&dir, "empty.toml", "");
    let binary = dir.join("binary.toml");
    std::fs::write(&binary, [0xff, 0xfe, 0x00, 0x80]).expect("write");
    let out = dir.join("out");
    for (scene, what) in [
        (dir.to_str().expect("utf-8").to_string(), "Is a directory"),
        (empty.to_str().expect("utf-8").to_string(), "missing"),
        (binary.to_str().expect("utf-8").to_string(), "not UTF-8"),
        (
            dir.join("nope.toml").to_str().expect("utf-8").to_string(),
            "No such file",
        ),
    ] {
        let r = run(&["render", "--scene", &scene, "--out", out.to_str().expect("utf-8")]);
        assert!(r.failed_cleanly(), "{scene}: exit {:?}: {}", r.code, r.stderr);
        assert!(
            r.stderr.contains(&scene) && r.stderr.contains(what),
            "{scene}: {}",
            r.stderr
        );
        assert!(!out.exists());
    }
}

/// Frames that share an id (a sender that restarted) each get a file.
#[test]
fn repeated_frame_ids_do_not_overwrite_each_other() {
    let start = header(WireFormat::Gray8);
    let mut stream = Vec::new();
    for k in 0..3u8 {
        stream.extend(send_frames(&[k; 64], start, 1, None).expect("encodes").stream);
    }
    let (r, out) = receive("receive-repeated-ids", stream, &["--frames", "3"], None);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert_eq!(
        entries(&out),
        [
            "frame-00000-2.png",
            "frame-00000-3.png",
            "frame-00000.png",
            "receive.json"
        ]
    );
}

/// A Gray16 frame with `bits` outside 9–16 is refused by the decoder, not
/// written as garbage (or a panic in the PNG writer's shift).
#[test]
fn gray16_bits_outside_9_to_16_are_refused() {
    for bits in [0u8, 8, 17, 255] {
        let start = header(WireFormat::Gray16 { bits });
        let mut enc = Encoder::<Recorder, 64>::new(Recorder::default()).expect("encoder");
        enc.begin_frame(start).expect("begin");
        for _ in 0..4 {
            enc.push_line(&[0xff; 32]).expect("line");
        }
        enc.end_frame(None).expect("end");
        let bytes = enc.into_inner().bytes;
        let mut dec = host_sim::link::decoder::Decoder::new(1 << 20, 1 << 24);
        let mut n = 0;
        dec.push(&bytes, &mut |_| n += 1);
        assert_eq!((n, dec.stats.frames_refused), (0, 1), "bits {bits}");
        if bits == 17 {
            let (r, out) = receive(
                "receive-gray16-17",
                bytes,
                &["--frames", "1", "--timeout", "1"],
                None,
            );
            assert!(r.failed_cleanly(), "exit {:?}: {}", r.code, r.stderr);
            assert!(r.stderr.contains("0 of 1 frames"), "{}", r.stderr);
            assert_eq!(entries(&out), ["receive.json"]);
        }
    }
}

/// Headers that claim huge frames (up to 16384×16384 RGB565, 512 MiB) are
/// refused at their start: the decoder never reserves more than its 16 MiB
/// frame limit, whatever a hostile link claims.
#[test]
fn frame_headers_claiming_huge_frames_are_refused() {
    // Only the header, as the wire carries it (a hostile sender need not
    // send the pixels, nor have an encoder that holds such lines):
    // COBS(postcard ‖ CRC-32 LE) 0x00.
    let wire = |start: FrameStart| {
        let mut body = [0u8; hilcam::link::MESSAGE_MAX];
        let n = postcard::to_slice(&hilcam::link::Message::FrameStart(start), &mut body)
            .expect("serializes")
            .len();
        let mut msg = body[..n].to_vec();
        msg.extend_from_slice(&hilcam::link::CRC32.checksum(&body[..n]).to_le_bytes());
        let mut bytes = vec![0u8; msg.len() + msg.len() / 254 + 2];
        let k = cobs::encode(&msg, &mut bytes);
        bytes.truncate(k);
        bytes.push(0);
        let mut dec = host_sim::link::decoder::Decoder::new(1 << 20, 1 << 24);
        dec.push(&bytes, &mut |_| {});
        dec.stats
    };
    // The encoding is right: a header within the limit is accepted.
    let ok = wire(FrameStart {
        width: 4096,
        height: 4096,
        ..header(WireFormat::Gray8)
    });
    assert_eq!((ok.messages_ok, ok.frames_refused), (1, 0));
    for (w, h, format) in [
        (16384u16, 16384u16, WireFormat::Rgb565),
        (16384, 1025, WireFormat::Gray8),
        (4097, 4096, WireFormat::Gray8),
    ] {
        let stats = wire(FrameStart {
            width: w,
            height: h,
            ..header(format)
        });
        assert_eq!(
            (stats.messages_ok, stats.frames_refused),
            (1, 1),
            "{w}x{h} {format:?}"
        );
    }
}

// ---------------------------------------------------------------------------
// Crashes

/// Every numeric flag is range-checked with an error naming it (no panic,
/// no huge allocation), before anything is written.
#[test]
fn numeric_flags_are_range_checked() {
    let dir = scratch("flags");
    let out = dir.join("out");
    let o = out.to_str().expect("utf-8");
    let scene = repo().join("scenes/standard.toml");
    let s = scene.to_str().expect("utf-8");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "receive",
                "--device",
                "/dev/null",
                "--out",
                o,
                "--timeout",
                "1e20",
            ],
            "--timeout",
        ),
        (
            vec!["receive", "--device", "/dev/null", "--out", o, "--timeout", "nan"],
            "--timeout",
        ),
        (
            vec!["receive", "--device", "/dev/null", "--out", o, "--timeout=-1"],
            "--timeout",
        ),
        (
            vec![
                "receive",
                "--device",
                "/dev/null",
                "--out",
                o,
                "--deadline",
                "inf",
            ],
            "--deadline",
        ),
        (
            vec!["receive", "--device", "/dev/null", "--out", o, "--frames", "0"],
            "--frames",
        ),
        (
            vec![
                "receive",
                "--device",
                "/dev/null",
                "--out",
                o,
                "--frames",
                "18446744073709551615",
            ],
            "--frames",
        ),
        (
            vec!["receive", "--device", "/dev/null", "--out", o, "--baud", "0"],
            "--baud",
        ),
        (
            vec!["stream", "--scene", s, "--out", o, "--frames", "4294967295"],
            "--frames",
        ),
        (
            vec!["stream", "--scene", s, "--out", o, "--frames", "0"],
            "--frames",
        ),
        (
            vec!["render", "--scene", s, "--out", o, "--max-lsb", "1e300"],
            "--max-lsb",
        ),
        (
            vec!["render", "--scene", s, "--out", o, "--max-geom-err-px", "nan"],
            "--max-geom-err-px",
        ),
        (vec!["faults", "--out", o, "--scale", "1e9"], "--scale"),
        (vec!["throughput", "--scene", s, "--frames", "0"], "--frames"),
        (vec!["tradeoff", "--out", o, "--repeats", "0"], "--repeats"),
        (
            vec![
                "profile",
                "--board",
                "lm3s6965evb",
                "--scene",
                s,
                "--out",
                o,
                "--top",
                "0",
            ],
            "--top",
        ),
        (
            vec![
                "profile",
                "--board",
                "lm3s6965evb",
                "--out",
                o,
                "--top",
                "18446744073709551616",
            ],
            "--top",
        ),
    ];
    for (args, flag) in cases {
        let r = run(&args);
        assert!(
            matches!(r.code, Some(1) | Some(2)) && !r.stderr.contains("panicked"),
            "{args:?}: exit {:?}: {}",
            r.code,
            r.stderr
        );
        assert!(
            r.stderr.contains(flag),
            "{args:?}: {flag} not named: {}",
            r.stderr
        );
        assert!(!out.exists(), "{args:?}: wrote {:?}", entries(&out));
    }
}

/// `stream` memory does not grow with the frame count: 20× the frames,
/// the same peak (within 2 MiB).
#[test]
fn stream_memory_does_not_grow_with_frames() {
    let dir = scratch("stream-memory");
    let scene = repo().join("scenes/standard.toml");
    let peak = |frames: &str| {
        let out = dir.join(frames);
        let r = run(&[
            "stream",
            "--scene",
            scene.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
            "--frames",
            frames,
            "--faults",
            "ber=1e-5,cut=1e-3,seed=3",
        ]);
        assert_eq!(r.code, Some(0), "{}", r.stderr);
        assert!(r.stdout.contains(&format!("sent {frames} ")), "{}", r.stdout);
        assert!(
            r.stdout.contains("corrupted accepted 0 intact lost 0"),
            "{}",
            r.stdout
        );
        r.max_rss_kib
    };
    let (small, large) = (peak("100"), peak("2000"));
    eprintln!("stream peak RSS: 100 frames {small} KiB, 2000 frames {large} KiB");
    assert!(
        large <= small + 2048,
        "100 frames {small} KiB, 2000 frames {large} KiB"
    );
}

// ---------------------------------------------------------------------------
// Frames and files lost

/// Garbage at the wrong baud rate, without end: the overall deadline stops
/// `receive`, with a failing status and receive.json.
#[test]
fn receive_stops_at_the_deadline_on_endless_noise() {
    let (child, mut master, slave, dir) = start_receive(
        "receive-noise",
        &["--frames", "1", "--timeout", "1", "--deadline", "2"],
    );
    let out = dir.join("out");
    let t = Instant::now();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let s2 = stop.clone();
    let noise = std::thread::spawn(move || {
        let mut x = 0x9e37_79b9_u32;
        while !s2.load(std::sync::atomic::Ordering::SeqCst) {
            let buf: Vec<u8> = (0..256)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 17;
                    x ^= x << 5;
                    x as u8 | 1 // never a delimiter: one endless message
                })
                .collect();
            let _ = master.write_all(&buf);
            std::thread::sleep(Duration::from_millis(5));
        }
    });
    let r = finish(child, &dir);
    let took = t.elapsed();
    stop.store(true, std::sync::atomic::Ordering::SeqCst);
    noise.join().expect("noise");
    drop(slave);
    assert!(r.failed_cleanly(), "exit {:?}: {}", r.code, r.stderr);
    assert!(r.stderr.contains("deadline"), "{}", r.stderr);
    assert!(took < Duration::from_secs(30), "took {took:?}");
    assert_eq!(entries(&out), ["receive.json"]);
}

/// Ctrl-C (SIGINT) while receiving: the frames already received stay, and
/// receive.json says it was interrupted.
#[test]
fn receive_interrupted_keeps_the_frames_already_received() {
    let (child, mut master, slave, dir) =
        start_receive("receive-sigint", &["--frames", "5", "--timeout", "60"]);
    let out = dir.join("out");
    let sent = send_frames(&[5u8; 64], header(WireFormat::Gray8), 2, None).expect("encodes");
    master.write_all(&sent.stream).expect("write");
    let t = Instant::now();
    while entries(&out).iter().filter(|e| e.ends_with(".png")).count() < 2
        && t.elapsed() < Duration::from_secs(20)
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    // SAFETY: kill(2) on our own child's pid.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let r = finish(child, &dir);
    drop(master);
    drop(slave);
    assert!(r.failed_cleanly(), "exit {:?}: {}", r.code, r.stderr);
    assert!(
        r.stderr.contains("2 of 5 frames") && r.stderr.contains("interrupted"),
        "{}",
        r.stderr
    );
    assert_eq!(
        entries(&out),
        ["frame-00000.png", "frame-00001.png", "receive.json"]
    );
}

/// A 640×480 render of the standard scene (about 60 KB of PNGs).
fn vga_scene(dir: &Path) -> PathBuf {
    let s = standard()
        .replacen("width = 160", "width = 640", 1)
        .replacen("height = 120", "height = 480", 1)
        .replacen("pitch = 12e-6", "pitch = 3e-6", 1);
    write_scene(dir, "vga.toml", &s)
}

/// A full disk (here a 16 KiB file-size limit, with SIGXFSZ ignored, so a
/// write fails with EFBIG as on ENOSPC): an error naming the file, and no
/// output at all, not a truncated PNG.
#[test]
fn a_failed_write_leaves_nothing_partial() {
    let dir = scratch("full-disk");
    let scene = vga_scene(&dir);
    let out = dir.join("out");
    fn limit() -> std::io::Result<()> {
        // SAFETY: async-signal-safe calls with valid arguments.
        unsafe {
            libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
            let l = libc::rlimit {
                rlim_cur: 16 * 1024,
                rlim_max: 16 * 1024,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &l) != 0 {
                return Err(std::io::Error::last_os_error());
            }
        }
        Ok(())
    }
    let r = run_with(
        &[
            "render",
            "--scene",
            scene.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
        ],
        Some(limit),
    );
    assert!(r.failed_cleanly(), "exit {:?}: {}{}", r.code, r.stdout, r.stderr);
    assert!(r.stderr.contains(".png: "), "the file is not named: {}", r.stderr);
    assert!(r.stderr.contains("File too large"), "{}", r.stderr);
    assert_eq!(entries(&out), Vec::<String>::new(), "partial output left");
}

/// SIGTERM in the middle of a render: nothing left behind, neither a
/// truncated PNG nor a temporary file.
#[test]
fn sigterm_while_rendering_leaves_nothing() {
    let dir = scratch("sigterm");
    let s = standard()
        .replacen("width = 160", "width = 2048", 1)
        .replacen("height = 120", "height = 2048", 1)
        .replacen("pitch = 12e-6", "pitch = 1e-6", 1);
    let scene = write_scene(&dir, "big.toml", &s);
    let out = dir.join("out");
    let child = Command::new(BIN)
        .args(["render", "--scene"])
        .arg(&scene)
        .arg("--out")
        .arg(&out)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(dir.join("stderr")).expect("file"))
        .spawn()
        .expect("spawns");
    // Wait until the PNGs are being written (the frame's staged file: not
    // the directory's probe, `Outputs::prepare`'s, which is staged and
    // removed before the render starts — seen, then gone, it failed this
    // test once), then stop it.
    let t = Instant::now();
    let writing = || entries(&out).iter().any(|e| e.starts_with(".frame.png.partial-"));
    let mut started = writing();
    while !started && t.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(2));
        started = writing();
    }
    assert!(
        started,
        "never started writing: {}",
        std::fs::read_to_string(dir.join("stderr")).unwrap_or_default()
    );
    // SAFETY: kill(2) on our own child's pid.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) };
    let (code, _) = reap(child);
    let err = std::fs::read_to_string(dir.join("stderr")).unwrap_or_default();
    assert_eq!(code, Some(130), "{err}");
    assert_eq!(entries(&out), Vec::<String>::new(), "left behind");
}

/// `--out` that cannot take files is an error naming it, before the
/// render (and `stream`'s I/O errors name the path too).
#[test]
fn an_unwritable_out_is_named_before_any_work() {
    let dir = scratch("bad-out");
    let file = write_scene(&dir, "not-a-dir", "x");
    let bad = file.join("out");
    let scene = repo().join("scenes/standard.toml");
    for cmd in ["render", "stream"] {
        let r = run(&[
            cmd,
            "--scene",
            scene.to_str().expect("utf-8"),
            "--out",
            bad.to_str().expect("utf-8"),
        ]);
        assert!(r.failed_cleanly(), "{cmd}: exit {:?}: {}", r.code, r.stderr);
        assert!(
            r.stderr.contains(bad.to_str().expect("utf-8")),
            "{cmd}: {}",
            r.stderr
        );
    }
}

// ---------------------------------------------------------------------------
// Resources

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

/// `render` memory is O(width): a 2048×2048 frame peaks within 8 MiB of a
/// 2048×64 one (the whole-frame version held about 63 B/pixel, 264 MB).
#[test]
fn render_memory_does_not_grow_with_height() {
    let (short, tall) = peaks_by_height(
        "render",
        &["diff.png", "frame.png", "metrics.json", "reference.png"],
    );
    assert!(
        tall <= short + 8 * 1024,
        "2048x64 {short} KiB, 2048x2048 {tall} KiB"
    );
}

/// Scene files are capped at 1 MiB (docs/scenes.md): a larger file, or an
/// endless one, is refused at once, naming it.
#[test]
fn scene_files_are_size_capped() {
    let dir = scratch("size-cap");
    let mut big = standard();
    big.push_str(&format!("# {}\n", "x".repeat(2 << 20)));
    let p = write_scene(&dir, "big.toml", &big);
    let out = dir.join("out");
    for scene in [p.to_str().expect("utf-8"), "/dev/zero"] {
        let r = run(&["render", "--scene", scene, "--out", out.to_str().expect("utf-8")]);
        assert!(r.failed_cleanly(), "{scene}: exit {:?}: {}", r.code, r.stderr);
        assert!(
            r.stderr.contains(scene) && r.stderr.contains("larger than 1048576 bytes"),
            "{}",
            r.stderr
        );
        assert!(r.max_rss_kib < 64 * 1024, "{scene}: {} KiB", r.max_rss_kib);
        assert!(!out.exists());
    }
}

/// `faults` carries its scene: a copy of the binary elsewhere runs, and the
/// binary holds no build-time path to a scene file.
#[test]
fn faults_runs_from_a_moved_binary() {
    let dir = scratch("moved");
    let bin = dir.join("host-sim");
    std::fs::copy(BIN, &bin).expect("copy");
    let bytes = std::fs::read(&bin).expect("read");
    // The build-time path the command once read the scene from.
    let built_in = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/standard.toml").as_bytes();
    assert!(
        !bytes.windows(built_in.len()).any(|w| w == built_in),
        "the binary refers to the standard scene by a build-time path"
    );
    let out = dir.join("out");
    let r = Command::new(&bin)
        .args(["faults", "--scale", "0.002", "--out"])
        .arg(&out)
        .current_dir(&dir)
        .output()
        .expect("runs");
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(entries(&out), ["faults.json"]);
}

// ---------------------------------------------------------------------------
// Errors that name nothing

/// Cameras inside the documented per-field ranges that the renderer cannot
/// image are refused at load, naming the file and the fields, not with
/// `cannot render: FieldTooWide` after planning.
#[test]
fn cameras_the_renderer_cannot_image_are_refused_at_load() {
    let s = standard();
    let cases = [
        ("pitch-1mm", s.replacen("pitch = 12e-6", "pitch = 1e-3", 1)),
        (
            "16384x1",
            s.replacen("width = 160", "width = 16384", 1)
                .replacen("height = 120", "height = 1", 1),
        ),
        (
            "principal-point-extreme",
            s.replacen(
                "distortion = [0.15, 0.05]",
                "distortion = [0.15, 0.05]\nprincipal_point = [-16384.0, 32767.0]",
                1,
            ),
        ),
    ];
    for (name, text) in cases {
        refused(
            name,
            &text,
            &["camera.pitch", "camera.focal_length", "field too wide"],
        );
    }
}

/// The core's parameter names are translated to the scene file's keys.
#[test]
fn core_errors_use_the_scene_files_names() {
    let s = standard();
    let pose = s.lines().find(|l| l.starts_with("pose = ")).expect("pose");
    let cases = [
        (
            "pp-nan",
            s.replacen(
                "distortion = [0.15, 0.05]",
                "distortion = [0.15, 0.05]\nprincipal_point = [nan, 0.0]",
                1,
            ),
            "camera.principal_point",
            "principal_x",
        ),
        (
            "pitch-inf",
            s.replacen("pitch = 12e-6", "pitch = [12e-6, inf]", 1),
            "camera.pitch",
            "pitch_y",
        ),
        (
            "angle-nan",
            s.replace(
                pose,
                "pose = { position = [0.0, 1.0, -3.0], yaw_pitch_roll = [nan, 0.0, 0.0] }",
            ),
            "camera.pose.yaw_pitch_roll",
            "angle",
        ),
        (
            "eye-nan",
            s.replacen("eye = [0.0, 1.2, -3.0]", "eye = [nan, 1.2, -3.0]", 1),
            "camera.pose.eye",
            "translation",
        ),
    ];
    for (name, text, want, not) in cases {
        let dir = scratch(name);
        let scene = write_scene(&dir, "scene.toml", &text);
        let r = run(&[
            "render",
            "--scene",
            scene.to_str().expect("utf-8"),
            "--out",
            dir.join("out").to_str().expect("utf-8"),
        ]);
        assert!(r.failed_cleanly(), "{name}: exit {:?}: {}", r.code, r.stderr);
        assert!(
            r.stderr.contains(&format!("{want}:")) && !r.stderr.contains(&format!("{not}:")),
            "{name}: {}",
            r.stderr
        );
    }
    // A far target is a direction, not an error blamed on `up`.
    let far = s.replacen("target = [0.0, 0.4, 0.0]", "target = [0.0, 0.4, 1e300]", 1);
    let dir = scratch("far-target");
    let scene = write_scene(&dir, "scene.toml", &far);
    let r = run(&[
        "render",
        "--scene",
        scene.to_str().expect("utf-8"),
        "--out",
        dir.join("out").to_str().expect("utf-8"),
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(
        r.stdout.contains("smooth: max_lsb=0") || r.stdout.contains("smooth: max_lsb=1"),
        "{}",
        r.stdout
    );
}

/// `frame`'s truth lists the checker corners in view, at most
/// `MAX_CORNERS`, counting the rest: a 1 m board of 1 mm cells (a million
/// corners, most out of view) ends with bounded output and memory.
#[test]
fn frame_truth_lists_the_corners_in_view_within_a_cap() {
    let dir = scratch("frame-corners");
    let s = std::fs::read_to_string(repo().join("scenes/calibration-board.toml"))
        .expect("calibration board")
        .replacen("cell = 0.03", "cell = 0.001", 1)
        .replacen("size = [0.27, 0.21]", "size = [1.0, 1.0]", 1);
    let scene = write_scene(&dir, "fine.toml", &s);
    let out = dir.join("out");
    let r = run(&[
        "frame",
        "--scene",
        scene.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let t: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("truth.json")).expect("truth")).expect("json");
    let (w, h) = (t["width"].as_f64().expect("w"), t["height"].as_f64().expect("h"));
    let listed: Vec<&serde_json::Value> = t["checker_corners"]
        .as_array()
        .expect("list")
        .iter()
        .flat_map(|r| r.as_array().expect("rect").iter())
        .collect();
    assert!(!listed.is_empty() && listed.len() <= host_sim::truth::MAX_CORNERS);
    for c in &listed {
        let p = c["pixel"].as_array().expect("pixel");
        let (x, y) = (p[0].as_f64().expect("x"), p[1].as_f64().expect("y"));
        assert!(
            (-0.5..w - 0.5).contains(&x) && (-0.5..h - 0.5).contains(&y),
            "{c}"
        );
    }
    eprintln!(
        "fine board: {} corners listed, {} left out, peak RSS {} KiB",
        listed.len(),
        t["corners_left_out"],
        r.max_rss_kib
    );
    assert!(r.max_rss_kib < 512 * 1024, "peak RSS {} KiB", r.max_rss_kib);
}

/// `stream` writes `received.png` only from a frame the receiver decoded:
/// with every message dropped no frame arrives, and no picture claims one
/// did.
#[test]
fn stream_writes_no_received_picture_when_nothing_arrived() {
    let dir = scratch("stream-nothing");
    let scene = repo().join("scenes/standard.toml");
    let args = |faults: &'static str, out: &Path| {
        run(&[
            "stream",
            "--scene",
            scene.to_str().expect("utf-8"),
            "--frames",
            "5",
            "--faults",
            faults,
            "--out",
            out.to_str().expect("utf-8"),
        ])
    };
    let lost = dir.join("lost");
    let r = args("drop=1", &lost);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert_eq!(entries(&lost), ["stream.json"]);
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(lost.join("stream.json")).expect("json")).expect("json");
    assert!(j["received_png_frame"].is_null());
    assert_eq!(j["outcome"]["frames_delivered_intact"], 0);
    let clean = dir.join("clean");
    let r = args("none", &clean);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert_eq!(entries(&clean), ["received.png", "stream.json"]);
}

/// `camera` names a scene it cannot hold by its file, with the limit, and
/// a baud rate out of range, before it opens the port.
#[test]
fn camera_refuses_what_it_cannot_hold_before_opening_the_port() {
    let dir = scratch("camera-hold");
    let wide =
        standard()
            .replacen("width = 160", "width = 2000", 1)
            .replacen("pitch = 12e-6", "pitch = 1e-6", 1);
    let scene = write_scene(&dir, "wide.toml", &wide);
    let r = run(&[
        "camera",
        "--device",
        "/nonexistent/port",
        "--scene",
        scene.to_str().expect("utf-8"),
    ]);
    assert!(r.failed_cleanly(), "{}", r.stderr);
    assert!(
        r.stderr.contains("wide.toml") && r.stderr.contains("camera.width") && r.stderr.contains("1024"),
        "{}",
        r.stderr
    );
    let r = run(&["camera", "--device", "/nonexistent/port", "--baud", "3"]);
    assert!(r.failed_cleanly() && r.stderr.contains("--baud"), "{}", r.stderr);
}

/// `frame` memory is O(width): a 2048×2048 frame peaks within 8 MiB of a
/// 2048×64 one (it renders a line at a time straight into frame.png).
#[test]
fn frame_memory_does_not_grow_with_height() {
    let (short, tall) = peaks_by_height("frame", &["frame.png", "truth.json"]);
    assert!(
        tall <= short + 8 * 1024,
        "2048x64 {short} KiB, 2048x2048 {tall} KiB"
    );
}

/// `replay` streams its capture: 20 frames or 1 000, the same peak memory
/// (within 4 MiB); every frame lost, refused or cut off is counted and
/// makes the exit status non-zero.
#[test]
fn replay_memory_is_one_frame_and_losses_fail_it() {
    let dir = scratch("replay");
    let start = FrameStart {
        version: PROTOCOL_VERSION,
        frame_id: 0,
        width: 160,
        height: 120,
        format: WireFormat::Gray16 { bits: 12 },
        scene_id: 0,
        exposure: 1 << 32,
        truth: Default::default(),
    };
    let base = vec![0x12u8; start.frame_bytes()];
    let peak = |n: u32| {
        let sent = send_frames(&base, start, n, None).expect("encodes");
        let cap = dir.join(format!("cap{n}.bin"));
        std::fs::write(&cap, &sent.stream).expect("capture");
        let out = dir.join(format!("out{n}"));
        let r = run(&[
            "replay",
            "--capture",
            cap.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        assert_eq!(r.code, Some(0), "{}", r.stderr);
        assert!(r.stdout.contains(&format!("{n} frames")), "{}", r.stdout);
        (r.max_rss_kib, sent.stream)
    };
    let (small, _) = peak(20);
    let (large, stream) = peak(1000);
    eprintln!("replay peak RSS: 20 frames {small} KiB, 1000 frames {large} KiB");
    assert!(
        large <= small + 4 * 1024,
        "20 frames {small} KiB, 1000 frames {large} KiB"
    );
    // Cut inside the last frame: counted, and the exit says so.
    let cap = dir.join("cut.bin");
    std::fs::write(&cap, &stream[..stream.len() - 100]).expect("capture");
    let out = dir.join("cut");
    let r = run(&[
        "replay",
        "--capture",
        cap.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(r.failed_cleanly(), "{}", r.stderr);
    assert!(r.stderr.contains("cut off by the end 1"), "{}", r.stderr);
}

/// A variant a scene cannot take is named, with the reason in words; a
/// yaw beyond ±1000 rad is refused naming its key.
#[test]
fn impossible_variants_and_angles_say_what_and_why() {
    let dir = scratch("variant-angle");
    let out = dir.join("out");
    let dof = repo().join("scenes/shallow-dof.toml");
    let r = run(&[
        "frame",
        "--scene",
        dof.to_str().expect("utf-8"),
        "--variant",
        "mix32-s4-adaptive",
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(r.failed_cleanly(), "{}", r.stderr);
    assert!(
        r.stderr.contains("--variant mix32-s4-adaptive") && r.stderr.contains("formats cannot hold"),
        "{}",
        r.stderr
    );
    assert!(entries(&out).is_empty());
    let s = standard().replacen(
        "pose = { eye = [0.0, 1.2, -3.0], target = [0.0, 0.4, 0.0], up = [0.0, 1.0, 0.0] }",
        "pose = { position = [0.0, 1.2, -3.0], yaw_pitch_roll = [1e300, 0.0, 0.0] }",
        1,
    );
    assert!(s.contains("1e300"));
    let scene = write_scene(&dir, "yaw.toml", &s);
    let r = run(&[
        "frame",
        "--scene",
        scene.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(r.failed_cleanly(), "{}", r.stderr);
    assert!(
        r.stderr.contains("yaw.toml") && r.stderr.contains("camera.pose.yaw_pitch_roll"),
        "{}",
        r.stderr
    );
}

/// A run's outputs are only this run's: a replay of one frame into the
/// directory of a replay of three leaves one frame (the earlier run's
/// other files removed, as the manifest names them), and a file hilcam did
/// not write stays.
#[test]
fn a_new_run_leaves_no_stale_outputs_of_the_last() {
    let dir = scratch("stale");
    let start = FrameStart {
        version: PROTOCOL_VERSION,
        frame_id: 0,
        width: 8,
        height: 2,
        format: WireFormat::Gray8,
        scene_id: 0,
        exposure: 1 << 32,
        truth: Default::default(),
    };
    let out = dir.join("out");
    let replay = |n: u32| {
        let sent = send_frames(&[5u8; 16], start, n, None).expect("encodes");
        let cap = dir.join(format!("cap{n}.bin"));
        std::fs::write(&cap, &sent.stream).expect("capture");
        let r = run(&[
            "replay",
            "--capture",
            cap.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        assert_eq!(r.code, Some(0), "{}", r.stderr);
    };
    replay(3);
    std::fs::write(out.join("notes.txt"), "mine").expect("user file");
    assert_eq!(entries(&out).len(), 3 * 2 + 2);
    replay(1);
    assert_eq!(
        entries(&out),
        ["frame-00000.json", "frame-00000.png", "notes.txt", "replay.json"]
    );
}
