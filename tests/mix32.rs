//! The 32-bit per-quantity-format path (`mix32`): the rendering targets on
//! every shipped scene it renders, a typed refusal of the others, and the
//! extremes (far grazing hits, tangent rays, the inside of a sphere, wide
//! angles, saturation, a light at the surface, the lens fold, every shape
//! and pixel format) against the f64 reference.

use crate::common;

use common::fixture::{
    agrees, rendered_as, scene, CHECKER_FLOOR, INSIDE_SPHERE, POINT_LIGHT, TANGENT_SPHERE,
};
use hilcam::num::scalar::I32F32;
use hilcam::planner::Budget;
use hilcam::render::Override;
use hilcam::render::FLAG_OUTSIDE_FIELD;
use hilcam::scene::PixelFormat;
use host_sim::harness::{collect, prepare, Collect, Metrics};
use host_sim::reference::render::RefScene;
use host_sim::scene_file::{load, Resolved};
use host_sim::variant::Variant;

/// The frame rendered on the mix32 path and its metrics against the
/// reference; `Err` with the renderer's refusal. Through a pinhole: some of
/// these geometries put content outside the depth of field (a camera inside
/// a sphere, a floor a few pixels away), and defocus runs in the wide
/// arithmetic only (tests/defocus.rs checks it).
fn mix(r: &Resolved) -> Result<(Metrics, Collect), String> {
    rendered_as(r, "mix32-poly")
}

/// Geometry within 1/256 px, and [`agrees`]: smooth pixels within 1 LSB,
/// flags agree, edge pixels that differ within 0.05 %.
fn meets_targets(m: &Metrics) {
    assert!(
        m.max_geom_err_px <= 1.0 / 256.0,
        "{}: geometry {} px",
        m.scene,
        m.max_geom_err_px
    );
    agrees(m);
}

#[test]
fn shipped_scenes_meet_the_targets() {
    let dir = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes"));
    let mut rendered = Vec::new();
    for name in [
        "standard",
        "checkerboard-barrel",
        "wide-vignetting",
        "spheres-specular",
        "shallow-target",
    ] {
        let r = load(&dir.join(format!("{name}.toml"))).expect("loads");
        let (m, _) = mix(&r).unwrap_or_else(|e| panic!("{name}: {e}"));
        eprintln!(
            "{name}: geom {:.2e} px, max {} / smooth {} LSB, exact {:.5}, edge differing {}",
            m.max_geom_err_px, m.max_abs_lsb, m.max_abs_lsb_smooth, m.exact_fraction, m.edge_pixels_differing
        );
        meets_targets(&m);
        assert!(m.exact_fraction >= 0.99, "{name}: exact {}", m.exact_fraction);
        rendered.push(name);
    }
    assert_eq!(rendered.len(), 5);
}

/// Grazing rays to the horizon of a checkered floor: `t` saturates at
/// 8 192 U, far beyond where the floor's cells alias into edge pixels.
#[test]
fn far_grazing_hits_saturate_without_wrapping() {
    let r = scene(
        CHECKER_FLOOR,
        &[(
            "eye = [0.0123, 1.2, -3.0], target = [0.0, 0.4, 0.0]",
            "eye = [0.0123, 0.0537, -3.0], target = [0.0, 0.0537, 10.0]",
        )],
    );
    let (m, _) = mix(&r).expect("renders");
    meets_targets(&m);
}

#[test]
fn tangent_rays_and_the_inside_of_a_sphere() {
    let tangent = scene(TANGENT_SPHERE, &[]);
    let (m, _) = mix(&tangent).expect("renders");
    meets_targets(&m);
    let inside = scene(
        INSIDE_SPHERE,
        &[("[environment]\nambient = 0.2", "[environment]\nambient = 0.5")],
    );
    let (m, core) = mix(&inside).expect("renders");
    meets_targets(&m);
    assert!(core.pixels.iter().all(|p| *p > 0), "every ray hits the inside");
}

