//! A small scene every rendering test starts from (96×64 Gray8, two
//! materials, one directional light, no primitives), and a checkered floor.

use host_sim::scene_file::{parse, Resolved};

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
    let mut text = format!("{BASE}{extra}");
    for (a, b) in replace {
        assert!(text.contains(a), "fixture lacks {a:?}");
        text = text.replacen(a, b, 1);
    }
    parse(&text).unwrap_or_else(|e| panic!("{e}"))
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
