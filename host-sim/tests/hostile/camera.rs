//! `camera`: scenes it cannot hold.

use super::*;

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