/// Corner slopes of 15: cos⁴α ≈ 2·10⁻⁵ goes to 0 as the reference's does.
#[test]
fn wide_angle_vignetting_to_zero() {
    let r = scene(
        CHECKER_FLOOR,
        &[
            ("focal_length = 2.4e-3", "focal_length = 3.2e-3"),
            ("pitch = 12e-6", "pitch = 1e-3"),
        ],
    );
    let (m, core) = mix(&r).expect("renders");
    meets_targets(&m);
    assert_eq!(core.pixels[0], 0, "corner fully vignetted");
}

/// K = 10⁹ saturates every lit pixel at DN_max in every format (the sum
/// is capped before vignetting, never wrapped); K = 0 gives 0.
#[test]
fn exposure_saturation_in_every_format() {
    for (fmt, bytes) in [
        ("format = \"gray8\"", vec![255u8]),
        ("format = \"gray16\"\nbits = 12", 4095u16.to_le_bytes().to_vec()),
        ("format = \"rgb565\"", 0xFFFFu16.to_le_bytes().to_vec()),
    ] {
        let bright = scene(
            CHECKER_FLOOR,
            &[
                ("exposure = 800.0", "exposure = 1e9"),
                ("format = \"gray8\"", fmt),
            ],
        );
        let (m, core) = mix(&bright).expect("renders");
        assert_eq!(m.max_abs_lsb, 0, "{fmt}");
        assert!(
            core.pixels.chunks(bytes.len()).all(|p| p == bytes),
            "{fmt}: not all saturated"
        );
        let dark = scene(
            CHECKER_FLOOR,
            &[
                ("exposure = 800.0", "exposure = 0.0"),
                ("format = \"gray8\"", fmt),
            ],
        );
        let (_, core) = mix(&dark).expect("renders");
        assert!(core.pixels.iter().all(|p| *p == 0), "{fmt}");
    }
}

/// A checkered floor lit by a point light `height` metres above it, on
/// the mix32 path against the reference.
fn floor_lit_from(height: f64) -> Metrics {
    let r = scene(
        &format!(
            "{CHECKER_FLOOR}[[lights]]\nkind = \"point\"\nposition = [0.1, {height}, 0.2]\nintensity = 5.0\n"
        ),
        &[],
    );
    mix(&r).expect("renders").0
}

/// A point light 1 mm above a lit floor: `1/r³` of 10⁹ m⁻³ saturates the
/// pixels under it, as the reference's irradiance does; elsewhere within
/// 1 LSB.
#[test]
fn point_light_at_the_surface() {
    meets_targets(&floor_lit_from(0.001));
}

/// A point light 20 µm above the floor, under 2⁻¹⁰ of the frame's length
/// unit: the floor's `n·l` is taken per pixel there, not as the plane's
/// per-frame constant; within the targets as well.
#[test]
fn point_light_in_the_plane() {
    meets_targets(&floor_lit_from(0.00002));
}

/// A fold inside the sensor: the pixels beyond it are flagged and black,
/// the flags agree with the reference's.
#[test]
fn lens_fold_inside_the_sensor() {
    let r = scene(
        CHECKER_FLOOR,
        &[(
            "tolerable_blur = 12e-6",
            "tolerable_blur = 12e-6\ndistortion = [-6.0, 0.0]",
        )],
    );
    let (m, core) = mix(&r).expect("renders");
    assert!(m.outside_field_pixels > 100, "{}", m.outside_field_pixels);
    meets_targets(&m);
    for (p, f) in core.pixels.iter().zip(&core.flags) {
        if f & FLAG_OUTSIDE_FIELD != 0 {
            assert_eq!(*p, 0);
        }
    }
}

/// Discs and rectangles (with a checker), a point and a directional light,
/// in colour.
#[test]
fn discs_rectangles_and_colour() {
    let r = scene(
        r#"
[[primitives]]
kind = "disc"
material = "a"
centre = [-0.4, 0.3, 0.2]
normal = [0.2, 1.0, -0.3]
radius = 0.35
[[primitives]]
kind = "rectangle"
material = "a"
centre = [0.5, 0.5, 0.4]
normal = [0.0, 0.3, -1.0]
u_axis = [1.0, 0.0, 0.0]
size = [0.6, 0.5]
checker = { cell = 0.07, material = "b", u_axis = [1.0, 0.0, 0.0] }
[[lights]]
kind = "point"
position = [1.0, 2.0, -1.5]
intensity = 20.0
"#,
        &[("format = \"gray8\"", "format = \"rgb565\"")],
    );
    let (m, _) = mix(&r).expect("renders");
    meets_targets(&m);
    assert!(m.exact_fraction >= 0.99, "exact {}", m.exact_fraction);
}

