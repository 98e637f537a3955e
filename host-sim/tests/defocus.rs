//! Defocus (camera-model.md §8) as its users check it:
//! - edge spread: a slanted step edge at depth `Z`, rendered by the default
//!   path (the planner's aperture pattern), spreads over `β(Z) f / s`
//!   pixels within 5 % over 1–20 px, in front of and behind focus, and no
//!   pixel lies farther from the uniform disc's edge-spread function than
//!   the planner's predicted placement error;
//! - with the default, area-integrated sampling, the same edge at 0.5–20 px
//!   of blur measures its diameter within 2 % and stays within the plan's
//!   bound of the converged reference (16×16 samples × 1 024 aperture
//!   points);
//! - targets at §4's near and far depth-of-field planes spread by
//!   `b̃ / ẑ(Ẑ)` (normalized);
//! - the shipped shallow-depth-of-field scene against the reference, which
//!   samples the aperture with the same spiral; scenes within their depth
//!   of field pay nothing.

use hilcam::num::scalar::I32F32;
use hilcam::planner::Budget;
use hilcam::render::Override;
use host_sim::harness::{collect, prepare};
use host_sim::reference::lens::ThinLens;
use host_sim::reference::render::RefScene;

const WIDTH: usize = 128;
const HEIGHT: usize = 48;
/// 16 mm on 10 µm pixels.
const F: f64 = 16e-3;
const FX: f64 = F / 10e-6;
/// F/1: d = 16 mm; β f/s reaches 25.6 px at infinity.
const D: f64 = 16e-3;
const FOCUS: f64 = 1.0;

/// A camera at the origin looking along +z at a bright rectangle at depth
/// `z` (`edge`: its left edge through the axis, slanted 5°; otherwise
/// filling the view), 16-bit, lit along the axis so that its radiance is
/// uniform.
fn scene(z: f64, tolerable_blur: f64, edge: bool) -> String {
    let (c, s) = (5f64.to_radians().cos(), 5f64.to_radians().sin());
    let (centre, size) = if edge {
        ([0.05 * z * c, 0.05 * z * s, z], [0.1 * z, 0.1 * z])
    } else {
        ([0.0, 0.0, z], [0.2 * z, 0.2 * z])
    };
    format!(
        r#"
name = "edge"
[output]
format = "gray16"
bits = 16
exposure = 20000.0
[camera]
width = {WIDTH}
height = {HEIGHT}
focal_length = {F}
pitch = 10e-6
f_number = 1.0
focus_distance = {FOCUS}
tolerable_blur = {tolerable_blur}
pose = {{ eye = [0.0, 0.0, 0.0], target = [0.0, 0.0, 1.0], up = [0.0, 1.0, 0.0] }}
[environment]
ambient = 0.0
background = 0.0
[[materials]]
name = "white"
albedo = 0.8
[[lights]]
kind = "directional"
direction = [0.0, 0.0, -1.0]
irradiance = 10.0
[[primitives]]
kind = "rectangle"
material = "white"
centre = [{}, {}, {}]
normal = [0.0, 0.0, -1.0]
u_axis = [{c}, {s}, 0.0]
size = [{}, {}]
"#,
        centre[0], centre[1], centre[2], size[0], size[1]
    )
}

/// The frame's 16-bit values and the aperture points it was rendered with
/// (`points`: forced, else the planner's), with the planner's predicted
/// placement error, px.
fn render(text: &str, points: Option<u16>) -> (Vec<f64>, u16, f64) {
    let (v, aperture, plan) = render_resolved(&parse(text).expect("scene"), points);
    (v, aperture, plan.defocus.err_px)
}

/// [`render`] of a parsed scene: the values, the aperture points and the
/// plan.
fn render_resolved(
    r: &host_sim::scene_file::Resolved,
    points: Option<u16>,
) -> (Vec<f64>, u16, hilcam::planner::Plan) {
    let (_, plan, f) = prepare::<I32F32>(r, &Budget::default(), |p| match points {
        Some(points) => p.options.with(Override::Aperture { points }),
        None => p.options,
    })
    .expect("prepares");
    let c = collect(&f).expect("renders");
    let v = c
        .pixels
        .chunks_exact(2)
        .map(|b| f64::from(u16::from_le_bytes([b[0], b[1]])))
        .collect();
    (v, f.stages().aperture, plan)
}

