//! The closed loop without QEMU: `host-sim drive`'s driver against the
//! host camera (`host-sim camera`, the core's receiver, command state and
//! encoder) over a socket pair — clean, and with the fault campaign's
//! faults in both directions. The firmware in QEMU runs the same loop in
//! the test command (`host-sim drive`).

use hilcam::link::MAX_SCENE_CHUNK;
use host_sim::camera_cmd::serve;
use host_sim::client::{spawn_reader, Client};
use host_sim::drive_cmd::{drive, poses, DriveReport};
use host_sim::link::sim::{Faults, FaultyWriter};
use host_sim::scene_file::load;
use serialport::SerialPort;
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::time::Duration;

fn standard() -> host_sim::scene_file::Resolved {
    load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/standard.toml"
    )))
    .expect("standard")
}

/// Drives the host camera through `n` poses of the standard scene's
/// wobble, with `to_camera` and `to_host` faults, each pose with its
/// trigger in one write if `batched`; returns the drive's report and the
/// camera's counts.
fn run(
    n: usize,
    to_camera: Faults,
    to_host: Faults,
    batched: bool,
) -> (DriveReport, host_sim::camera_cmd::CameraStats) {
    let r = standard();
    let (host, cam) = UnixStream::pair().expect("socket pair");
    let cam_reader = cam.try_clone().expect("clone");
    // The camera holds another scene: the drive sends the standard one as
    // data (LoadScene), through the faults too.
    let scenes = vec![load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/calibration-board.toml"
    )))
    .expect("scene")];
    let camera = std::thread::spawn(move || serve(cam_reader, FaultyWriter::new(cam, &to_host), &scenes));
    let reader = host.try_clone().expect("clone");
    let hangup = host.try_clone().expect("clone");
    let mut driver = Client::new(FaultyWriter::new(host, &to_camera), spawn_reader(reader, None));
    driver.timeout = Duration::from_millis(300);
    driver.frame_timeout = Duration::from_secs(1);
    driver.batched = batched;
    let out = std::env::temp_dir().join(format!("hilcam-loop-{}-{}", std::process::id(), to_host.seed));
    let poses = poses(&r, None, n).expect("poses");
    let report = drive(&mut driver, "host", &r, &poses, None, None, &out).expect("drive");
    // Closes the link (the reader thread holds a handle too): the camera
    // sees its input end and stops.
    hangup.shutdown(std::net::Shutdown::Both).expect("shutdown");
    drop(driver);
    let stats = camera.join().expect("camera thread").expect("camera");
    let _ = std::fs::remove_dir_all(&out);
    (report, stats)
}

/// A clean link: every frame arrives, in order, byte-identical with the
/// host render of its pose, with the truth of the pose sent; every command
/// applied once.
#[test]
fn the_host_camera_follows_the_trajectory() {
    let (r, cam) = run(30, Faults::default(), Faults::default(), false);
    assert!(r.passed(), "{r:#?}");
    assert_eq!(
        (r.frames_received, r.lost, r.out_of_order, r.resent),
        (30, 0, 0, 0)
    );
    // Describe is answered, not counted; the scene's LoadScene parts, then
    // SetPose and Trigger a frame.
    let parts = standard()
        .scene_bytes()
        .expect("data")
        .len()
        .div_ceil(MAX_SCENE_CHUNK) as u32;
    assert!(parts > 1);
    assert_eq!((cam.acks, cam.rejects, cam.frames), (parts + 2 * 30, 0, 30));
    // The poses differ from frame to frame (the loop moves the camera).
    let t0 = r.frames[0].truth.translation;
    assert!(r.frames.iter().any(|f| f.truth.translation != t0));
}

/// Each pose sent with its trigger in one write (`host-sim drive
/// --batched`): the camera reads both in one batch and answers each; every
/// frame is still the render of its pose, with its truth.
#[test]
fn a_pose_and_its_trigger_sent_at_once() {
    let (r, cam) = run(10, Faults::default(), Faults::default(), true);
    assert!(r.passed() && r.batched, "{r:#?}");
    assert_eq!(
        (r.frames_received, r.bit_exact, r.truth_matches, r.resent),
        (10, 10, 10, 0)
    );
    assert_eq!((cam.rejects, cam.frames), (0, 10));
    // Each frame's truth names its trigger, the command after its pose;
    // the camera's time from the pose's answer to the trigger's is kept.
    assert!(r.frames.windows(2).all(|w| w[1].command == w[0].command + 2));
    assert!(r.frames.iter().all(|f| f.pose_to_trigger_camera_ns.is_some()));
}

