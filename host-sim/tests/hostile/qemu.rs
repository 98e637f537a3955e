//! The QEMU commands (`hil`, `profile`, `drive`, `costfit`, `tradeoff`):
//! what they are given to run is checked before QEMU starts (an ELF that
//! is not a Cortex-M firmware, or not one built for the board, would run
//! silent until the timeout or die with a register dump), and their flags
//! and files are named when wrong. Needs no QEMU: every case fails before.

use super::*;

/// `--elf` that is not a hilcam firmware for the board: named, with why,
/// before QEMU runs; nothing left in `--out` (no UART log).
#[test]
fn hil_and_profile_refuse_an_elf_that_is_not_a_firmware_for_the_board() {
    let dir = scratch("qemu-elf");
    let text = dir.join("firmware.txt");
    std::fs::write(&text, "not an ELF\n").expect("text");
    for command in ["hil", "profile"] {
        for (elf, why) in [
            (BIN, "not a Cortex-M firmware"),
            (text.to_str().expect("utf-8"), "not an ELF file"),
        ] {
            let out = dir.join(format!("out-{command}"));
            let r = run(&[
                command,
                "--board",
                "lm3s6965evb",
                "--elf",
                elf,
                "--scene",
                repo().join("scenes/standard.toml").to_str().expect("utf-8"),
                "--out",
                out.to_str().expect("utf-8"),
            ]);
            assert!(r.failed_cleanly(), "{command} {elf}: {}", r.stderr);
            assert!(
                r.stderr.contains(elf) && r.stderr.contains(why),
                "{command} {elf}: {}",
                r.stderr
            );
            assert!(entries(&out).is_empty(), "{command}: {:?}", entries(&out));
        }
    }
}

/// Unknown boards, missing files and out-of-range counts: each named.
#[test]
fn qemu_commands_name_a_bad_board_file_or_count() {
    let dir = scratch("qemu-flags");
    let out = dir.join("out");
    let out = out.to_str().expect("utf-8");
    let missing = dir.join("missing.toml");
    let missing = missing.to_str().expect("utf-8");
    let standard = repo().join("scenes/standard.toml");
    let standard = standard.to_str().expect("utf-8");
    for (args, named) in [
        (vec!["hil", "--board", "nosuch", "--out", out], "--board"),
        (vec!["profile", "--board", "nosuch", "--out", out], "--board"),
        (
            vec!["drive", "--board", "nosuch", "--frames", "1", "--out", out],
            "--board",
        ),
        (
            vec!["hil", "--board", "microbit", "--scene", missing, "--out", out],
            missing,
        ),
        (
            vec!["profile", "--board", "microbit", "--scene", missing, "--out", out],
            missing,
        ),
        (
            vec![
                "drive", "--board", "microbit", "--scene", missing, "--frames", "1", "--out", out,
            ],
            missing,
        ),
        (
            vec![
                "drive", "--board", "microbit", "--scene", standard, "--frames", "0", "--out", out,
            ],
            "--frames",
        ),
        // The driven camera is built without cast shadows: a scene that
        // asks for them is named before a firmware is built.
        (
            vec![
                "drive", "--board", "microbit", "--scene", standard, "--frames", "1", "--out", out,
            ],
            "environment.shadows",
        ),
        (vec!["costfit", "--keep", missing, "--out", out], missing),
        (
            vec!["tradeoff", "--boards", "lm3s6965evb,nosuch", "--out", out],
            "--boards",
        ),
        (vec!["tradeoff", "--repeats", "0", "--out", out], "--repeats"),
    ] {
        let r = run(&args);
        assert!(r.failed_cleanly(), "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(named), "{args:?}: {}", r.stderr);
        assert!(
            entries(Path::new(out)).is_empty(),
            "{args:?}: {:?}",
            entries(Path::new(out))
        );
    }
}

/// `drive --poses`: a keyframe beyond ±1000 m, an endless file and bytes
/// that are not text are named (file, keyframe, field) before a firmware
/// is built: the camera's bare `Reject` used to be all that was said, and
/// `/dev/zero` was read until memory ran out.
#[test]
fn drive_names_a_bad_poses_file_before_building() {
    let dir = scratch("drive-poses");
    let far = dir.join("far.jsonl");
    std::fs::write(
        &far,
        "{\"t\": 0.0, \"position\": [1e300, 0, 0], \"quaternion\": [1, 0, 0, 0]}\n",
    )
    .expect("poses");
    let binary = dir.join("binary.csv");
    std::fs::write(&binary, [0xffu8, 0xfe, 0x00, 0x80]).expect("poses");
    let standard = repo().join("scenes/standard.toml");
    for (poses, said) in [
        (far.to_str().expect("utf-8"), "keyframe 0: position"),
        (binary.to_str().expect("utf-8"), "not UTF-8"),
        ("/dev/zero", "not a poses file"),
    ] {
        let out = dir.join("out");
        let t = Instant::now();
        let r = run(&[
            "drive",
            "--board",
            "lm3s6965evb",
            "--scene",
            standard.to_str().expect("utf-8"),
            "--poses",
            poses,
            "--frames",
            "2",
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        assert!(r.failed_cleanly(), "{poses}: {}", r.stderr);
        assert!(
            r.stderr.contains(poses) && r.stderr.contains(said),
            "{poses}: {}",
            r.stderr
        );
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "{poses}: {:?}",
            t.elapsed()
        );
        assert!(r.max_rss_kib < 200 * 1024, "{poses}: {} KiB", r.max_rss_kib);
        assert!(entries(&out).is_empty(), "{poses}: {:?}", entries(&out));
    }
}