/// The uniform disc's edge-spread function, diameter `b` px, at `s` px
/// from the edge (towards the bright side).
fn esf(b: f64, s: f64) -> f64 {
    let x = (2.0 * s / b).clamp(-1.0, 1.0);
    0.5 + (x * (1.0 - x * x).sqrt() + x.asin()) / std::f64::consts::PI
}

/// Its inverse: where it reaches level `l` in (0, 1).
fn esf_inverse(b: f64, l: f64) -> f64 {
    let (mut lo, mut hi) = (-b / 2.0, b / 2.0);
    for _ in 0..60 {
        let m = 0.5 * (lo + hi);
        if esf(b, m) < l {
            lo = m;
        } else {
            hi = m;
        }
    }
    0.5 * (lo + hi)
}

/// What one edge measures.
struct Spread {
    /// The fitted disc diameter, px.
    measured_px: f64,
    /// The largest horizontal distance of a pixel's (s, level) from the
    /// disc's edge-spread function of the expected diameter, px.
    placement_px: f64,
    /// The planner's prediction of it.
    predicted_px: f64,
    points: u16,
}

/// The signed distance, pixels, of pixel position `(x, y)` from the pinhole
/// image of the edge of [`scene`] at depth `z` (`rs`), positive towards the
/// bright side (the image's unit normal, from two of its points and one
/// inside, projected).
fn edge_side(rs: &RefScene, z: f64) -> impl Fn(f64, f64) -> f64 {
    let (c, s) = (5f64.to_radians().cos(), 5f64.to_radians().sin());
    let at = |t: f64| {
        rs.project([-0.05 * z * s * t, 0.05 * z * c * t, z])
            .expect("in view")
    };
    let (p, q) = (at(-1.0), at(1.0));
    let inside = rs.project([0.05 * z * c, 0.05 * z * s, z]).expect("in view");
    let (dx, dy) = (q.0 - p.0, q.1 - p.1);
    let len = dx.hypot(dy);
    let sign = (((inside.0 - p.0) * dy - (inside.1 - p.1) * dx) / len).signum();
    let (nx, ny) = (sign * dy / len, -sign * dx / len);
    move |x, y| nx * (x - p.0) + ny * (y - p.1)
}

/// The pixels within `reach` px of the edge (`side`, [`edge_side`]) where
/// the bright field is lit: each pixel's distance and its level, the
/// edge frame over the bright one.
fn edge_points(edge: &[f64], white: &[f64], side: &impl Fn(f64, f64) -> f64, reach: f64) -> Vec<(f64, f64)> {
    let mut pts = Vec::new();
    for j in 0..HEIGHT {
        for i in 0..WIDTH {
            let d = side(i as f64, j as f64);
            let k = j * WIDTH + i;
            if d.abs() <= reach && white[k] > 1000.0 {
                pts.push((d, edge[k] / white[k]));
            }
        }
    }
    pts
}