/// Faults in both directions (bit errors, drops, duplicates, inserted
/// bursts, truncated messages): no corrupted command is accepted, none is
/// applied twice or out of order (one frame a trigger, however often the
/// trigger is resent), and no frame arrives with the wrong pixels or the
/// wrong ground truth — frames are lost instead.
///
/// The four seeds run at once, each over its own socket pair: a lost
/// frame is a second of the driver's `frame_timeout` spent waiting, and in
/// turn they took 50 s.
#[test]
fn faults_lose_frames_but_never_corrupt_them() {
    // Frames are long (19 kB): low rates lose some of them. Commands are
    // short (≤ 108 B): rates 100× higher hit some of them too.
    let faults = |seed, scale: f64| Faults {
        ber: 5e-7 * scale,
        drop: 5e-7 * scale,
        dup: 5e-7 * scale,
        insert: 5e-7 * scale,
        truncate: 0.002 * scale.sqrt(),
        cut: 0.0,
        seed,
    };
    let runs: Vec<_> = std::thread::scope(|s| {
        let seeds: Vec<_> = (1..=4u64)
            .map(|seed| {
                (
                    seed,
                    s.spawn(move || run(40, faults(seed, 100.0), faults(seed + 100, 1.0), false)),
                )
            })
            .collect();
        seeds
            .into_iter()
            .map(|(seed, h)| (seed, h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))))
            .collect()
    });
    let (mut total_lost, mut total_resent, mut total_refused) = (0, 0, 0);
    for (seed, (r, cam)) in runs {
        // Every trigger made exactly one frame, resent or not.
        assert_eq!(cam.frames, 40, "seed {seed}: {cam:?}");
        assert_eq!(r.frames_received + r.lost, 40, "seed {seed}");
        assert_eq!(r.out_of_order, 0, "seed {seed}");
        // Nothing delivered is wrong.
        assert_eq!(r.bit_exact, r.frames_received, "seed {seed}");
        assert_eq!(r.truth_matches, r.frames_received, "seed {seed}");
        assert_eq!(cam.rejects, 0, "seed {seed}: a resent command was refused");
        total_lost += r.lost;
        eprintln!(
            "seed {seed}: {} received, {} lost, {} late, {} commands resent, camera refused {:?} messages",
            r.frames_received, r.lost, r.late, r.resent, cam.refused
        );
        total_resent += r.resent;
        total_refused += cam.refused.iter().sum::<u32>();
    }
    // The faults did hit both ways (otherwise this test checks nothing).
    assert!(
        total_lost > 0,
        "no frame was lost: the fault rates are too low to test anything"
    );
    assert!(
        total_resent > 0 && total_refused > 0,
        "no command was hit: the fault rates are too low to test anything"
    );
}

/// `host-sim camera --device` on a pty: the driver on the master side
/// drives the command-line camera through 10 poses; every frame arrives
/// bit-exact with its truth; the camera stops when the driver hangs up.
#[test]
fn the_command_line_camera_obeys_over_a_pty() {
    let r = standard();
    let (master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("pty name");
    let dir = std::env::temp_dir().join(format!("hilcam-pty-camera-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let capture = dir.join("camera.bin");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["camera", "--device", &path, "--scene"])
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/standard.toml"))
        .arg("--capture")
        .arg(&capture)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("host-sim camera");
    let reader = master.try_clone_native().expect("clone");
    let mut driver = Client::new(master, spawn_reader(reader, None));
    // Bytes written before the camera has the port open may be flushed by
    // its opening: the driver sends again after a silence.
    driver.timeout = Duration::from_millis(500);
    driver.frame_timeout = Duration::from_secs(10);
    let poses = poses(&r, None, 10).expect("poses");
    let report = drive(&mut driver, "pty", &r, &poses, None, None, &dir.join("out"));
    drop(driver);
    drop(slave);
    // The reader thread still holds the master: the camera may not see the
    // hang-up; stop it.
    std::thread::sleep(Duration::from_millis(200));
    let _ = child.kill();
    let out = child.wait_with_output().expect("camera exits");
    let report = report.unwrap_or_else(|e| panic!("{e}\n{}", String::from_utf8_lossy(&out.stderr)));
    assert!(report.passed(), "{report:#?}");
    // What the camera captured replays to the same frames.
    let replay = host_sim::drive_cmd::replay(&capture, &dir.join("replay")).expect("replay");
    assert_eq!(replay.frames, 10);
    let _ = std::fs::remove_dir_all(&dir);
}
