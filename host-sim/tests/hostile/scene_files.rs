//! Scene files every command reads: wrong shapes, duplicate names, odd paths, size caps, cameras the renderer cannot image, the core's errors in the file's names.

use super::*;

/// Arrays longer or shorter than the field holds are errors naming the
/// field (OpenCV's five distortion coefficients used to render with two).
#[test]
fn arrays_of_the_wrong_length_are_refused_naming_the_field() {
    let s = standard();
    let cases: [(&str, &str, &str, &str); 8] = [
        (
            "opencv-distortion",
            "distortion = [0.15, 0.05]",
            "distortion = [0.15, 0.05, 0.001, 0.002, 0.01]",
            "distortion",
        ),
        (
            "short-distortion",
            "distortion = [0.15, 0.05]",
            "distortion = [0.15]",
            "distortion",
        ),
        (
            "eye-4",
            "eye = [0.0, 1.2, -3.0]",
            "eye = [0.0, 1.2, -3.0, 77]",
            "eye",
        ),
        (
            "target-2",
            "target = [0.0, 0.4, 0.0]",
            "target = [0.0, 0.4]",
            "target",
        ),
        ("pitch-3", "pitch = 12e-6", "pitch = [12e-6, 12e-6, 1.0]", "pitch"),
        (
            "light-position-junk",
            "position = [2.0, 3.0, -2.0]",
            "position = [2.0, 3.0, -2.0, 5.0]",
            "position",
        ),
        (
            "colour-4",
            "ambient = 0.2",
            "ambient = [0.2, 0.2, 0.2, 0.2]",
            "ambient",
        ),
        (
            "normal-4",
            "normal = [0.0, 1.0, 0.0]",
            "normal = [0.0, 1.0, 0.0, 0.0]",
            "normal",
        ),
    ];
    for (name, from, to, field) in cases {
        assert!(s.contains(from), "{name}: standard.toml lacks {from}");
        refused(name, &s.replacen(from, to, 1), &[field, "exactly"]);
    }
    // A rotation matrix with a fourth column.
    let pose = s.lines().find(|l| l.starts_with("pose = ")).expect("pose");
    refused(
        "rotation-3x4",
        &s.replace(
            pose,
            "pose = { position = [0.0, 1.0, -3.0], rotation = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] }",
        ),
        &["rotation", "exactly 3 numbers in a row"],
    );
}

/// Two materials of one name: an error naming both, not the first winning.
#[test]
fn duplicate_material_names_are_refused_naming_both() {
    let s = standard();
    let dup = s.replacen(
        "[[materials]]",
        "[[materials]]\nname = \"floor\"\nalbedo = 0.9\n\n[[materials]]",
        1,
    );
    refused(
        "duplicate-material",
        &dup,
        &["materials[1].name", "materials[0]", "\"floor\""],
    );
}

/// Odd scene paths: a directory, an empty file, bytes that are not UTF-8,
/// a file that does not exist: each an error naming the path.
#[test]
fn odd_scene_paths_are_errors_naming_them() {
    let dir = scratch("odd-paths");
    let empty = write_scene(&dir, "empty.toml", "");
    let binary = dir.join("binary.toml");
    std::fs::write(&binary, [0xff, 0xfe, 0x00, 0x80]).expect("write");
    let out = dir.join("out");
    for (scene, what) in [
        (dir.to_str().expect("utf-8").to_string(), "Is a directory"),
        (empty.to_str().expect("utf-8").to_string(), "missing"),
        (binary.to_str().expect("utf-8").to_string(), "not UTF-8"),
        (
            dir.join("nope.toml").to_str().expect("utf-8").to_string(),
            "No such file",
        ),
    ] {
        let r = run(&["render", "--scene", &scene, "--out", out.to_str().expect("utf-8")]);
        assert!(r.failed_cleanly(), "{scene}: exit {:?}: {}", r.code, r.stderr);
        assert!(
            r.stderr.contains(&scene) && r.stderr.contains(what),
            "{scene}: {}",
            r.stderr
        );
        assert!(!out.exists());
    }
}

/// Scene files are capped at 1 MiB (docs/scenes.md): a larger file, or an
/// endless one, is refused at once, naming it.
#[test]
fn scene_files_are_size_capped() {
    let dir = scratch("size-cap");
    let mut big = standard();
    big.push_str(&format!("# {}\n", "x".repeat(2 << 20)));
    let p = write_scene(&dir, "big.toml", &big);
    let out = dir.join("out");
    for scene in [p.to_str().expect("utf-8"), "/dev/zero"] {
        let r = run(&["render", "--scene", scene, "--out", out.to_str().expect("utf-8")]);
        assert!(r.failed_cleanly(), "{scene}: exit {:?}: {}", r.code, r.stderr);
        assert!(
            r.stderr.contains(scene) && r.stderr.contains("larger than 1048576 bytes"),
            "{}",
            r.stderr
        );
        assert!(r.max_rss_kib < 64 * 1024, "{scene}: {} KiB", r.max_rss_kib);
        assert!(!out.exists());
    }
}