/// The path renders a line in chunks of 32 pixels: widths below one chunk
/// and with a partial last chunk (in one and in three channels, one sample
/// a pixel and the sampled loop's 4×4 grid) render every pixel, the hits of
/// every primitive pass, within the targets. (The sampled loop handed the
/// byte writer its whole 32-word buffer: in Gray8 a last chunk's final
/// `len mod 4` pixels were left 0 — width 17's last column, 31's last
/// three.)
#[test]
fn lines_that_are_not_whole_chunks() {
    let sampled = "\n[sampling]\nedge_error = 0.125\n";
    for (width, sampling) in [
        ("7", ""),
        ("45", ""),
        ("71", ""),
        ("1", sampled),
        ("2", sampled),
        ("17", sampled),
        ("31", sampled),
        ("33", sampled),
    ] {
        for fmt in ["format = \"gray8\"", "format = \"rgb565\""] {
            let r = scene(
                &format!("{CHECKER_FLOOR}{TANGENT_SPHERE}{POINT_LIGHT}{sampling}"),
                &[
                    ("width = 96", &format!("width = {width}")),
                    ("format = \"gray8\"", fmt),
                    (
                        "tolerable_blur = 12e-6",
                        "tolerable_blur = 12e-6\ndistortion = [0.15, 0.05]",
                    ),
                ],
            );
            let (m, _) = mix(&r).expect("renders");
            assert_eq!(
                m.stages.iter().any(|s| s.starts_with("sample:")),
                !sampling.is_empty(),
                "{width} {fmt}: {:?}",
                m.stages
            );
            meets_targets(&m);
            assert!(
                m.exact_fraction >= 0.99,
                "{width} {fmt}{sampling}: exact {}",
                m.exact_fraction
            );
        }
    }
}

/// With the principal point at the sensor's centre the right half of a line
/// takes the left half's rays mirrored: in a scene symmetric about the
/// camera's vertical plane columns `i` and `W − 1 − i` then agree within 1
/// LSB (the hit points' rounding is not odd: a few differ by 1) with the
/// same flags, at widths below, at and across chunks of 32 (an odd width's
/// middle column traced on its own), in one and three channels, distorted
/// (with the lens fold inside the sensor) and not — and within the targets
/// against the reference, which traces every column.
#[test]
fn a_centred_principal_point_mirrors_the_rays() {
    const SYMMETRIC: &str = r#"
[[primitives]]
kind = "plane"
material = "b"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
[[primitives]]
kind = "sphere"
material = "a"
centre = [0.0, 0.4, 0.0]
radius = 0.6
[[lights]]
kind = "point"
position = [0.0, 2.0, -1.5]
intensity = 20.0
"#;
    for width in [1, 2, 31, 33, 64, 65, 96] {
        for (fmt, format) in [("gray8", PixelFormat::Gray8), ("rgb565", PixelFormat::Rgb565)] {
            for distortion in ["", "\ndistortion = [0.15, 0.05]", "\ndistortion = [-6.0, 0.0]"] {
                let r = scene(
                    SYMMETRIC,
                    &[
                        ("eye = [0.0123, 1.2, -3.0]", "eye = [0.0, 1.2, -3.0]"),
                        ("direction = [0.3, 1.0, -0.5]", "direction = [0.0, 1.0, -0.5]"),
                        ("width = 96", &format!("width = {width}")),
                        ("format = \"gray8\"", &format!("format = \"{fmt}\"")),
                        (
                            "tolerable_blur = 12e-6",
                            &format!("tolerable_blur = 12e-6{distortion}"),
                        ),
                    ],
                );
                let what = format!("width {width}, {fmt}{distortion}");
                let (m, core) = mix(&r).unwrap_or_else(|e| panic!("{what}: {e}"));
                meets_targets(&m);
                assert!(m.exact_fraction >= 0.99, "{what}: exact {}", m.exact_fraction);
                let w = width as usize;
                let dn = core.dn(format);
                let (mut pairs, mut differ) = (0, 0);
                for (j, (line, flags)) in dn.chunks(w).zip(core.flags.chunks(w)).enumerate() {
                    for i in 0..w / 2 {
                        let (a, b) = (line[i], line[w - 1 - i]);
                        let d = (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0);
                        assert!(
                            d <= 1,
                            "{what}: line {j}, columns {i} and {}: {a:?} {b:?}",
                            w - 1 - i
                        );
                        assert_eq!(
                            flags[i],
                            flags[w - 1 - i],
                            "{what}: line {j}, flags of column {i}"
                        );
                        pairs += 1;
                        differ += (d > 0) as usize;
                    }
                }
                assert!(
                    differ * 100 <= pairs,
                    "{what}: {differ} of {pairs} mirrored pairs differ"
                );
                // Not a uniform frame: the sphere's shading varies along
                // a line (in RGB565 the lit sphere saturates).
                assert!(
                    w < 31 || format == PixelFormat::Rgb565 || core.pixels.windows(2).any(|p| p[0] != p[1]),
                    "{what}"
                );
            }
        }
    }
}

