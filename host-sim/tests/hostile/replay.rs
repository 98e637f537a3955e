//! `replay`: memory, losses.

use super::*;

/// `replay` streams its capture: 20 frames or 1 000, the same peak memory
/// (within 4 MiB); every frame lost, refused or cut off is counted and
/// makes the exit status non-zero.
#[test]
fn replay_memory_is_one_frame_and_losses_fail_it() {
    let dir = scratch("replay");
    let start = FrameStart {
        width: 160,
        height: 120,
        scene_id: 0,
        ..header(WireFormat::Gray16 { bits: 12 })
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

/// A device is not a capture: `/dev/zero` (endless) and a directory are
/// refused naming the path, at once, with nothing written.
#[test]
fn replay_refuses_devices_and_directories() {
    let dir = scratch("replay-device");
    for capture in ["/dev/zero", dir.to_str().expect("utf-8")] {
        let out = dir.join("out");
        let r = run(&[
            "replay",
            "--capture",
            capture,
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        assert!(r.failed_cleanly(), "{capture}: {}", r.stderr);
        assert!(
            r.stderr.contains(capture) && r.stderr.contains("not a capture file"),
            "{capture}: {}",
            r.stderr
        );
        assert!(
            entries(&out).iter().all(|e| e.starts_with(".probe")),
            "{:?}",
            entries(&out)
        );
    }
}
