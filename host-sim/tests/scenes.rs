//! Scene files: bad input gives a clear error naming the field and writes
//! nothing; good input writes the four outputs.

use host_sim::scene_file::parse;
use std::process::Command;

const STANDARD: &str = include_str!("../../scenes/standard.toml");

/// (replace, with, expected fragment of the error)
const BAD: &[(&str, &str, &str)] = &[
    ("focal_length = 2.4e-3", "", "focal_length"),
    ("focal_length = 2.4e-3", "focal_length = \"long\"", "focal_length"),
    ("focal_length = 2.4e-3", "focal_length = nan", "camera.focal_length: not a finite number"),
    ("focal_length = 2.4e-3", "focal_length = -2.4e-3", "camera.focal_length: must be greater than zero"),
    ("focal_length = 2.4e-3", "focal_length = 0.0", "camera.focal_length: must be greater than zero"),
    ("focal_length = 2.4e-3", "focal_length = 1e9", "camera.focal_length: outside the supported range"),
    ("radius = 0.4", "radius = inf", "primitives[1].radius: not a finite number"),
    ("radius = 0.4", "radius = -0.4", "primitives[1].radius: outside the supported range"),
    ("radius = 0.4", "radius = 1e12", "primitives[1].radius: outside the supported range"),
    ("intensity = 50.0", "intensity = -1.0", "lights[0].intensity: outside the supported range"),
    ("albedo = 0.8", "albedo = 1.5", "materials[1].albedo: outside the supported range"),
    ("albedo = 0.8", "albedo = [0.8, 0.1, 0.1]", "materials[1].albedo: a colour triple needs the rgb565 format"),
    ("exposure = 800.0", "exposure = nan", "output.exposure: not a finite number"),
    ("format = \"gray8\"", "format = \"gray7\"", "output.format"),
    ("material = \"grey\"", "material = \"gold\"", "primitives[2].material: no material named \"gold\""),
    ("name = \"standard\"", "name = \"standard\"\ncolour = 1", "unknown field `colour`"),
    ("pitch = 12e-6", "pitch = 12e-6\nwidht = 3", "unknown field `widht`"),
    ("distortion = [0.15, 0.05]", "distortion = [0.15, nan]", "camera.distortion: not a finite number"),
    ("width = 160", "width = 0", "camera.width: must be greater than zero"),
    ("width = 160", "width = 70000", "width"),
    (
        "pose = { eye = [0.0, 1.2, -3.0], target = [0.0, 0.4, 0.0], up = [0.0, 1.0, 0.0] }",
        "pose = { position = [0.0, 1.0, -3.0], rotation = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.1], [0.0, 0.0, 1.0]] }",
        "camera.pose.rotation: not orthonormal",
    ),
    (
        "pose = { eye = [0.0, 1.2, -3.0], target = [0.0, 0.4, 0.0], up = [0.0, 1.0, 0.0] }",
        "pose = { eye = [0.0, 1.2, -3.0], target = [0.0, 1.2, -3.0], up = [0.0, 1.0, 0.0] }",
        "camera.pose.target: degenerate",
    ),
    ("centre = [-0.5, 0.4, 0.3]", "centre = [-5000.0, 0.4, 0.3]", "primitives[1].centre: outside the supported range"),
    ("normal = [0.0, 1.0, 0.0]", "normal = [0.0, 0.0, 0.0]", "primitives[0].normal: degenerate"),
];

#[test]
fn each_bad_field_gives_an_error_naming_it() {
    for (from, to, want) in BAD {
        assert!(STANDARD.contains(from), "fixture lacks {from:?}");
        let text = STANDARD.replacen(from, to, 1);
        match parse(&text) {
            Ok(_) => panic!("accepted {to:?}"),
            Err(e) => assert!(
                e.contains(want),
                "for {to:?}: error {e:?} does not mention {want:?}"
            ),
        }
    }
    eprintln!("{} bad scene inputs rejected", BAD.len());
}

#[test]
fn render_writes_nothing_on_bad_input_and_four_files_on_good() {
    let dir = std::env::temp_dir().join(format!("hilcam-render-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("tmp");
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, STANDARD.replace("radius = 0.4", "radius = -1.0")).expect("write");
    let out = dir.join("out-bad");
    let run = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["render", "--scene"])
        .arg(&bad)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("runs");
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("primitives[1].radius"), "{err}");
    assert!(!out.exists(), "partial output written");

    let good = dir.join("good.toml");
    std::fs::write(&good, STANDARD).expect("write");
    let out = dir.join("out-good");
    let run = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["render", "--scene"])
        .arg(&good)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("runs");
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    for f in ["frame.png", "reference.png", "diff.png", "metrics.json"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("metrics.json")).expect("read")).expect("json");
    for key in [
        "width",
        "height",
        "format",
        "stages",
        "max_abs_lsb",
        "rms_lsb",
        "exact_fraction",
        "psnr_db",
        "max_geom_err_px",
        "edge_pixels",
        "edge_pixels_differing",
        "max_abs_lsb_smooth",
        "psnr_db_smooth",
    ] {
        assert!(m.get(key).is_some(), "metrics.json lacks {key}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The benchmark scenes in `docs/bench/` are the standard scene with
/// primitives left out or added, and nothing else changed: the figures
/// `docs/bench/README.md` quotes compare them with it. Fails if the
/// standard scene's camera, lens, lights, materials or exposure change
/// without them (or they without it), and if the content behind the view
/// changes the frame (the README: "the same bytes").
#[test]
fn bench_scenes_are_the_standard_scene_but_for_primitives() {
    let table = |text: &str| -> toml::Table { toml::from_str(text).expect("a scene file parses as TOML") };
    let standard = table(STANDARD);
    let prims = |t: &toml::Table| {
        t.get("primitives")
            .and_then(|p| p.as_array())
            .cloned()
            .unwrap_or_default()
    };
    let rest = |t: &toml::Table| {
        let mut t = t.clone();
        t.remove("name");
        t.remove("primitives");
        t
    };
    let all = prims(&standard);
    // (file, how many of the standard scene's primitives it keeps first, how many it adds)
    let bench: [(&str, &str, usize, usize); 3] = [
        (
            "standard-plane",
            include_str!("../../docs/bench/standard-plane.toml"),
            1,
            0,
        ),
        (
            "standard-one-sphere",
            include_str!("../../docs/bench/standard-one-sphere.toml"),
            2,
            0,
        ),
        (
            "standard-behind",
            include_str!("../../docs/bench/standard-behind.toml"),
            all.len(),
            2,
        ),
    ];
    for (name, text, kept, added) in bench {
        let t = table(text);
        assert_eq!(
            rest(&t),
            rest(&standard),
            "{name}: differs from scenes/standard.toml beyond its primitives"
        );
        let p = prims(&t);
        assert_eq!(p.len(), kept + added, "{name}: primitives");
        assert_eq!(
            p[..kept],
            all[..kept],
            "{name}: the standard scene's first {kept} primitives"
        );
    }
    let frame = |text: &str| {
        let r = parse(text).expect("the scene loads");
        host_sim::harness::render_skipping_stage_errors(&r, &hilcam::planner::Budget::default())
            .expect("the scene renders")
            .core
    };
    let (a, b) = (frame(STANDARD), frame(bench[2].1));
    assert!(
        a.pixels == b.pixels && a.flags == b.flags,
        "standard-behind's frame is not the standard scene's"
    );
}
