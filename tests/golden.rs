//! Golden frames: every shipped scene × output format × arithmetic, hashed
//! (CRC-64 of the pixel bytes, then of the flags) and compared with the
//! committed `tests/golden/frames.txt`. A change that alters a frame fails
//! here and has to say so: rerun with `HILCAM_BLESS=1` to rewrite the file,
//! and give the reason in the commit.
//!
//! An arithmetic that refuses a scene is pinned as `refused`: a change that
//! makes it render (or stop rendering) shows up here too.
//!
//! The planner's results are pinned the same way (`tests/golden/plans.txt`):
//! each shipped scene's plan at its own pose and at
//! `host_sim::trajectory::PINNED_POSES` poses about it, every prediction to
//! the bit (CRC-64 of their `Debug` text, which gives each `f64` exactly).
//! A change that makes the planner faster without changing what it decides
//! or predicts passes here unchanged. What it decides alone (each plan's
//! `options`, what the renderer is told) is pinned in
//! `tests/golden/plan-options.txt`: a refit of the cost model rewrites
//! `plans.txt` (its predictions move) and, if `git diff` shows
//! `plan-options.txt` unchanged, has moved no decision.

use hilcam::num::scalar::Scalar;
use hilcam::planner::{Budget, Plan};
use hilcam::render::Frame;
use hilcam::scene::PixelFormat;
use host_sim::harness::Collect;
use host_sim::scene_file::load;
use host_sim::variant::{FrameUser, Variant};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// The arithmetics pinned: the default (the planner's choice), and each one
/// the sweep keeps, with the polynomial and with a table.
const VARIANTS: [&str; 5] = [
    "planned",
    "mix32-poly",
    "f32-poly",
    "i32f32-poly",
    "i32f32-lut64-linear",
];

/// Every output format, with the scene's own exposure.
const FORMATS: [(&str, PixelFormat); 3] = [
    ("gray8", PixelFormat::Gray8),
    ("gray16-12", PixelFormat::Gray16 { bits: 12 }),
    ("rgb565", PixelFormat::Rgb565),
];

const CRC: crc::Crc<u64> = crc::Crc::<u64>::new(&crc::CRC_64_ECMA_182);

fn golden_path() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/frames.txt"))
}

fn plans_path() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/plans.txt"))
}

fn options_path() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/golden/plan-options.txt"
    ))
}

fn scenes() -> Vec<PathBuf> {
    host_sim::qemu::shipped_scenes().expect("scenes/")
}

struct Hash;

impl FrameUser for Hash {
    type Out = String;
    fn use_frame<S: Scalar>(self, _: &Plan, _: &Frame<S>, core: Collect) -> String {
        let mut d = CRC.digest();
        d.update(&core.pixels);
        d.update(&core.flags);
        format!("{:016x}", d.finalize())
    }
}

/// An RGB scene's colours as gray ones, for its one-channel renders: the
/// red channel, which is what a one-channel frame of the RGB scene showed
/// (a scene with colour triples and a gray format is refused as such).
fn red_as_gray(r: &mut host_sim::scene_file::Resolved) {
    use host_sim::scene_file::Colour;
    let gray = |c: &mut Colour| {
        if let Colour::Rgb(v) = *c {
            *c = Colour::Gray(v[0]);
        }
    };
    let d = &mut r.desc;
    gray(&mut d.environment.ambient);
    gray(&mut d.environment.background);
    for m in &mut d.materials {
        gray(&mut m.albedo);
        gray(&mut m.specular);
    }
    for l in &mut d.lights {
        l.intensity.as_mut().map(gray);
        l.irradiance.as_mut().map(gray);
    }
    use hilcam::scene::data::{Colour as Data, LightData};
    for l in &mut r.lights {
        let (LightData::Point { intensity: c, .. } | LightData::Directional { irradiance: c, .. }) = l;
        if let Data::Rgb(v) = *c {
            *c = Data::Gray(v[0]);
        }
    }
}

/// `scene format variant` → hash, for every combination.
fn current() -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for path in scenes() {
        let base = load(&path).expect("a shipped scene loads");
        for (fname, format) in FORMATS {
            let mut r = base.clone();
            r.format = format;
            if format.channels() == 1 {
                red_as_gray(&mut r);
            }
            for v in VARIANTS {
                let variant = Variant::parse(v).expect("variant name");
                let hash = variant
                    .render(&r, &Budget::default(), Hash)
                    .unwrap_or_else(|_| "refused".to_string());
                out.insert(format!("{} {fname} {v}", r.desc.name), hash);
            }
        }
    }
    out
}

