//! `render`: memory with height, variants and angles a scene cannot take.

use super::*;

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
    refused("yaw-1e300", &s, &["camera.pose.yaw_pitch_roll"]);
}
