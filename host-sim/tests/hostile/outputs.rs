//! Outputs of every command: a full disk, signals, an unwritable `--out`, stale files of an earlier run.

use super::*;

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

/// A run's outputs are only this run's: a replay of one frame into the
/// directory of a replay of three leaves one frame (the earlier run's
/// other files removed, as the manifest names them), and a file hilcam did
/// not write stays.
#[test]
fn a_new_run_leaves_no_stale_outputs_of_the_last() {
    let dir = scratch("stale");
    let start = FrameStart {
        width: 8,
        height: 2,
        scene_id: 0,
        ..header(WireFormat::Gray8)
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
