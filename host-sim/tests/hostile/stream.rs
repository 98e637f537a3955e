//! `stream` and `faults`: memory, frames that never arrive, a moved binary, frames the link cannot carry.

use super::*;

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

/// A frame the link cannot carry (a line over the encoder's chunk, a
/// frame over the receivers' cap) is refused naming the key and the limit,
/// before anything is rendered: quickly, in little memory, nothing written.
#[test]
fn frames_the_link_cannot_carry_are_refused_before_rendering() {
    let dir = scratch("stream-carry");
    let wide = standard()
        .replace("width = 160", "width = 4096")
        .replace("height = 120", "height = 4096")
        .replace("pitch = 12e-6", "pitch = 0.5e-6");
    let tall = standard()
        .replace("width = 160", "width = 2048")
        .replace("height = 120", "height = 9000")
        .replace("pitch = 12e-6", "pitch = 1e-6");
    for (name, text, key) in [("wide", wide, "camera.width"), ("tall", tall, "camera.height")] {
        let scene = write_scene(&dir, name, &text);
        let out = dir.join(format!("out-{name}"));
        let r = run(&[
            "stream",
            "--scene",
            scene.to_str().expect("utf-8"),
            "--frames",
            "2",
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        assert!(r.failed_cleanly(), "{name}: {} {}", r.stdout, r.stderr);
        assert!(
            r.stderr.contains(key) && r.stderr.contains("the link carries"),
            "{name}: {}",
            r.stderr
        );
        assert!(
            r.max_rss_kib < 32 * 1024,
            "{name}: {} KiB before refusing",
            r.max_rss_kib
        );
        let left: Vec<String> = entries(&out)
            .into_iter()
            .filter(|e| !e.starts_with(".probe"))
            .collect();
        assert!(left.is_empty(), "{name}: {left:?}");
    }
}
