//! A small scene every rendering test starts from (96×64 Gray8, two
//! materials, one directional light, no primitives), and a checkered floor.

use hilcam::num::scalar::I32F32;
use hilcam::planner::{Budget, Plan};
use hilcam::render::Override;
use host_sim::harness::{collect, prepare, Collect, Metrics};
use host_sim::reference::render::RefScene;
use host_sim::reference::sampling::Pattern;
use host_sim::scene_file::Resolved;
use host_sim::variant::Variant;

/// The frame rendered as `variant` (its arithmetic, distortion and table)
/// through a pinhole, and its metrics against the reference; `Err` with
/// the renderer's refusal.
#[allow(dead_code)] // not every test binary renders variants
pub fn rendered_as(r: &Resolved, variant: &str) -> Result<(Metrics, Collect), String> {
    let v = Variant::parse(variant).expect("variant");
    let budget = Budget::default();
    let pinhole = |p: &Plan| v.options(p).with(Override::Aperture { points: 0 });
    let (_, plan, frame) = prepare::<I32F32>(r, &budget, pinhole)?;
    let core = collect(&frame).map_err(|e| format!("{}: {e}", r.desc.name))?;
    let rs = RefScene::new(r);
    let rs = rs.with_pattern(Pattern {
        aperture: 0,
        ..rs.pattern
    });
    let reference = rs.render();
    let m = host_sim::harness::compare(r, &rs, &reference, &plan, &budget, &frame, &core);
    Ok((m, core))
}

/// The base scene (no primitives).
pub const BASE: &str = r#"
name = "extreme"
[output]
format = "gray8"
exposure = 800.0
[camera]
width = 96
height = 64
focal_length = 2.4e-3
pitch = 12e-6
f_number = 2.0
focus_distance = 3.0
tolerable_blur = 12e-6
pose = { eye = [0.0123, 1.2, -3.0], target = [0.0, 0.4, 0.0], up = [0.0, 1.0, 0.0] }
[environment]
ambient = 0.2
background = 1.0
[[materials]]
name = "a"
albedo = 0.7
[[materials]]
name = "b"
albedo = 0.2
[[lights]]
kind = "directional"
direction = [0.3, 1.0, -0.5]
irradiance = 6.0
"#;

/// The base scene with `extra` appended and each `(a, b)` replaced once.
pub fn scene(extra: &str, replace: &[(&str, &str)]) -> Resolved {
    try_scene(extra, replace).unwrap_or_else(|e| panic!("{e}"))
}

/// [`scene`], or the loader's error.
#[allow(dead_code)] // not every test binary refuses a scene
pub fn try_scene(extra: &str, replace: &[(&str, &str)]) -> Result<Resolved, String> {
    let mut text = format!("{BASE}{extra}");
    for (a, b) in replace {
        assert!(text.contains(a), "fixture lacks {a:?}");
        text = text.replacen(a, b, 1);
    }
    // One sample a pixel unless the test asks for a pattern.
    super::parse_point(&text)
}

/// An infinite checkered floor at y = 0.
pub const CHECKER_FLOOR: &str = r#"
[[primitives]]
kind = "plane"
material = "a"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
checker = { cell = 0.5, material = "b", u_axis = [1.0, 0.0, 0.0] }
"#;

/// A point light up, right of and in front of the origin.
pub const POINT_LIGHT: &str = r#"
[[lights]]
kind = "point"
position = [1.0, 2.0, -1.5]
intensity = 20.0
"#;

/// A sphere filling most of the frame: its silhouette crosses many pixels
/// where the discriminant is near 0.
pub const TANGENT_SPHERE: &str = r#"
[[primitives]]
kind = "sphere"
material = "a"
centre = [0.0, 0.4, 0.0]
radius = 1.0
"#;

/// A sphere around the camera: every ray meets its inside (the far root).
pub const INSIDE_SPHERE: &str = r#"
[[primitives]]
kind = "sphere"
material = "a"
centre = [0.0123, 1.2, -3.0]
radius = 2.0
"#;

/// Smooth pixels agree within 1 LSB, flags agree, and the edge pixels that
/// differ stay within the issue's 0.05 %.
pub fn agrees(m: &Metrics) {
    agrees_off_edges(m);
    assert!(
        m.edge_pixels_differing_fraction <= 0.0005,
        "{}: {} edge pixels differ",
        m.scene,
        m.edge_pixels_differing
    );
}

/// Smooth pixels agree within 1 LSB and flags agree: differences only where
/// a 1/256 px move changes what the ray sees.
pub fn agrees_off_edges(m: &Metrics) {
    assert!(
        m.max_abs_lsb_smooth <= 1,
        "{}: smooth max {} LSB",
        m.scene,
        m.max_abs_lsb_smooth
    );
    assert_eq!(m.field_flags_differing, 0, "{}", m.scene);
}