#[test]
fn shipped_frames_match_the_committed_hashes() {
    check(
        current(),
        &golden_path(),
        scenes().len() * FORMATS.len() * VARIANTS.len(),
    );
}

/// `scene` → the hash of its plans at its pose and at
/// `host_sim::trajectory::PINNED_POSES` poses about it
/// (`host_sim::trajectory::poses_about`).
/// Each shipped scene's plans, at its pose and at `PINNED_POSES` poses
/// about it, hashed whole (`plans.txt`: predictions too, which move with
/// every refit of the cost model) and by what the renderer is told alone
/// (`plan-options.txt`: the decisions, which a refit must not move
/// unannounced — they choose the frames).
fn current_plans() -> (BTreeMap<String, String>, BTreeMap<String, String>) {
    use host_sim::trajectory::{poses_about, PINNED_POSES, POSES_SEED};
    let mut state = POSES_SEED;
    let budget = Budget::default();
    let (mut whole, mut decided) = (BTreeMap::new(), BTreeMap::new());
    for path in scenes() {
        let r = load(&path).expect("a shipped scene loads");
        let scene = r.core_scene().expect("a shipped scene builds");
        let pose = host_sim::drive_cmd::scene_pose(&r).expect("its pose");
        let (mut d, mut o) = (CRC.digest(), CRC.digest());
        let mut add = |plan: hilcam::planner::Plan| {
            d.update(format!("{plan:?}").as_bytes());
            o.update(format!("{:?}", plan.options).as_bytes());
        };
        add(hilcam::planner::plan(&scene, &budget));
        for (k, at_pose) in poses_about(&pose, PINNED_POSES, &mut state).iter().enumerate() {
            let mut at = scene.clone();
            let e = hilcam::geom::extrinsics::Extrinsics::from_matrix(at_pose.rotation, at_pose.translation);
            let moved = e.is_ok_and(|e| at.set_pose(e).is_ok());
            assert!(moved, "{}: pose {k}", r.desc.name);
            add(hilcam::planner::plan(&at, &budget));
        }
        whole.insert(r.desc.name.clone(), format!("{:016x}", d.finalize()));
        decided.insert(r.desc.name.clone(), format!("{:016x}", o.finalize()));
    }
    (whole, decided)
}

#[test]
fn shipped_plans_match_the_committed_hashes() {
    let (whole, decided) = current_plans();
    check(decided, &options_path(), scenes().len());
    check(whole, &plans_path(), scenes().len());
}

/// Compares `now` with the committed file at `path` (rewrites it with
/// `HILCAM_BLESS`); `count` entries expected.
fn check(now: BTreeMap<String, String>, path: &std::path::Path, count: usize) {
    let name = path
        .file_name()
        .map_or(String::new(), |n| n.to_string_lossy().into_owned());
    if std::env::var_os("HILCAM_BLESS").is_some() {
        let text: String = now.iter().map(|(k, v)| format!("{k} {v}\n")).collect();
        std::fs::create_dir_all(path.parent().expect("dir")).expect("mkdir");
        std::fs::write(path, text).expect("write golden");
        return;
    }
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("tests/golden/{name} (HILCAM_BLESS=1 writes it): {e}"));
    let golden: BTreeMap<String, String> = text
        .lines()
        .filter_map(|l| l.rsplit_once(' '))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let mut diffs = Vec::new();
    for (k, v) in &now {
        match golden.get(k) {
            Some(g) if g == v => {}
            Some(g) => diffs.push(format!("{k}: {g} -> {v}")),
            None => diffs.push(format!("{k}: not pinned (now {v})")),
        }
    }
    for k in golden.keys().filter(|k| !now.contains_key(*k)) {
        diffs.push(format!("{k}: pinned but no longer rendered"));
    }
    assert!(
        diffs.is_empty(),
        "{} of {} entries differ from tests/golden/{name}:\n{}",
        diffs.len(),
        now.len(),
        diffs.join("\n")
    );
    assert_eq!(now.len(), count);
}