/// Cameras inside the documented per-field ranges that the renderer cannot
/// image are refused at load, naming the file and the fields, not with
/// `cannot render: FieldTooWide` after planning.
#[test]
fn cameras_the_renderer_cannot_image_are_refused_at_load() {
    let s = standard();
    let cases = [
        ("pitch-1mm", s.replacen("pitch = 12e-6", "pitch = 1e-3", 1)),
        (
            "16384x1",
            s.replacen("width = 160", "width = 16384", 1)
                .replacen("height = 120", "height = 1", 1),
        ),
        (
            "principal-point-extreme",
            s.replacen(
                "distortion = [0.15, 0.05]",
                "distortion = [0.15, 0.05]\nprincipal_point = [-16384.0, 32767.0]",
                1,
            ),
        ),
    ];
    for (name, text) in cases {
        refused(
            name,
            &text,
            &["camera.pitch", "camera.focal_length", "field too wide"],
        );
    }
}

/// The core's parameter names are translated to the scene file's keys.
#[test]
fn core_errors_use_the_scene_files_names() {
    let s = standard();
    let pose = s.lines().find(|l| l.starts_with("pose = ")).expect("pose");
    let cases = [
        (
            "pp-nan",
            s.replacen(
                "distortion = [0.15, 0.05]",
                "distortion = [0.15, 0.05]\nprincipal_point = [nan, 0.0]",
                1,
            ),
            "camera.principal_point",
            "principal_x",
        ),
        (
            "pitch-inf",
            s.replacen("pitch = 12e-6", "pitch = [12e-6, inf]", 1),
            "camera.pitch",
            "pitch_y",
        ),
        (
            "angle-nan",
            s.replace(
                pose,
                "pose = { position = [0.0, 1.0, -3.0], yaw_pitch_roll = [nan, 0.0, 0.0] }",
            ),
            "camera.pose.yaw_pitch_roll",
            "angle",
        ),
        (
            "eye-nan",
            s.replacen("eye = [0.0, 1.2, -3.0]", "eye = [nan, 1.2, -3.0]", 1),
            "camera.pose.eye",
            "translation",
        ),
    ];
    for (name, text, want, not) in cases {
        let dir = scratch(name);
        let scene = write_scene(&dir, "scene.toml", &text);
        let r = run(&[
            "render",
            "--scene",
            scene.to_str().expect("utf-8"),
            "--out",
            dir.join("out").to_str().expect("utf-8"),
        ]);
        assert!(r.failed_cleanly(), "{name}: exit {:?}: {}", r.code, r.stderr);
        assert!(
            r.stderr.contains(&format!("{want}:")) && !r.stderr.contains(&format!("{not}:")),
            "{name}: {}",
            r.stderr
        );
    }
    // A far target is a direction, not an error blamed on `up`.
    let far = s.replacen("target = [0.0, 0.4, 0.0]", "target = [0.0, 0.4, 1e300]", 1);
    let dir = scratch("far-target");
    let scene = write_scene(&dir, "scene.toml", &far);
    let r = run(&[
        "render",
        "--scene",
        scene.to_str().expect("utf-8"),
        "--out",
        dir.join("out").to_str().expect("utf-8"),
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(
        r.stdout.contains("smooth: max_lsb=0") || r.stdout.contains("smooth: max_lsb=1"),
        "{}",
        r.stdout
    );
}

/// A scene's name names output files: a path separator, a control
/// character, a leading dot or 65 characters are refused naming `name`
/// (a name `a/../b` would have made `hil` write outside `--out`).
#[test]
fn scene_names_that_could_not_name_a_file_are_refused() {
    let long = "x".repeat(65);
    for (k, bad) in ["../escape", "a/b", "line\\nbreak", ".hidden", "", long.as_str()]
        .iter()
        .enumerate()
    {
        let text = standard().replacen("name = \"standard\"", &format!("name = \"{bad}\""), 1);
        let r = refused(
            &format!("scene-name-{k}"),
            &text,
            &["name:", "is not a scene name"],
        );
        assert!(r.stderr.len() < 600, "{bad:?}: the message echoes the whole name");
    }
}
