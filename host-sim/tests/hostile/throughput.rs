//! `throughput` and `export`: frames beyond the stated cap, cameras the
//! calibration files cannot express, each named.

use super::*;

/// `throughput` renders whole frames into memory: a frame over its 64 MiB
/// cap is refused naming `camera.height` and the cap, at once.
#[test]
fn throughput_refuses_frames_over_its_cap() {
    let dir = scratch("throughput-cap");
    let text = standard()
        .replace("width = 160", "width = 16384")
        .replace("height = 120", "height = 16384")
        .replace("pitch = 12e-6", "pitch = 0.1e-6");
    let scene = write_scene(&dir, "huge.toml", &text);
    let r = run(&[
        "throughput",
        "--scene",
        scene.to_str().expect("utf-8"),
        "--frames",
        "1",
    ]);
    assert!(r.failed_cleanly(), "{}", r.stderr);
    assert!(
        r.stderr.contains("camera.height") && r.stderr.contains("at most 67108864 B"),
        "{}",
        r.stderr
    );
    assert!(r.max_rss_kib < 32 * 1024, "{} KiB before refusing", r.max_rss_kib);
}

/// `export` of cameras the calibration formats cannot hold (orthographic)
/// names the file and the key; nothing is written.
#[test]
fn export_names_what_the_calibration_files_cannot_hold() {
    let dir = scratch("export-ortho");
    let text = standard().replacen(
        "[camera]\n",
        "[camera]\nmodel = \"orthographic\"\northographic_scale = 0.01\n",
        1,
    );
    let scene = write_scene(&dir, "ortho.toml", &text);
    let out = dir.join("out");
    let r = run(&[
        "export",
        "--scene",
        scene.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(r.failed_cleanly(), "{} {}", r.stdout, r.stderr);
    assert!(
        r.stderr.contains(scene.to_str().expect("utf-8")) && r.stderr.contains("camera.model"),
        "{}",
        r.stderr
    );
    assert!(
        entries(&out).iter().all(|e| e.starts_with(".probe")),
        "{:?}",
        entries(&out)
    );
}