/// A mirrored frame's `undistorted` (the geometry the metrics check):
/// column `W − 1` is column 0 mirrored, and a pixel past the sensor's
/// last column or line is `None` (it overflowed the column's slope).
#[test]
fn mirrored_undistorted_columns() {
    let r = scene(
        CHECKER_FLOOR,
        &[(
            "tolerable_blur = 12e-6",
            "tolerable_blur = 12e-6\ndistortion = [0.15, 0.05]",
        )],
    );
    let v = Variant::parse("mix32-poly").expect("variant");
    let (_, _, frame) = prepare::<I32F32>(&r, &Budget::default(), |p| {
        v.options(p).with(Override::Aperture { points: 0 })
    })
    .expect("prepares");
    for j in [0, 31, 63] {
        let (left, right) = (frame.undistorted(0, j), frame.undistorted(95, j));
        assert!(left.is_some_and(|(x, _)| x != 0));
        assert_eq!(left.map(|(x, y)| (-x, y)), right, "line {j}");
        assert_eq!(frame.undistorted(96, j), None);
        assert_eq!(frame.undistorted(u16::MAX, j), None);
        assert_eq!(frame.undistorted(0, 64 + j), None);
    }
}

/// What the formats cannot hold is refused when the frame is prepared, with
/// a typed error: a distortion whose factor `g` leaves ±8, and a sphere
/// smaller than 2⁻¹⁰ of the frame's length unit (set by a light 900 m away).
#[test]
fn outside_the_formats_is_a_typed_error() {
    let strong = scene(
        CHECKER_FLOOR,
        &[(
            "tolerable_blur = 12e-6",
            "tolerable_blur = 12e-6\ndistortion = [10.0, 100.0]",
        )],
    );
    let tiny = scene(
        "[[primitives]]\nkind = \"sphere\"\nmaterial = \"a\"\ncentre = [0.0, 0.4, 0.0]\nradius = 1e-3\n\
         [[lights]]\nkind = \"point\"\nposition = [900.0, 0.0, 0.0]\nintensity = 5.0\n",
        &[],
    );
    for r in [strong, tiny] {
        let e = mix(&r).expect_err("refused");
        assert!(e.contains("OutsideFormat"), "{e}");
        // The generic path renders it.
        assert!(host_sim::harness::render_skipping_stage_errors(&r, &Budget::default()).is_ok());
    }
}