/// The diameter `b` in `(lo, hi)` whose `model(b, distance)` fits the
/// points' levels in least squares (golden-section search, `steps` steps).
fn fit_diameter(
    pts: &[(f64, f64)],
    (mut lo, mut hi): (f64, f64),
    steps: u32,
    model: impl Fn(f64, f64) -> f64,
) -> f64 {
    let cost = |b: f64| pts.iter().map(|(d, v)| (v - model(b, *d)).powi(2)).sum::<f64>();
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..steps {
        let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if cost(a) < cost(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    0.5 * (lo + hi)
}

/// Renders the edge at depth `z` and the bright field, and fits the disc
/// diameter of the edge's spread (least squares over the pixels within
/// reach of the edge, each at its distance from the edge's pinhole image).
fn measure(z: f64, tolerable_blur: f64, expected_px: f64) -> Spread {
    let text = scene(z, tolerable_blur, true);
    let (edge, points, predicted_px) = render(&text, None);
    let (white, _, _) = render(&scene(z, tolerable_blur, false), Some(0));
    let side = edge_side(&RefScene::new(&parse(&text).expect("scene")), z);
    let pts = edge_points(&edge, &white, &side, 0.75 * expected_px + 3.0);
    let measured_px = fit_diameter(&pts, (0.3 * expected_px, 2.0 * expected_px), 100, esf);
    let placement_px = pts
        .iter()
        .map(|(d, v)| {
            let r = expected_px / 2.0;
            if *v <= 0.0 {
                (d + r).max(0.0)
            } else if *v >= 1.0 {
                (r - d).max(0.0)
            } else {
                (d - esf_inverse(expected_px, *v)).abs()
            }
        })
        .fold(0.0, f64::max);
    Spread {
        measured_px,
        placement_px,
        predicted_px,
        points,
    }
}

#[test]
fn edges_spread_over_the_blur_circle() {
    // b̃ of 0.01 px: every edge here lies outside the depth of field.
    let tolerable = 1e-7;
    let mut worst: f64 = 0.0;
    for target in [1.0, 2.0, 5.0, 10.0, 20.0] {
        for side in [-1.0, 1.0] {
            // β f/s = target: 1/Z = 1/Z̃ ± target / (d f/s).
            let z = 1.0 / (1.0 / FOCUS + side * target / (D * FX));
            let expected = D * (1.0 / z - 1.0 / FOCUS).abs() * FX;
            let m = measure(z, tolerable, expected);
            let err = m.measured_px / expected - 1.0;
            println!(
                "Z = {z:.4} m ({}): blur {expected:.3} px, measured {:.3} px ({:+.2} %), {} aperture points, \
                 placement {:.3} px (predicted {:.3})",
                if side < 0.0 { "behind" } else { "in front" },
                m.measured_px,
                100.0 * err,
                m.points,
                m.placement_px,
                m.predicted_px
            );
            assert!(m.points > 0, "Z = {z}: the planner did not sample the aperture");
            assert!(
                err.abs() <= 0.05,
                "Z = {z}: spread {} px, expected {expected}",
                m.measured_px
            );
            // The prediction covers the pattern; 0.02 px for rounding and
            // the 16-bit quantization.
            assert!(
                m.placement_px <= m.predicted_px + 0.02,
                "Z = {z}: placement {} px over the predicted {}",
                m.placement_px,
                m.predicted_px
            );
            worst = worst.max(err.abs());
        }
    }
    println!("largest spread error {:.2} %", 100.0 * worst);
}

#[test]
fn targets_at_the_depth_of_field_planes_spread_by_the_tolerable_blur() {
    // b̃ of four pixels.
    let blur = 40e-6;
    let lens = ThinLens {
        f: F,
        d: D,
        focus: FOCUS,
        blur,
    };
    let far = lens.far().expect("finite far plane");
    for z in [lens.near(), far] {
        // §4: b(Ẑ) = b̃ at the planes; normalized, b̃ / ẑ(Ẑ).
        let image = lens.image_distance(z).expect("real image");
        let expected = blur / image * FX;
        let beta = D * (1.0 / z - 1.0 / FOCUS).abs() * FX;
        assert!((beta / expected - 1.0).abs() < 1e-9, "§8's β is §4's b/ẑ");
        let m = measure(z, blur, expected);
        let err = m.measured_px / expected - 1.0;
        println!(
            "DOF plane Z = {z:.4} m: b̃/ẑ = {expected:.3} px, measured {:.3} px ({:+.2} %), {} aperture points",
            m.measured_px,
            100.0 * err,
            m.points
        );
        assert!(
            err.abs() <= 0.05,
            "Z = {z}: spread {} px, expected {expected}",
            m.measured_px
        );
    }
}

#[test]
fn content_within_the_depth_of_field_pays_nothing() {
    // The same edge inside a depth of field of ±10 px of blur: a pinhole.
    let z = 1.0 / (1.0 / FOCUS + 2.0 / (D * FX));
    let (_, points, _) = render(&scene(z, 100e-6, true), None);
    assert_eq!(points, 0);
    for name in [
        "standard",
        "spheres-specular",
        "checkerboard-barrel",
        "calibration-board",
    ] {
        let path = format!("{}/../scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"));
        let r = host_sim::scene_file::load(std::path::Path::new(&path)).expect("scene");
        let (_, plan, f) = prepare::<I32F32>(&r, &Budget::default(), |p| p.options).expect("prepares");
        assert!(!plan.defocus.outside_dof, "{name}");
        assert_eq!(f.stages().aperture, 0, "{name}");
    }
}

#[test]
fn the_shallow_scene_matches_the_reference() {
    let path = format!("{}/../scenes/shallow-dof.toml", env!("CARGO_MANIFEST_DIR"));
    let r = host_sim::scene_file::load(std::path::Path::new(&path)).expect("scene");
    let out = host_sim::harness::render(&r, &Budget::default()).expect("renders");
    let m = &out.metrics;
    println!(
        "shallow-dof: {} aperture points, exact {:.4}, smooth max {} LSB, edges differing {}, defocus error vs \
         1024 points rms {:.3} DN max {:.2} DN",
        m.plan.aperture_points,
        m.exact_fraction,
        m.max_abs_lsb_smooth,
        m.edge_pixels_differing,
        m.defocus_error.map_or(0.0, |e| e.rms_dn),
        m.defocus_error.map_or(0.0, |e| e.max_dn)
    );
    assert!(m.plan.aperture_points > 0 && m.plan.outside_dof);
    assert!(m.max_abs_lsb_smooth <= 1);
    assert!(m.exact_fraction >= 0.99);
    assert!(m.edge_pixels_differing_fraction <= 0.0005);
    assert!(m.defocus_error.is_some());
}

/// The planner's choice on the shallow scene: the fast arithmetic's
/// aperture loop (pixel centres; its aperture rays start at points rounded
/// to S24 U, and a ray next to a sphere's silhouette is decided exactly).
/// Geometry within the candidate's prediction, at least 99.9 % of the
/// pixels identical, none more than 1 LSB off (without the exact decision
/// a pixel at the sphere's blurred silhouette was 2 LSB off).
#[test]
fn the_fast_aperture_loop_on_the_shallow_scene() {
    use hilcam::render::{Arithmetic, LineLoop};
    let path = format!("{}/../scenes/shallow-dof.toml", env!("CARGO_MANIFEST_DIR"));
    let r = host_sim::scene_file::load(std::path::Path::new(&path)).expect("scene");
    let (_, plan, f) = prepare::<I32F32>(&r, &Budget::default(), |p| p.options).expect("prepares");
    assert_eq!(f.line_loop(), LineLoop::FastGrayAperture);
    assert_eq!(plan.options.arithmetic, Arithmetic::Fast);
    // The predicted cost counts the loop's pixels by kind: the plan's
    // shares are its frame's, every `APERTURE_STRIDE`-th row and column
    // (about half of the scene's pixels are one sum).
    let k = f
        .aperture_classes(hilcam::planner::APERTURE_STRIDE)
        .expect("defocused");
    let n = f64::from(k.pixels);
    assert_eq!(
        (plan.samples.traced, plan.samples.only),
        (f64::from(k.traced) / n, f64::from(k.only) / n)
    );
    assert!(
        plan.samples.traced + plan.samples.only < 0.6,
        "{:?}",
        plan.samples
    );
    let c = plan.candidates.get(plan.chosen).expect("the chosen candidate");
    let out = host_sim::harness::render(&r, &Budget::default()).expect("renders");
    let m = &out.metrics;
    println!(
        "shallow-dof, fast aperture loop: geometry {:.2e} px (predicted {:.2e}), exact {:.4}, max {} LSB \
         (predicted {:.3} before rounding), smooth max {} LSB",
        m.max_geom_err_px, c.geom_err_px, m.exact_fraction, m.max_abs_lsb, c.lsb, m.max_abs_lsb_smooth
    );
    assert!(m.max_geom_err_px <= c.geom_err_px);
    assert!(m.exact_fraction >= 0.999);
    assert!(m.max_abs_lsb <= 1);
}

/// A random defocused scene: a camera at the origin looking along +z
/// (16 mm on 10 µm pixels, focused at 1 m), spheres, rectangles (checkered
/// or not) and discs at 0.4–1.8 m, a directional light and maybe a point one.
fn random_defocused(
    (format, n, tilt): (usize, f64, f64),
    prims: &[(usize, [f64; 3], f64, bool)],
    point: Option<[f64; 3]>,
) -> String {
    let format = [
        "format = \"gray8\"",
        "format = \"gray16\"\nbits = 12",
        "format = \"rgb565\"",
    ][format];
    let (a, b) = if format.contains("rgb") {
        ("[0.8, 0.6, 0.4]", "[0.1, 0.2, 0.15]")
    } else {
        ("0.8", "0.12")
    };
    // (Shadows off: the fast aperture loop these exercise takes none.)
    let mut t = format!(
        "name = \"random-defocus\"\n[output]\n{format}\nexposure = 300.0\n[camera]\nwidth = 64\nheight = 48\n\
         focal_length = 16e-3\npitch = 10e-6\nf_number = {n}\nfocus_distance = 1.0\ntolerable_blur = 10e-6\n\
         pose = {{ eye = [0.0, 0.0, 0.0], target = [0.0, 0.0, 1.0], up = [0.0, 1.0, 0.0] }}\n\
         [environment]\nambient = 0.1\nbackground = 0.05\nshadows = false\n\
         [[materials]]\nname = \"a\"\nalbedo = {a}\n[[materials]]\nname = \"b\"\nalbedo = {b}\n\
         [[lights]]\nkind = \"directional\"\ndirection = [0.3, 0.4, -1.0]\nirradiance = 5.0\n"
    );
    if let Some(p) = point {
        t += &format!("[[lights]]\nkind = \"point\"\nposition = {p:?}\nintensity = 3.0\n");
    }
    for (k, [x, y, z], size, checker) in prims {
        // Within the view (±0.16 z across, ±0.12 z up).
        let c = [x * 0.16 * z, y * 0.12 * z, *z];
        let normal = [tilt, 0.0, -1.0];
        let ch = if *checker {
            format!(
                "checker = {{ cell = {}, material = \"b\", u_axis = [1.0, 0.3, 0.0] }}\n",
                size * z / 3.0
            )
        } else {
            String::new()
        };
        let r = size * z;
        t += &match k {
            0 => format!("[[primitives]]\nkind = \"sphere\"\nmaterial = \"a\"\ncentre = {c:?}\nradius = {r}\n"),
            1 => format!(
                "[[primitives]]\nkind = \"rectangle\"\nmaterial = \"a\"\ncentre = {c:?}\nnormal = {normal:?}\n\
                 u_axis = [1.0, 0.0, 0.0]\nsize = [{}, {}]\n{ch}",
                2.0 * r,
                1.5 * r
            ),
            _ => format!(
                "[[primitives]]\nkind = \"disc\"\nmaterial = \"b\"\ncentre = {c:?}\nnormal = {normal:?}\nradius = {r}\n"
            ),
        };
    }
    t
}

/// [`random_defocused`]'s arguments.
type DefocusedCase = (
    (usize, f64, f64),
    Vec<(usize, [f64; 3], f64, bool)>,
    Option<[f64; 3]>,
);

/// [`random_defocused`]'s arguments: the format, f-number and tilt, 1 to
/// `max − 1` primitives (kind, place, size, checker), a point light or
/// none.
fn random_defocused_spec(max: usize) -> impl proptest::strategy::Strategy<Value = DefocusedCase> {
    use proptest::prelude::*;
    let prim = (
        0usize..3,
        (-1.0f64..1.0, -1.0f64..1.0, 0.4f64..1.8),
        0.02f64..0.3,
        any::<bool>(),
    )
        .prop_map(|(k, (x, y, z), s, ch)| (k, [x, y, z], s, ch));
    (
        (0usize..3, prop::sample::select(vec![1.4, 2.0, 2.8]), -0.5f64..0.5),
        prop::collection::vec(prim, 1..max),
        prop::option::of((-1.0f64..1.0, -1.0f64..1.0, -1.0f64..0.5).prop_map(|(x, y, z)| [x, y, z])),
    )
}

/// A runner of `cases` from a fixed seed, writing no failure file.
fn deterministic_runner(cases: u32) -> proptest::test_runner::TestRunner {
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let mut config = Config::with_cases(cases);
    config.failure_persistence = None;
    TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha))
}

