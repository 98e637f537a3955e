//! `frame`: the truth file's cap, memory with height.

use super::*;

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