/// Parallel rays: an orthographic (telecentric) camera over spheres, a
/// disc and a checkered rectangle, and a weak-perspective one (the
/// planner's choice for a shallow scene is covered by the shipped
/// `shallow-target`).
#[test]
fn parallel_rays_orthographic() {
    let prims = r#"
[[primitives]]
kind = "sphere"
material = "a"
centre = [-0.2, 0.3, 0.1]
radius = 0.25
[[primitives]]
kind = "disc"
material = "b"
centre = [0.3, 0.2, 0.2]
normal = [0.2, 1.0, -0.3]
radius = 0.2
[[primitives]]
kind = "rectangle"
material = "a"
centre = [0.1, 0.6, 0.5]
normal = [0.0, 0.3, -1.0]
u_axis = [1.0, 0.0, 0.0]
size = [0.6, 0.5]
checker = { cell = 0.07, material = "b", u_axis = [1.0, 0.0, 0.0] }
"#;
    let r = scene(
        &format!("{CHECKER_FLOOR}{prims}{POINT_LIGHT}"),
        &[(
            "tolerable_blur = 12e-6",
            "tolerable_blur = 12e-6\nmodel = \"orthographic\"\northographic_scale = 1.0e-3",
        )],
    );
    let (m, _) = mix(&r).expect("renders");
    meets_targets(&m);
    assert!(m.exact_fraction >= 0.99, "exact {}", m.exact_fraction);
}

/// The normalized Phong lobe under a point and a directional light, for
/// exponents 0, 1, 40 and 1000, in gray8 and RGB565, a sphere and a
/// plane. (In 12 bits and more, a sharp lobe magnifies the hit point's
/// 2⁻¹⁸ U rounding past 1 LSB: s = 40 measured 2 LSB, s = 1 000 18 LSB —
/// the planner's error model covers that and falls back to the wide path.)
#[test]
fn specular_lobes() {
    for exponent in [0, 1, 40, 1000] {
        for fmt in ["format = \"gray8\"", "format = \"rgb565\""] {
            let r = scene(
                &format!("{CHECKER_FLOOR}{TANGENT_SPHERE}{POINT_LIGHT}"),
                &[
                    ("format = \"gray8\"", fmt),
                    (
                        "albedo = 0.7",
                        &format!("albedo = 0.7\nspecular = 0.9\nmix = 0.3\nexponent = {exponent}"),
                    ),
                ],
            );
            let (m, _) = mix(&r).expect("renders");
            meets_targets(&m);
        }
    }
}

/// A channel whose albedo is 0 stays dark (a zero factor with a large
/// exponent once read as saturation).
#[test]
fn a_zero_albedo_channel_stays_dark() {
    let r = scene(
        &format!("{CHECKER_FLOOR}{POINT_LIGHT}"),
        &[
            ("format = \"gray8\"", "format = \"rgb565\""),
            ("albedo = 0.7", "albedo = [0.7, 0.0, 0.3]"),
            ("albedo = 0.2", "albedo = [0.2, 0.0, 0.1]"),
            ("ambient = 0.2", "ambient = 0.0"),
            ("background = 1.0", "background = 0.0"),
        ],
    );
    let (m, core) = mix(&r).expect("renders");
    meets_targets(&m);
    let green = core
        .pixels
        .chunks(2)
        .map(|p| (u16::from_le_bytes([p[0], p[1]]) >> 5) & 63);
    assert!(green.into_iter().all(|g| g == 0), "green must stay 0");
}