/// The planner's bounds hold where it renders defocus with the fast
/// aperture loop: on random defocused scenes (gray8, 12-bit, RGB565), the
/// smooth pixels within the predicted LSB (+ rounding) and the geometry
/// within the predicted error; where the plan meets the budget, within 1
/// LSB, at least 99 % exact and the differing edge pixels within the
/// budget's share.
#[test]
fn fast_defocus_plans_hold_their_bounds_on_random_scenes() {
    use hilcam::render::Arithmetic;
    use proptest::prelude::*;
    use std::cell::Cell;
    let spec = random_defocused_spec(4);
    let mut runner = deterministic_runner(64);
    let budget = Budget::default();
    let (fast, differing) = (Cell::new(0), Cell::new(0usize));
    let result = runner.run(&spec, |(cam, prims, point)| {
        let t = random_defocused(cam, &prims, point);
        let r = parse(&t).unwrap_or_else(|e| panic!("{e}:\n{t}"));
        let out = host_sim::harness::render_skipping_stage_errors(&r, &budget)
            .unwrap_or_else(|e| panic!("{e}:\n{t}"));
        let (m, p) = (&out.metrics, &out.plan);
        if p.options.aperture == 0 || p.options.arithmetic != Arithmetic::Fast {
            return Ok(());
        }
        fast.set(fast.get() + 1);
        differing.set(
            differing.get() + m.width * m.height
                - (m.exact_fraction * (m.width * m.height) as f64).round() as usize,
        );
        if let Some(e) = m.beyond_prediction() {
            return Err(proptest::test_runner::TestCaseError::fail(format!("{e}:\n{t}")));
        }
        if p.meets_budget {
            prop_assert!(
                m.max_abs_lsb_smooth as f64 <= budget.max_lsb,
                "smooth {} LSB:\n{t}",
                m.max_abs_lsb_smooth
            );
            prop_assert!(m.exact_fraction >= 0.99, "exact {}:\n{t}", m.exact_fraction);
            prop_assert!(
                m.edge_pixels_differing_fraction <= budget.max_edge_differing,
                "edge pixels differing {}:\n{t}",
                m.edge_pixels_differing_fraction
            );
        }
        Ok(())
    });
    eprintln!(
        "fast aperture plans: {} of 64, {} pixels differing in all",
        fast.get(),
        differing.get()
    );
    if let Err(e) = result {
        panic!("{e}");
    }
    assert!(
        fast.get() >= 16,
        "the fast aperture loop exercised: {}",
        fast.get()
    );
}

