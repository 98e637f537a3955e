//! Cast shadows (camera-model.md §6) against the f64 reference, which tests
//! every primitive at every shaded point: both arithmetics within the
//! rendering targets on the shipped scene and on random ones (so a test the
//! planner leaves out is one the reference finds nothing for), shadows off
//! and scenes that need no test, and the adaptive rule at a shadow's edge.

use crate::common;

use common::fixture::{agrees, rendered_as, scene};
use host_sim::reference::render::RefScene;
use host_sim::scene_file::{load, parse, Resolved};

/// The shipped `shadows` scene (its own sampling).
fn shipped() -> Resolved {
    load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/shadows.toml"
    )))
    .expect("loads")
}

/// `r` with `environment.shadows = false`.
fn without_shadows(text: &str) -> Resolved {
    parse(&text.replace("[environment]", "[environment]\nshadows = false")).expect("valid")
}

const ARITHMETICS: [&str; 2] = ["mix32-poly", "i32f32-poly"];

#[test]
fn the_shadows_scene_meets_the_targets_in_both_arithmetics() {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/shadows.toml")).expect("read");
    let lit = without_shadows(&text);
    for v in ARITHMETICS {
        let (m, with) = rendered_as(&shipped(), v).expect("renders");
        assert!(m.stages.contains(&"shadows".to_string()), "{v}: {:?}", m.stages);
        agrees(&m);
        // The shadows are there: a twentieth of the frame or more at least
        // 10 DN darker than with every light reaching every point.
        let (m_off, without) = rendered_as(&lit, v).expect("renders");
        assert!(!m_off.stages.contains(&"shadows".to_string()), "{v}");
        agrees(&m_off);
        let darker = with
            .pixels
            .iter()
            .zip(&without.pixels)
            .filter(|(a, b)| u16::from(**a) + 10 <= u16::from(**b))
            .count();
        let lighter = with
            .pixels
            .iter()
            .zip(&without.pixels)
            .filter(|(a, b)| **a > **b)
            .count();
        assert!(darker * 20 >= with.pixels.len(), "{v}: {darker} pixels darker");
        assert_eq!(lighter, 0, "{v}: a shadow brightened a pixel");
    }
}

/// Spheres, a rectangle and a floor at random, lit by a point light and a
/// directional one: where the planner proves a primitive cannot shadow a
/// surface, the reference (which tests them all) finds no shadow either.
#[test]
fn random_occluders_agree_with_the_reference() {
    let mut state = 0x005e_ed0f_5ad0_u64;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut tested = 0;
    for case in 0..16 {
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * next();
        let (r1, r2) = (u(0.1, 0.4), u(0.1, 0.3));
        let extra = format!(
            "[[lights]]\nkind = \"point\"\nposition = [{:.3}, {:.3}, {:.3}]\nintensity = 20.0\n\
             [[primitives]]\nkind = \"plane\"\nmaterial = \"a\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n\
             [[primitives]]\nkind = \"sphere\"\nmaterial = \"a\"\ncentre = [{:.3}, {:.3}, {:.3}]\nradius = {r1:.3}\n\
             [[primitives]]\nkind = \"sphere\"\nmaterial = \"b\"\ncentre = [{:.3}, {:.3}, {:.3}]\nradius = {r2:.3}\n\
             [[primitives]]\nkind = \"rectangle\"\nmaterial = \"a\"\ncentre = [{:.3}, {:.3}, {:.3}]\n\
             normal = [{:.3}, 1.0, {:.3}]\nu_axis = [1.0, 0.0, 0.0]\nsize = [0.4, 0.3]\n",
            u(-2.0, 2.0),
            u(0.5, 3.0),
            u(-2.0, 1.0),
            u(-1.0, 1.0),
            u(0.0, 1.0) + r1,
            u(-0.5, 1.0),
            u(-1.0, 1.0),
            u(0.0, 0.8) + r2,
            u(-0.5, 1.0),
            u(-1.0, 1.0),
            u(0.3, 1.2),
            u(-0.5, 1.0),
            u(-0.5, 0.5),
            u(-0.5, 0.5),
        );
        let r = scene(&extra, &[]);
        for v in ARITHMETICS {
            let (m, _) = rendered_as(&r, v).unwrap_or_else(|e| panic!("case {case} {v}: {e}"));
            tested += m.stages.contains(&"shadows".to_string()) as u32;
            agrees(&m);
        }
    }
    assert!(tested >= 24, "only {tested} of 32 frames took a shadow test");
}

/// No test where none can find a shadow: a lone sphere, two spheres lit
/// from between them... (the planner's proof), and a scene that turns them
/// off — the same frame as the scene without an occluder's test.
#[test]
fn scenes_that_need_no_test_take_none() {
    let none = |extra: &str| {
        let (m, _) = rendered_as(&scene(extra, &[]), "mix32-poly").expect("renders");
        agrees(&m);
        !m.stages.contains(&"shadows".to_string())
    };
    let sphere = |x: f64| {
        format!(
            "[[primitives]]\nkind = \"sphere\"\nmaterial = \"a\"\ncentre = [{x}, 0.4, 0.0]\nradius = 0.3\n"
        )
    };
    assert!(none(&sphere(0.0)), "a lone sphere");
    // The fixture's sun is above and behind the camera: neither sphere's
    // way to it passes the other.
    assert!(
        none(&format!("{}{}", sphere(-0.8), sphere(0.8))),
        "two spheres side by side"
    );
    // A floor with the sun above: the floor shadows nothing above it.
    let floor = "[[primitives]]\nkind = \"plane\"\nmaterial = \"b\"\npoint = [0.0, -0.01, 0.0]\nnormal = [0.0, 1.0, 0.0]\n";
    assert!(
        !none(&format!("{floor}{}", sphere(0.0))),
        "a sphere over a floor takes tests"
    );
    let r = scene(
        &format!("{floor}{}", sphere(0.0)),
        &[("[environment]", "[environment]\nshadows = false")],
    );
    let (m, _) = rendered_as(&r, "mix32-poly").expect("renders");
    assert!(!m.stages.contains(&"shadows".to_string()));
    agrees(&m);
}

/// The adaptive rule sees a shadow's edge: with shadows, more pixels take
/// the grid (the reference's rule, which the core's follows: the targets
/// above hold with the scene's adaptive 4×4 pattern).
#[test]
fn the_adaptive_rule_sees_a_shadows_edge() {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/shadows.toml")).expect("read");
    let count = |r: &Resolved| {
        let rs = RefScene::new(r);
        let (w, h) = (rs.sensor.width as usize, rs.sensor.height as usize);
        (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .filter(|&(i, j)| rs.takes_grid(i, j))
            .count()
    };
    let (with, without) = (count(&shipped()), count(&without_shadows(&text)));
    assert!(
        with > without + 200,
        "{with} against {without} pixels on the grid"
    );
}