/// A plane without a checker lit by a directional light and by none to
/// two point lights (2⁻⁹ of the frame's length unit to metres above it,
/// in front of or behind it: a plane whose side the rays see has none
/// takes `closed_flat`), seen from above or from below (facing away), with
/// and without distortion: every pixel that sees it and nothing else is
/// shaded in closed form (`Frame::closed_plane`). In 16 bits and in
/// RGB565, at exposures that put the lit plane up to full scale and past
/// it, its smooth pixels are within the fast candidate's predicted error
/// (+ rounding) of the reference.
#[test]
fn a_point_lit_plane_in_closed_form_within_the_prediction() {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let mut config = Config::with_cases(120);
    config.failure_persistence = None;
    let mut runner = TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    let light = (
        -3.0f64..3.0,
        0.0f64..1.0,
        -3.0f64..3.0,
        any::<bool>(),
        1.0f64..100.0,
    );
    let case = (
        (-0.3f64..0.3, -0.3f64..0.3),
        (0.05f64..2.0, any::<bool>(), -1.0f64..1.0),
        prop::collection::vec(light, 0..3),
        prop::option::of(0.0f64..0.3),
        common::log_uniform(30.0, 3000.0),
        prop::bool::weighted(0.25),
    );
    let worst = std::cell::Cell::new(0.0f64);
    let result = runner.run(&case, |((nx, nz), (height, below, ex), lights, k1, exposure, rgb)| {
        // Heights from 2^-8 m, 2^-10 of the frame's unit or more (the
        // content lies within 8 m of the camera: U ≤ 1 m), up to 1 m.
        let unit_floor = libm::ldexp(1.0, -8);
        let format = if rgb {
            "format = \"rgb565\""
        } else {
            "format = \"gray16\"\nbits = 16"
        };
        let mut t = format!(
            "name = \"closed\"\n[output]\n{format}\nexposure = {exposure}\n[camera]\n\
             width = 64\nheight = 48\nfocal_length = 2.4e-3\npitch = 24e-6\nf_number = 2.0\n\
             focus_distance = 3.0\ntolerable_blur = 24e-6\n"
        );
        if let Some(k1) = k1 {
            t += &format!("distortion = [{k1}, 0.02]\n");
        }
        let ey = if below { -height } else { height };
        let albedo = if rgb { "[0.7, 0.5, 0.3]" } else { "0.7" };
        t += &format!(
            "pose = {{ eye = [{ex}, {ey}, -3.0], target = [0.0, 0.0, 0.0], up = [0.0, 1.0, 0.0] }}\n\
             [environment]\nambient = 0.1\nbackground = 0.3\n\
             [[materials]]\nname = \"a\"\nalbedo = {albedo}\n\
             [[primitives]]\nkind = \"plane\"\nmaterial = \"a\"\npoint = [0.0, 0.0, 0.0]\nnormal = [{nx}, 1.0, {nz}]\n\
             [[lights]]\nkind = \"directional\"\ndirection = [0.3, 1.0, -0.5]\nirradiance = 2.0\n"
        );
        for (x, h, z, behind, i) in &lights {
            // Over the plane y = 0 (tilted by n): lifted along y by h m, at
            // least 2^-9 U.
            let h = h.max(unit_floor) * if *behind { -1.0 } else { 1.0 };
            let y = h - (nx * x + nz * z);
            t += &format!("[[lights]]\nkind = \"point\"\nposition = [{x}, {y}, {z}]\nintensity = {i}\n");
        }
        let r = crate::common::parse_point(&t).unwrap_or_else(|e| panic!("{e}:\n{t}"));
        let v = Variant::parse("mix32-poly").expect("variant");
        let budget = Budget::default();
        let (_, plan, frame) = prepare::<I32F32>(&r, &budget, |p| v.options(p)).map_err(TestCaseError::fail)?;
        prop_assert_eq!(frame.closed_plane(), Some(0), "not in closed form:\n{}", t);
        let fast = plan
            .candidates
            .iter()
            .find(|c| c.arithmetic == hilcam::render::Arithmetic::Fast)
            .expect("a fast candidate");
        let core = collect(&frame).map_err(TestCaseError::fail)?;
        // The host's build for this processor's x86-64 level (its rays in
        // vector lanes) renders the baseline build's bytes.
        let (w, h) = frame.size();
        let (mut line, mut flags) = (vec![0u8; frame.line_bytes()], vec![0u8; w as usize]);
        let mut base = Vec::new();
        for j in 0..h {
            frame.render_line(j, &mut line, &mut flags).map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
            base.extend_from_slice(&line);
        }
        prop_assert!(core.pixels == base, "the x86-64 level's bytes differ:\n{}", t);
        let rs = RefScene::new(&r);
        let reference = rs.render();
        let m = host_sim::harness::compare(&r, &rs, &reference, &plan, &budget, &frame, &core);
        // The largest ratio in 16 bits (RGB565's 1 LSB roundings of a tiny
        // predicted error are near 1 and say nothing).
        if !rgb {
            worst.set(worst.get().max(m.max_abs_lsb_smooth as f64 / (fast.lsb + 1.0)));
        }
        prop_assert!(
            m.max_abs_lsb_smooth as f64 <= fast.lsb.floor() + 1.0,
            "smooth {} LSB, predicted {}:\n{}",
            m.max_abs_lsb_smooth,
            fast.lsb,
            t
        );
        Ok(())
    });
    eprintln!(
        "closed form, 16 bits: largest measured / (predicted + 1) {:.3}",
        worst.get()
    );
    if let Err(e) = result {
        panic!("{e}");
    }
}

