//! Trajectories: keyframes from a scene file or a poses file, positions
//! interpolated linearly and orientations by slerp, bad keyframes refused
//! with the keyframe and field named.

use host_sim::trajectory::{quaternion_of, rotation_of, slerp, Keyframe, Trajectory};

fn yaw(deg: f64) -> [f64; 4] {
    let h = deg.to_radians() / 2.0;
    [h.cos(), 0.0, h.sin(), 0.0]
}

fn close(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> bool {
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .all(|(x, y)| (x - y).abs() < 1e-12)
}

#[test]
fn slerp_and_lerp_interpolate_between_keyframes() {
    let t = Trajectory::new(vec![
        Keyframe {
            t: 0.0,
            position: [0.0, 0.0, 0.0],
            quaternion: yaw(0.0),
        },
        Keyframe {
            t: 2.0,
            position: [2.0, -4.0, 6.0],
            quaternion: yaw(90.0),
        },
    ])
    .expect("trajectory");
    let mid = t.at(1.0);
    assert_eq!(mid.translation, [1.0, -2.0, 3.0]);
    // Halfway in angle: 45°, not the normalized mean of the two matrices.
    assert!(close(&mid.rotation, &rotation_of(yaw(45.0))), "{mid:?}");
    // At and beyond the ends: the keyframes' poses.
    assert!(close(&t.at(-1.0).rotation, &rotation_of(yaw(0.0))));
    assert!(close(&t.at(5.0).rotation, &rotation_of(yaw(90.0))));
    assert_eq!(t.sample(3).len(), 3);
    // Slerp takes the short way round (q and −q are the same rotation).
    let q = slerp(yaw(10.0), yaw(30.0).map(|v| -v), 0.5);
    assert!(close(&rotation_of(q), &rotation_of(yaw(20.0))));
    // R from q and back.
    for q in [yaw(0.0), yaw(179.0), [0.5, 0.5, -0.5, 0.5], [0.1, 0.9, 0.3, -0.2]] {
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        let r = rotation_of(q.map(|v| v / n));
        assert!(close(&rotation_of(quaternion_of(&r)), &r));
    }
}

#[test]
fn bad_keyframes_are_refused_naming_them() {
    for (text, want) in [
        ("0,0,0,0,1,0,0,0\n0,1,0,0,1,0,0,0", "keyframe 1: t"),
        ("0,0,0,0,0,0,0,0", "keyframe 0: quaternion"),
        ("0,0,0,0,1,0,0", "line 1: 7 fields"),
        ("0,0,nan,0,1,0,0,0", "keyframe 0: position"),
        ("", "no keyframes"),
        (
            "{\"t\": 0, \"position\": [0, 0, 0], \"quaternion\": [1, 0, 0, 0], \"speed\": 3}",
            "speed",
        ),
    ] {
        let e = Trajectory::parse(text).expect_err(text);
        assert!(e.contains(want), "{text:?}: {e}");
    }
    // A header line is skipped; JSON lines work.
    let ok = "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,1,0,0,1,0,0,0\n";
    assert_eq!(Trajectory::parse(ok).expect("csv").span(), (0.0, 1.0));
    let json = "{\"t\": 0, \"position\": [0, 0, 0], \"quaternion\": [1, 0, 0, 0]}";
    assert!(Trajectory::parse(json).is_ok());
}

/// A scene file's [[trajectory]] is read, checked, and what drive follows.
#[test]
fn a_scene_file_gives_the_camera_a_trajectory() {
    let base = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/standard.toml"))
        .expect("standard");
    let with = |keys: &str| format!("{base}\n{keys}");
    let keys = "[[trajectory]]\nt = 0.0\nposition = [0.0, 1.2, -3.0]\nquaternion = [1.0, 0.0, 0.0, 0.0]\n\
                [[trajectory]]\nt = 1.0\nposition = [0.2, 1.2, -3.0]\nquaternion = [0.9998477, 0.0, 0.0174524, 0.0]\n";
    let r = host_sim::scene_file::parse(&with(keys)).expect("scene with a trajectory");
    let poses = host_sim::drive_cmd::poses(&r, None, 5).expect("poses");
    assert_eq!(poses.len(), 5);
    assert!((poses[2].translation[0] - 0.1).abs() < 1e-12);
    let far = keys.replace("[0.2, 1.2, -3.0]", "[2000.0, 1.2, -3.0]");
    let e = host_sim::scene_file::parse(&with(&far)).expect_err("too far");
    assert!(e.contains("trajectory keyframe 1: position"), "{e}");
    let back = keys.replace("t = 1.0", "t = -1.0");
    let e = host_sim::scene_file::parse(&with(&back)).expect_err("backwards");
    assert!(e.contains("keyframe 1: t"), "{e}");
}
