use super::*;

fn chain(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| s.to_string()).collect()
}

#[test]
fn a_helper_counts_for_the_stage_that_inlined_it() {
    // recip inlined in the plane's intersection, in the line loop.
    let c = chain(&[
        "hilcam::render::fast::arith::recip",
        "hilcam::render::fast::rays::Ray::plane_t",
        "hilcam::render::fast::intersect::MixShape::nearest",
        "hilcam::render::fast::Mix32::trace_row",
        "hilcam::render::fast::Mix32::line_f",
    ]);
    assert_eq!(stage_of(&c), Some(Stage::Intersection));
    // The same helper for a ray's 1/a.
    let c = chain(&["hilcam::render::fast::arith::recip", "hilcam::render::fast::rays::Ray::new", "hilcam::render::fast::Mix32::trace_row"]);
    assert_eq!(stage_of(&c), Some(Stage::Rays));
    // The sampled loop's own code, not the plain loop's.
    let c = chain(&["core::cmp::Ord::min", "hilcam::render::fast::Mix32::line_s"]);
    assert_eq!(stage_of(&c), Some(Stage::Sampling));
    let c = chain(&["hilcam::render::fast::Mix32::line_f"]);
    assert_eq!(stage_of(&c), Some(Stage::LineLoop));
    // The closed-form plane: 1/|q| in its term is shading, its w the
    // intersection's, the run's own loop the line loop's.
    let c = chain(&[
        "hilcam::render::fast::arith::rsqrt_top",
        "hilcam::render::fast::arith::rsqrt_norm",
        "hilcam::render::fast::shade::cube_over",
        "hilcam::render::fast::shade::closed_term",
        "hilcam::render::fast::Mix32::closed_run",
    ]);
    assert_eq!(stage_of(&c), Some(Stage::Shading));
    let c = chain(&["hilcam::render::fast::arith::wmul_px", "hilcam::render::fast::shade::closed_w", "hilcam::render::fast::Mix32::closed_run"]);
    assert_eq!(stage_of(&c), Some(Stage::Intersection));
    let c = chain(&["hilcam::render::fast::Mix32::closed_run"]);
    assert_eq!(stage_of(&c), Some(Stage::LineLoop));
    // The frame's preparation, however the demangler spaces generics
    // (not the render module's line loop).
    for f in ["hilcam::render::Frame<S,_>::prepare_inner", "hilcam::render::Frame<S, _>::prepare_mix32"] {
        assert_eq!(stage_of(&chain(&["hilcam::render::fast::arith::shl_q", f])), Some(Stage::Preparation));
    }
    let c = chain(&["hilcam::render::Frame<S,_>::render_carried"]);
    assert_eq!(stage_of(&c), Some(Stage::LineLoop));
}

#[test]
fn modules_claim_what_no_function_does_and_helpers_are_their_callers() {
    let c = chain(&["hilcam::render::sensor::noise::normal_q16", "hilcam::render::sensor::noise::Stage<S>::apply_with"]);
    assert_eq!(stage_of(&c), Some(Stage::Noise));
    let c = chain(&["crc::crc32::update_table", "hilcam::link::CobsStream<W>::emit"]);
    assert_eq!(stage_of(&c), Some(Stage::Link));
    // Out of line: the caller's stage (None).
    assert_eq!(stage_of(&chain(&["compiler_builtins::float::add::__adddf3"])), None);
    assert_eq!(stage_of(&chain(&["hilcam::num::Wide::checked_div"])), None);
    // Bare runtime symbols: their caller's.
    assert_eq!(stage_of(&chain(&["__clzsi2"])), None);
    assert_eq!(stage_of(&chain(&["fmax"])), None);
    // Neither: the firmware's.
    assert_eq!(stage_of(&chain(&["hilcam_firmware::ticks"])), Some(Stage::Firmware));
    assert_eq!(stage_of(&chain(&["some_crate::f"])), Some(Stage::Firmware));
}

#[test]
fn the_lines_table_quotes_each_line_from_its_file() {
    let first = include_str!("../../../src/render/fast/mod.rs").lines().nth(1).unwrap_or_default().trim().to_string();
    let r = ProfileReport {
        board: "lm3s6965evb".into(),
        frames: vec![FrameProfile {
            scene: "standard".into(),
            pixels: 1,
            stages: vec![],
            render_per_pixel: 0.0,
            firmware_per_pixel: 0.0,
            icount_per_pixel: None,
            total_per_pixel: 0.0,
            functions: vec![],
            lines: vec![
                ("src/render/fast/mod.rs:2".into(), 12.25),
                ("? in crc::crc32::update".into(), 3.0),
                ("src/nowhere.rs:7".into(), 1.0),
            ],
        }],
    };
    let t = lines_table(&r, 2);
    assert!(t.contains(&format!("| 12.2 | src/render/fast/mod.rs:2 | `{}` |", first.replace('|', "\\|"))), "{t}");
    assert!(t.contains("| 3.0 | ? in crc::crc32::update | `` |"), "{t}");
    // At most n lines a frame.
    assert!(!t.contains("nowhere"), "{t}");
}

#[test]
fn hashes_are_stripped_and_nothing_else() {
    assert_eq!(name_of("_ZN6hilcam5mix325recip17h0123456789abcdefE"), "hilcam::mix32::recip");
    assert_eq!(name_of("hilcam::render::fast::recip"), "hilcam::render::fast::recip");
    assert_eq!(name_of("a::hb::c"), "a::hb::c");
    assert_eq!(name_of("__clzsi2"), "__clzsi2");
    // A method by its type's path, wherever its impl block is.
    assert_eq!(
        name_of("hilcam::render::fast::closed::<impl hilcam::render::fast::Mix32>::closed_run::{{closure}}"),
        "hilcam::render::fast::Mix32::closed_run::{{closure}}"
    );
    assert_eq!(
        name_of("hilcam::render::x::<impl hilcam::render::Frame<S, P>>::line"),
        "hilcam::render::Frame<S, P>::line"
    );
    assert_eq!(
        name_of("core::ptr::drop_in_place<hilcam::m::<impl hilcam::M>::f>"),
        "core::ptr::drop_in_place<hilcam::M::f>"
    );
    assert_eq!(name_of("a::<impl a::T for a::U>::f"), "a::<impl a::T for a::U>::f");
}

#[test]
fn flash_is_counted_by_crate_outside_the_repository() {
    let root = Path::new("/work/main");
    let core = "/rustc/59807616e1fa2540724bfbac14d7976d7e4a3860/library/core/src/num/mod.rs";
    assert_eq!(source_of(core, root), "library/core");
    let builtins = "/root/.rustup/toolchains/x/lib/rustlib/src/rust/library/compiler-builtins/src/mem.rs";
    assert_eq!(source_of(builtins, root), "library/compiler-builtins");
    let crc = "/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/crc-3.2.1/src/crc32.rs";
    assert_eq!(source_of(crc, root), "crc-3.2.1");
    assert_eq!(source_of("/work/main/src/mix32.rs", root), "src/mix32.rs");
    assert_eq!(source_of("/elsewhere/x.rs", root), "/elsewhere/x.rs");
    assert!(is_library(core) && is_library(crc) && !is_library("/work/main/src/mix32.rs"));
}