/// A plane without a checker lit by a point light 20 µm above it, under
/// 2⁻¹⁰ of the frame's length unit: its `n·l` is not a per-frame constant
/// there, so it is not shaded in closed form (`Frame::closed_plane` is
/// `None`) but by the general path, within the targets; 1 m above it, it
/// is.
#[test]
fn a_light_at_the_plane_leaves_the_closed_form() {
    let floor = "[[primitives]]\nkind = \"plane\"\nmaterial = \"a\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n";
    for (height, closed) in [(0.00002, None), (1.0, Some(0))] {
        let r = scene(
            &format!(
                "{floor}[[lights]]\nkind = \"point\"\nposition = [0.1, {height}, 0.2]\nintensity = 5.0\n"
            ),
            &[],
        );
        let v = Variant::parse("mix32-poly").expect("variant");
        let (_, _, frame) = prepare::<I32F32>(&r, &Budget::default(), |p| {
            v.options(p).with(Override::Aperture { points: 0 })
        })
        .expect("prepares");
        assert_eq!(frame.closed_plane(), closed, "light {height} m above the floor");
        meets_targets(&mix(&r).expect("renders").0);
    }
}

/// Content around the base camera (eye `(0.0123, 1.2, −3)`, looking along
/// `f ≈ (−0.004, −0.258, 0.966)`): a sphere in front; a sphere wholly behind
/// the lens plane (camera frame `z = −2 ± 0.5`) and a wall 3 m behind the
/// eye, which no ray meets and which are tested on no chunk
/// (`render::behind_lens`, `render::plane_unseen`); a sphere whose centre
/// is behind the lens plane (camera frame `(0, −1, −0.05)`, radius 1) but
/// which reaches in front of it, 1.25 mm below the camera, across the
/// bottom of the view; and a wall to the right, turned away so that the
/// rays meet it only beyond a slope of about 0.2 (the view reaches 0.25),
/// 20 m away: seen only in the right-hand columns.
const BEHIND_THE_LENS: &str = r#"
[[primitives]]
kind = "sphere"
material = "a"
centre = [0.0, 0.4, 0.0]
radius = 0.5
[[primitives]]
kind = "sphere"
material = "b"
centre = [0.0202, 1.715, -4.932]
radius = 0.5
[[primitives]]
kind = "sphere"
material = "b"
centre = [0.0125, 0.2467, -3.306]
radius = 1.0
[[primitives]]
kind = "plane"
material = "b"
point = [0.0, 0.0, -6.0]
normal = [0.0, 0.0, 1.0]
[[primitives]]
kind = "plane"
material = "b"
point = [-0.9, 1.2, -3.0]
normal = [0.9785, 0.0, 0.206]
"#;

/// What lies behind the view is culled, what reaches into it from behind
/// is not: against the reference, which tests every ray against every
/// primitive (culled wrongly, the near sphere or the turned wall would be
/// background).
#[test]
fn content_behind_the_view_is_culled_what_reaches_into_it_is_not() {
    // (Without shadows: the wall behind the camera would shadow the sun
    // everywhere in front of it, which is not what this is about.)
    let r = scene(
        BEHIND_THE_LENS,
        &[("[environment]", "[environment]\nshadows = false")],
    );
    // The wide arithmetic culls by the same bounds.
    let (m, _) = rendered_as(&r, "i32f32-poly").expect("renders");
    meets_targets(&m);
    let (m, core) = mix(&r).expect("renders");
    meets_targets(&m);
    // Both are seen: the background (radiance 1) is 134 DN and more here,
    // the dark material b below 60.
    let (w, h) = (96, 64);
    let dark = |row: &[u8]| row.iter().filter(|p| **p < 100).count();
    let bottom = &core.pixels[(h - 1) * w..h * w];
    assert_eq!(
        dark(bottom),
        w,
        "the near sphere across the bottom line: {bottom:?}"
    );
    let top = &core.pixels[..w];
    assert!(
        (3..12).contains(&dark(top)) && top.iter().rev().take(3).all(|p| *p < 100),
        "the turned wall in the right-hand columns: {top:?}"
    );
}
