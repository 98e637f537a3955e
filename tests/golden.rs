//! Golden frames: every shipped scene × output format × arithmetic, hashed
//! (CRC-64 of the pixel bytes, then of the flags) and compared with the
//! committed `tests/golden/frames.txt`. A change that alters a frame fails
//! here and has to say so: rerun with `HILCAM_BLESS=1` to rewrite the file,
//! and give the reason in the commit.
//!
//! An arithmetic that refuses a scene is pinned as `refused`: a change that
//! makes it render (or stop rendering) shows up here too.

use hilcam::planner::{Budget, Plan};
use hilcam::render::Frame;
use hilcam::scalar::Scalar;
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

fn scenes() -> Vec<PathBuf> {
    host_sim::hil_cmd::shipped_scenes().expect("scenes/")
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

/// `scene format variant` → hash, for every combination.
fn current() -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for path in scenes() {
        let base = load(&path).expect("a shipped scene loads");
        for (fname, format) in FORMATS {
            let mut r = base.clone();
            r.format = format;
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
    let now = current();
    let path = golden_path();
    if std::env::var_os("HILCAM_BLESS").is_some() {
        let text: String = now.iter().map(|(k, v)| format!("{k} {v}\n")).collect();
        std::fs::create_dir_all(path.parent().expect("dir")).expect("mkdir");
        std::fs::write(&path, text).expect("write golden");
        return;
    }
    let text = std::fs::read_to_string(&path).expect("tests/golden/frames.txt (HILCAM_BLESS=1 writes it)");
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
        "{} of {} frames differ from tests/golden/frames.txt:\n{}",
        diffs.len(),
        now.len(),
        diffs.join("\n")
    );
    assert_eq!(now.len(), scenes().len() * FORMATS.len() * VARIANTS.len());
}