/// Through the aperture, a pixel whose aperture rays' sums are known to be
/// one (the background, or a flat rectangle hit well within its edges and
/// one texture cell, nothing nearer) takes its chief ray's, and one whose
/// rays that rectangle alone meets, over more than one cell, tests them
/// against it alone: on random
/// defocused scenes (tilted rectangles, checkers, discs, spheres, a point
/// light or none; gray8, 12-bit, RGB565), the frame is byte for byte the
/// one with every aperture ray traced, and the rule spares a fair share of
/// the pixels.
#[test]
fn uniform_aperture_pixels_are_the_traced_ones() {
    let (rendered, spared) = spared_pixels_are_the_traced_ones(random_defocused_spec(5), 128);
    assert!(rendered >= 96, "scenes rendered: {rendered}");
    assert!(spared >= 0.1, "pixels spared: {spared}");
}

/// [`uniform_aperture_pixels_are_the_traced_ones`] on rectangles facing the
/// camera, checkered (a sphere among them at times): where one of them
/// alone meets a pixel's rays, `Mix32::line_d` takes a run of such pixels
/// one texture cell at a time for each aperture point, the cells found at
/// the run's ends and by bisection, and adds one kept sum to each pixel of
/// a cell — byte for byte the frame with every aperture ray traced.
#[test]
fn facing_checkered_rectangles_are_the_traced_ones() {
    use proptest::prelude::*;
    let prim = (0usize..4, (-1.0f64..1.0, -1.0f64..1.0, 0.4f64..1.8), 0.02f64..0.3)
        // Three in four a checkered rectangle, else a sphere.
        .prop_map(|(k, (x, y, z), s)| (usize::from(k != 0), [x, y, z], s, true));
    let spec = (
        (0usize..3, prop::sample::select(vec![1.4, 2.0, 2.8]), Just(0.0)),
        prop::collection::vec(prim, 1..4),
        prop::option::of((-1.0f64..1.0, -1.0f64..1.0, -1.0f64..0.5).prop_map(|(x, y, z)| [x, y, z])),
    );
    let (rendered, spared) = spared_pixels_are_the_traced_ones(spec, 64);
    assert!(rendered >= 48, "scenes rendered: {rendered}");
    assert!(spared >= 0.1, "pixels spared: {spared}");
}

/// Renders `cases` scenes of `spec` through the fast aperture loop both
/// ways (the pixels of one sum and those one rectangle alone meets spared;
/// every aperture ray traced) and asserts the same bytes: how many
/// rendered, and the share of their pixels in the field spared.
fn spared_pixels_are_the_traced_ones(
    spec: impl proptest::strategy::Strategy<Value = DefocusedCase>,
    cases: u32,
) -> (u32, f64) {
    use hilcam::render::Arithmetic;
    use proptest::prelude::*;
    use std::cell::Cell;
    let mut runner = deterministic_runner(cases);
    let (rendered, traced, field) = (Cell::new(0), Cell::new(0u64), Cell::new(0u64));
    let result = runner.run(&spec, |(cam, prims, point)| {
        let t = random_defocused(cam, &prims, point);
        let r = parse(&t).unwrap_or_else(|e| panic!("{e}:\n{t}"));
        let Ok((_, _, f)) = prepare::<I32F32>(&r, &Budget::default(), |p| hilcam::render::Options {
            arithmetic: Arithmetic::Fast,
            samples: 1,
            adaptive: false,
            aperture: 64,
            ..p.options
        }) else {
            return Ok(());
        };
        let Some(c) = f.aperture_classes(1) else {
            return Ok(());
        };
        let (n, all) = (c.traced + c.only, c.field);
        let mut every = f.clone();
        every.trace_every_aperture_ray();
        let (a, b) = (collect(&f).expect("renders"), collect(&every).expect("renders"));
        prop_assert!(
            a.pixels == b.pixels && a.flags == b.flags,
            "{n} of {all} traced:\n{t}"
        );
        rendered.set(rendered.get() + 1);
        traced.set(traced.get() + u64::from(n));
        field.set(field.get() + u64::from(all));
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let spared = 1.0 - traced.get() as f64 / field.get().max(1) as f64;
    eprintln!(
        "{} scenes through the fast aperture loop, {:.1} % of their pixels in the field spared",
        rendered.get(),
        100.0 * spared
    );
    (rendered.get(), spared)
}

/// [`host_sim::scene_file::parse`] with one sample a pixel where the text
/// asks for no pattern: these tests measure the blur of centre samples
/// (pixel-area integration on top widens a measured edge: docs/sensor.md).
fn parse(text: &str) -> Result<host_sim::scene_file::Resolved, String> {
    if text.contains("[sampling]") {
        host_sim::scene_file::parse(text)
    } else {
        host_sim::scene_file::parse(&format!("{text}\n[sampling]\nedge_error = 0.5\n"))
    }
}

/// The frame of `text` as its scene file asks (no `[sampling]`: the
/// default, sensor-like pattern), 16-bit values, with the plan.
fn render_as_asked(text: &str) -> (Vec<f64>, hilcam::planner::Plan) {
    let (v, _, plan) = render_resolved(&host_sim::scene_file::parse(text).expect("scene"), None);
    (v, plan)
}

/// Defocus and pixel-area integration together (docs/sensor.md, "Defocus
/// and the adaptive rule"): a step edge at 0.5–20 px of blur, in front of
/// and behind focus, rendered with the default sampling. The disc diameter
/// fitted to the frame — each pixel modelled as the disc's edge-spread
/// function averaged over its square — is `β f / s` within 2 %, and no
/// pixel near the edge lies farther from the converged reference (16×16
/// samples × 1 024 aperture points) than the plan's predicted placement
/// errors allow at the edge's steepest slope.
#[test]
fn area_integrated_edges_spread_over_the_blur_circle() {
    use host_sim::reference::sampling::Pattern;
    let tolerable = 1e-7;
    let mut worst: (f64, f64) = (0.0, 0.0);
    let mut failures = Vec::new();
    for target in [0.5, 1.0, 2.0, 5.0, 10.0, 20.0] {
        for side in [-1.0, 1.0] {
            let z = 1.0 / (1.0 / FOCUS + side * target / (D * FX));
            let b = D * (1.0 / z - 1.0 / FOCUS).abs() * FX;
            let text = scene(z, tolerable, true);
            let (edge, plan) = render_as_asked(&text);
            let (white, _) = render_as_asked(&scene(z, tolerable, false));
            let rs = RefScene::new(&host_sim::scene_file::parse(&text).expect("scene"));
            let side_of = edge_side(&rs, z);
            // The pixel square's offsets along the edge normal: the side
            // of `(x, y)` and of `(x + 1, y)`, `(x, y + 1)`.
            let (nx, ny) = (
                side_of(1.0, 0.0) - side_of(0.0, 0.0),
                side_of(0.0, 1.0) - side_of(0.0, 0.0),
            );
            // The disc's edge-spread function averaged over the pixel
            // square.
            let area_esf = |b: f64, d: f64| {
                // 64 points across the square along the normal's larger
                // component, 8 along the other (the edge is 5° off the
                // columns: that one moves a point by at most 0.04 px).
                let (ku, kv) = if nx.abs() >= ny.abs() { (64, 8) } else { (8, 64) };
                let mut sum = 0.0;
                for u in 0..ku {
                    for v in 0..kv {
                        let (ou, ov) = (
                            (u as f64 + 0.5) / ku as f64 - 0.5,
                            (v as f64 + 0.5) / kv as f64 - 0.5,
                        );
                        sum += esf(b, d + nx * ou + ny * ov);
                    }
                }
                sum / (ku * kv) as f64
            };
            let reach = 0.5 * b + 1.5;
            let pts = edge_points(&edge, &white, &side_of, reach);
            let fitted = fit_diameter(&pts, (0.5 * b, 1.5 * b), 40, area_esf);
            let err = fitted / b - 1.0;
            // Against the converged reference on three rows (the slant
            // puts the edge at a different phase on each).
            let conv = rs.with_pattern(Pattern {
                n: 16,
                adaptive: false,
                aperture: host_sim::reference::defocus::CONVERGED,
            });
            let slope = (4.0 / (std::f64::consts::PI * b)).min(1.0);
            let predicted = plan.predicted_edge_err_px + plan.defocus.err_px;
            let mut largest: f64 = 0.0;
            let mut allowed: f64 = 0.0;
            for j in [HEIGHT / 2 - 1, HEIGHT / 2, HEIGHT / 2 + 1] {
                for i in 0..WIDTH {
                    let k = j * WIDTH + i;
                    if side_of(i as f64, j as f64).abs() > reach || white[k] <= 1000.0 {
                        continue;
                    }
                    let truth = conv.area_mean(i, j).expect("in the field")[0];
                    let bound = white[k] * slope * predicted + 1.0;
                    largest = largest.max((edge[k] - truth).abs() / white[k]);
                    allowed = allowed.max(bound / white[k]);
                    if (edge[k] - truth).abs() > bound {
                        failures.push(format!(
                            "blur {b:.3} px, pixel ({i}, {j}): {} DN, converged {truth:.1} (bound {bound:.1})",
                            edge[k]
                        ));
                    }
                }
            }
            println!(
                "blur {b:6.3} px ({}): fitted {fitted:6.3} px ({:+.2} %), {}×{} grid ({}) × {} aperture points, \
                 largest pixel error {:.2} % of the step (bound {:.2} %)",
                if side < 0.0 { "behind" } else { "in front" },
                100.0 * err,
                plan.options.samples,
                plan.options.samples,
                if plan.options.adaptive { "adaptive" } else { "every pixel" },
                plan.options.aperture,
                100.0 * largest,
                100.0 * allowed
            );
            if err.abs() > 0.02 {
                failures.push(format!("blur {b:.3} px: fitted {fitted:.3} px"));
            }
            worst = (worst.0.max(err.abs()), worst.1.max(largest));
        }
    }
    println!(
        "largest diameter error {:.2} %, largest pixel error {:.2} % of the step",
        100.0 * worst.0,
        100.0 * worst.1
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
