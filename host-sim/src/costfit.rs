//! `host-sim costfit`: fits the planner's cost model to QEMU counts.
//!
//! Calibration scenes vary one feature at a time (primitives of each kind,
//! textures, lights of each kind, distortion by polynomial or table, the
//! specular lobe, colour, parallel rays) and a few together. Each is
//! rendered on the Cortex-M3 (lm3s6965evb, `-icount`) with each arithmetic
//! forced (`mix32-poly`; `i32f32-poly`, `i32f32-lut64-linear`), and the
//! instructions per pixel are fitted by least squares, per arithmetic,
//! linear in [`Features`]. A few of them are rendered again with sample
//! grids (`-s2`, `-s4`, `-s4-adaptive`, `-s8-adaptive`) and aperture
//! points (`-ap16`, `-ap64`), and what those cost over one sample's
//! prediction is fitted the same way, linear in [`Samples`]'s terms
//! ([`hilcam::planner::SampleCost`]). The fitted coefficients are
//! [`hilcam::planner::FAST_COST`] and [`hilcam::planner::WIDE_COST`];
//! `costfit.json` holds the measurements (committed as
//! `docs/cost-calibration.json`, from which a test refits the constants),
//! and `costfit.md` the fit and, for every shipped scene, the default
//! path's predicted against measured cost.

use crate::hil_cmd::hil_variants;
use crate::qemu::{shipped_scenes, Board};
use crate::scene_file::load;
use crate::variant::Variant;
use hilcam::planner::{self, Budget, CostModel, Features, SampleCost, Samples, COST_TERMS};
use hilcam::render::Arithmetic;
use serde::{Deserialize, Serialize};
use std::fmt::Write;
use std::path::Path;

/// One calibration measurement.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Point {
    /// Scene name.
    pub scene: String,
    /// Variant rendered.
    pub variant: String,
    /// `fast` or `wide`.
    pub arithmetic: String,
    /// The features, in [`Features::to_array`]'s order.
    pub features: Vec<f64>,
    /// What a pixel takes beyond one sample (grid samples, corner looks,
    /// aperture points); one sample through the pinhole where absent.
    #[serde(default = "one_sample")]
    pub samples: Samples,
    /// Measured M3 instructions a pixel: the mean of [`Point::layouts`]
    /// where it has them.
    pub measured: f64,
    /// The count in each firmware layout the point was measured in (the
    /// loops and scenes built beside it move it: [`LAYOUTS`]); empty for a
    /// point measured in one.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub layouts: Vec<f64>,
}

fn one_sample() -> Samples {
    Samples::ONE
}

impl Point {
    /// One sample a pixel through the pinhole: a point of the features' fit.
    fn is_one_sample(&self) -> bool {
        self.samples == Samples::ONE
    }

    /// A sample grid through the pinhole: a point of the grid's fit.
    fn is_grid(&self) -> bool {
        !self.is_one_sample() && self.samples.aperture == 0.0
    }
}

/// The calibration scenes rendered again with sample grids (every
/// arithmetic): a plain floor, spheres, rectangles, distortion, two
/// without a floor (mostly background: a sample's own work and its tests
/// are told from its content's cost by these), parallel rays with
/// checkered rectangles, and checkered rectangles over a floor under a
/// directional light.
const SAMPLED_SCENES: [&str; 8] = [
    "cal-base",
    "cal-sphere4",
    "cal-rect3",
    "cal-distortion",
    "cal-nofloor-mix",
    "cal-nofloor-rect",
    "cal-big-rect-ortho",
    "cal-dir-only-rects",
];
/// The grids they are rendered with.
const GRIDS: [&str; 4] = ["s2", "s4", "s4-adaptive", "s8-adaptive"];
/// The calibration scenes rendered again through the aperture (perspective
/// rays: defocus is the thin lens's).
const APERTURE_SCENES: [&str; 5] = [
    "cal-base",
    "cal-sphere4",
    "cal-nofloor-mix",
    "cal-dof-checker",
    "cal-dof-target",
];
/// The calibration scenes measured through the aperture alone (the others
/// take one sample too): facing checkered rectangles under a directional
/// light, whose pixels the fast aperture loop takes as one sum or tests
/// against one rectangle ([`Samples::traced`], [`Samples::only`]) — a
/// rectangle behind the focus with cells about its blur, and one near the
/// focus with a small sphere before it.
const DOF_SCENES: [&str; 2] = ["cal-dof-checker", "cal-dof-target"];
/// The aperture points they are rendered with.
const APERTURES: [&str; 2] = ["ap16", "ap64"];
/// The variants the calibration scenes that weak perspective holds are
/// rendered with (perspective and parallel rays are candidates of their
/// plan): both ray models whatever the plan picks — a calibration that
/// followed the plan it calibrates could flip with each fit, and the
/// parallel-ray terms would otherwise come from orthographic cameras
/// alone (no `cos⁴α` stage). No distortion: no table.
/// (Each ray model in a firmware of its own: the perspective one is the
/// firmware these scenes were measured in before weak perspective was, and
/// a scene's count moves by a few percent with the loops built beside it.)
const WEAK_VARIANTS: [[&str; 2]; 2] = [["mix32-persp", "i32f32-persp"], ["mix32-weak", "i32f32-weak"]];
/// Calibration scenes added after the others, each set measured in a
/// firmware of its own (added to the others' batches, they would move
/// those scenes' counts: the loops built beside a scene change its own by
/// up to 14 %, as measured on cal-ortho): the scenes with the principal
/// point off the sensor's centre, and those whose spheres alone have a
/// lobe (the floor matte; every other specular calibration scene has a
/// glossy floor), which tell the lobe's code in the loop from the pixels
/// that evaluate it.
const LATER_BATCHES: [&[&str]; 2] = [
    &[
        "cal-off-centre",
        "cal-off-centre-distortion",
        "cal-off-centre-mix",
        "cal-off-centre-ortho",
    ],
    &["cal-gloss-spheres", "cal-gloss-spheres-rgb"],
];

/// Firmware layouts each one-sample calibration scene is measured in, its
/// points the mean of their counts: a scene's count moves with the scenes
/// and loops built beside it (by up to a fifth where one of them builds a
/// lobe into its loop, [`has_lobe`]; by up to 15 % otherwise: the
/// compiler's inlining and layout of the loops they share), so one
/// layout's count is one draw of that spread. The first layout is the batches above (the free scenes six
/// to a firmware in order, [`LATER_BATCHES`], each ray model of
/// [`WEAK_VARIANTS`] apart); the second deals every one-sample scene round
/// the same number of firmwares (scene `i` to firmware `i mod n`, so no
/// two scenes of a first-layout batch share one) and builds both ray
/// models of the weak-perspective scenes together. In both, the scenes
/// with a lobe are measured apart from those without ([`has_lobe`]). The
/// sampled and aperture points are measured in one layout.
pub const LAYOUTS: usize = 2;

/// Whether the calibration scene at `path` renders a specular lobe (its
/// plan's [`Features::specular`]). A firmware that holds one builds the
/// lobe into its loop for that many channels, and every frame of that loop
/// pays for it, lobe or not (cal-ortho 368 beside a scene with a lobe, 289
/// in a firmware without: `docs/cost-model.md`); the default firmware
/// builds it only where a shipped scene has one, so the calibration
/// measures the scenes with a lobe in firmwares of their own.
fn has_lobe(path: &Path) -> Result<bool, String> {
    let scene = load(path)?.core_scene()?;
    let opts = variant_options(&scene, &Variant::PLANNED);
    Ok(Features::of_options(&scene, &opts).specular != 0.0)
}

/// `paths` split by [`has_lobe`], each part in their order: without a
/// lobe, with one.
fn by_lobe(paths: &[std::path::PathBuf]) -> Result<(Vec<std::path::PathBuf>, Vec<std::path::PathBuf>), String> {
    let (mut plain, mut lobed) = (Vec::new(), Vec::new());
    for p in paths {
        if has_lobe(p)? {
            lobed.push(p.clone());
        } else {
            plain.push(p.clone());
        }
    }
    Ok((plain, lobed))
}

/// Whether weak perspective holds for the calibration scene at `path`
/// (its plan lists a weak-perspective candidate).
fn weak_holds(path: &Path) -> Result<bool, String> {
    let scene = load(path)?.core_scene()?;
    Ok(planner::plan(&scene, &Budget::default()).weak_mean_depth().is_some())
}

/// The names of [`Features::to_array`]'s terms.
pub const TERMS: [&str; COST_TERMS] = [
    "constant",
    "planes",
    "spheres",
    "discs",
    "rectangles",
    "checkers",
    "point_lights",
    "directional_lights",
    "poly",
    "table",
    "specular",
    "extra_channels",
    "parallel",
    "coverage",
    "bounded_area",
    "bounded_area_parallel",
    "noise_channels",
    "closed",
    "closed_point_lights",
    "lobe_area",
    "facing_area",
    "closed_mean",
    "flat_area",
    "unmirrored",
    "unmirrored_poly",
    "orthographic",
];

/// The calibration scenes as (name, TOML).
pub fn calibration_scenes() -> Vec<(String, String)> {
    let dir = crate::qemu::repo_root().join("scenes/costfit");
    let index = std::fs::read_to_string(dir.join("index.txt")).unwrap_or_default();
    (index.lines())
        .filter(|n| !n.trim().is_empty())
        .map(|n| {
            let path = dir.join(format!("{n}.toml"));
            let text = std::fs::read_to_string(&path).unwrap_or_else(|e| format!("# {}: {e}", path.display()));
            (n.to_string(), text)
        })
        .collect()
}

/// The options `variant` renders `scene` with (the default plan's, as the
/// variant changes them): its arithmetic, and the features measured.
fn variant_options(scene: &hilcam::scene::Scene, variant: &Variant) -> hilcam::render::Options {
    variant.options(&planner::plan(scene, &Budget::default()))
}

/// Least squares per arithmetic: the coefficients of every feature term
/// that some one-sample point exercises (the others stay 0), in relative
/// error (each point weighted by 1/measured: the planner compares costs
/// by their ratio, and the report gives relative errors), then what the
/// samples cost ([`SampleCost`]) from the other points: the grid's
/// constants and its samples times their one-sample prediction (relative
/// error too), the aperture's factor against that prediction.
pub fn fit(points: &[Point], arithmetic: &str) -> Result<CostModel, String> {
    let ours = || points.iter().filter(|p| p.arithmetic == arithmetic);
    let rows: Vec<(Vec<f64>, f64)> = ours()
        .filter(|p| p.is_one_sample())
        .map(|p| (p.features.iter().map(|x| x / p.measured).collect(), 1.0))
        .collect();
    let used: Vec<usize> = (0..COST_TERMS)
        .filter(|&k| rows.iter().any(|(f, _)| f.get(k).is_some_and(|x| *x != 0.0)))
        .collect();
    let solved = least_squares(&rows, &used, &TERMS).map_err(|e| format!("{arithmetic}: {e}"))?;
    let mut coef = [0.0; COST_TERMS];
    for (&i, c) in used.iter().zip(solved) {
        coef[i] = c;
    }
    let base = CostModel {
        coef,
        samples: SampleCost::ONE,
    };
    // A point's one-sample prediction.
    let one = |p: &Point| base.predict_terms(&p.features);
    // The grid's terms (its constants, its samples times one sample's
    // prediction, its samples, its samples times primitives), in relative
    // error as the features.
    let grid_rows: Vec<([f64; 5], f64)> = ours()
        .filter(|p| p.is_grid())
        .map(|p| {
            let [every, adaptive, n, n1, np] = p.samples.terms().0;
            ([every, adaptive, n * one(p), n1, np].map(|t| t / p.measured), 1.0)
        })
        .collect();
    // A sample's own work in instructions in the fast arithmetic alone:
    // the wide loop's scales with its content (fitted, it came out
    // negative, −168 instructions a sample: docs/cost-model.md).
    let grid_used: &[usize] = if arithmetic == "fast" { &[0, 1, 2, 3, 4] } else { &[0, 1, 2, 4] };
    let solved =
        least_squares(&grid_rows, grid_used, &GRID_TERMS).map_err(|e| format!("{arithmetic} sample grid: {e}"))?;
    let mut grid = [0.0; 5];
    for (&i, c) in grid_used.iter().zip(solved) {
        grid[i] = c;
    }
    // The aperture's terms, the first two times one sample's prediction,
    // in relative error as the features.
    let ap_rows: Vec<([f64; 4], f64)> = ours()
        .filter(|p| p.samples.aperture > 0.0 && p.samples.grid == 1.0 && p.samples.corners == 0.0)
        .map(|p| {
            let [c, t, o, m] = p.samples.terms().1;
            ([c * one(p), t * one(p), o, m].map(|x| x / p.measured), 1.0)
        })
        .collect();
    // The terms in instructions where some point tests one rectangle
    // alone: the wide loop traces every pixel, whose cost is the
    // content's (its points' own work scales with it too), and those
    // stay 0.
    let singles = ap_rows.iter().any(|(t, _)| t[2] != 0.0);
    let ap_used: Vec<usize> = if singles { vec![0, 1, 2, 3] } else { vec![0, 1] };
    let solved = least_squares(&ap_rows, &ap_used, &APERTURE_TERMS).map_err(|e| format!("{arithmetic} aperture: {e}"))?;
    let mut aperture = [0.0; 4];
    for (&i, c) in ap_used.iter().zip(solved) {
        aperture[i] = c;
    }
    Ok(CostModel {
        coef,
        samples: SampleCost {
            grid,
            aperture,
        },
    })
}

/// How the grid's cost generalizes: for each calibration scene rendered
/// with sample grids, [`fit`] without those points predicts them; the RMS
/// and largest relative error over all of them.
pub fn left_out_grid_error(points: &[Point], arithmetic: &str) -> Result<(f64, f64), String> {
    let sampled = |p: &Point| p.arithmetic == arithmetic && p.is_grid();
    let mut scenes: Vec<&str> = points.iter().filter(|p| sampled(p)).map(|p| p.scene.as_str()).collect();
    scenes.sort_unstable();
    scenes.dedup();
    let (mut sum2, mut max, mut count) = (0.0f64, 0.0f64, 0usize);
    for scene in scenes {
        let rest: Vec<Point> = points
            .iter()
            .filter(|p| !(sampled(p) && p.scene == scene))
            .cloned()
            .collect();
        let m = fit(&rest, arithmetic)?;
        for p in points.iter().filter(|p| sampled(p) && p.scene == scene) {
            let e = (m.samples.cost(m.predict_terms(&p.features), &p.samples) - p.measured) / p.measured;
            (sum2, max, count) = (sum2 + e * e, max.max(e.abs()), count + 1);
        }
    }
    if count == 0 {
        return Err(format!("{arithmetic}: no sampled points"));
    }
    Ok(((sum2 / count as f64).sqrt(), max))
}

/// The names of [`SampleCost::grid`]'s terms.
pub const GRID_TERMS: [&str; 5] = [
    "grid on every pixel (instructions)",
    "grid, adaptive (instructions)",
    "grid, per sample (x one sample)",
    "grid, per sample (instructions)",
    "grid, per sample and primitive (instructions)",
];
/// The names of [`SampleCost::aperture`]'s terms.
pub const APERTURE_TERMS: [&str; 4] = [
    "aperture constant (x one sample)",
    "aperture points, traced pixels (x one sample)",
    "aperture points, pixels of one rectangle (instructions)",
    "aperture points, every pixel (instructions)",
];

/// The least-squares coefficients of the columns `used` of `rows` (terms,
/// measured; `names` names the columns), by the normal equations, solved
/// by Gaussian elimination with partial pivoting.
fn least_squares<R: AsRef<[f64]>>(rows: &[(R, f64)], used: &[usize], names: &[&str]) -> Result<Vec<f64>, String> {
    let n = used.len();
    if rows.len() < n {
        return Err(format!("{} points for {n} terms", rows.len()));
    }
    // [AᵀA | Aᵀb]
    let mut m = vec![vec![0.0f64; n + 1]; n];
    for (f, y) in rows {
        let f = f.as_ref();
        for (a, &i) in used.iter().enumerate() {
            for (b, &j) in used.iter().enumerate() {
                m[a][b] += f[i] * f[j];
            }
            m[a][n] += f[i] * y;
        }
    }
    for c in 0..n {
        let p = (c..n)
            .max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))
            .ok_or("empty system")?;
        if m[p][c].abs() < 1e-9 {
            let name = used.get(c).and_then(|&i| names.get(i)).unwrap_or(&"?");
            return Err(format!("the term {name} is not determined by the points"));
        }
        m.swap(c, p);
        let pivot = m[c].clone();
        for (r, row) in m.iter_mut().enumerate() {
            if r != c {
                let k = row[c] / pivot[c];
                for (x, p) in row.iter_mut().zip(&pivot).skip(c) {
                    *x -= k * p;
                }
            }
        }
    }
    Ok((0..n).map(|a| m[a][n] / m[a][a]).collect())
}

/// `costfit.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Calibration {
    /// Board the counts come from.
    pub board: String,
    /// The measurements.
    pub points: Vec<Point>,
}

/// Reads a `costfit.json` (e.g. the committed `docs/cost-calibration.json`).
pub fn load_calibration(path: &Path) -> Result<Calibration, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// The features the planner computes now for a calibration point (its
/// scene from [`calibration_scenes`], rendered with its variant).
pub fn features_now(p: &Point) -> Result<Vec<f64>, String> {
    let (scene, opts) = scene_and_options(p)?;
    Ok(Features::of_options(&scene, &opts).to_array().to_vec())
}

/// The [`Samples`] the planner computes now for a calibration point, as
/// [`Point::samples`] records them.
pub fn samples_now(p: &Point) -> Result<Samples, String> {
    let (scene, opts) = scene_and_options(p)?;
    Ok(Samples::of_options(&scene, &opts))
}

/// A calibration point's scene, and the options its variant renders it
/// with.
fn scene_and_options(p: &Point) -> Result<(hilcam::scene::Scene, hilcam::render::Options), String> {
    let text = calibration_scenes()
        .into_iter()
        .find(|(n, _)| *n == p.scene)
        .map(|(_, t)| t)
        .ok_or_else(|| format!("{}: no such calibration scene", p.scene))?;
    let scene = crate::scene_file::parse(&text)?.core_scene()?;
    let opts = variant_options(&scene, &Variant::parse(&p.variant)?);
    Ok((scene, opts))
}

/// A model as the Rust constant `planner.rs` holds.
pub fn rust_const(name: &str, m: &CostModel) -> String {
    let coef: Vec<String> = m.coef.iter().map(|c| format!("{c:.1}")).collect();
    let three = |v: &[f64]| v.iter().map(|c| format!("{c:.3}")).collect::<Vec<_>>().join(", ");
    format!(
        "pub const {name}: CostModel = CostModel {{\n    coef: [{}],\n    samples: SampleCost {{\n        grid: [{}],\n        aperture: [{}],\n    }},\n}};",
        coef.join(", "),
        three(&m.samples.grid),
        three(&m.samples.aperture)
    )
}

/// Runs the calibration on `board`, fits, checks the fit against the
/// shipped scenes' default path, and writes costfit.json and costfit.md.
///
/// With `keep` (a calibration file, `docs/cost-calibration.json`), only
/// the points through the aperture are measured; the others are that
/// file's.
pub fn run(board: Board, out: &Path, keep: Option<&Path>) -> Result<String, String> {
    // The kept points read before anything is written.
    let kept = keep.map(load_calibration).transpose()?;
    let mut outputs = crate::output::Outputs::prepare(out)?;
    let work = out.join("work");
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let mut paths = Vec::new();
    for (name, text) in calibration_scenes() {
        let p = work.join(format!("{name}.toml"));
        std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))?;
        paths.push(p);
    }
    let parse = |names: &[String]| names.iter().map(|v| Variant::parse(v)).collect::<Result<Vec<_>, _>>();
    let with = |arith: &[&str], what: &[&str]| -> Vec<String> {
        arith
            .iter()
            .flat_map(|a| what.iter().map(move |w| format!("{a}-{w}")))
            .collect()
    };
    let pick = |names: &[&str]| -> Vec<std::path::PathBuf> {
        paths
            .iter()
            .filter(|p| names.iter().any(|n| p.file_stem().is_some_and(|s| s.to_string_lossy() == *n)))
            .cloned()
            .collect()
    };
    let mut points = Vec::new();
    if let Some(kept) = kept {
        points = kept.points;
        points.retain(|p| p.samples.aperture == 0.0);
    } else {
        // (mix32-nomean: the closed plane without its mean, beside each
        // scene planned with it, so that its term is told from the
        // plane's.)
        let one = parse(&["mix32-poly", "mix32-nomean", "i32f32-poly", "i32f32-lut64-linear"].map(String::from))?;
        let mut pinned = Vec::new();
        for p in &paths {
            if weak_holds(p)? {
                pinned.push(p.clone());
            }
        }
        let aperture_only = pick(&DOF_SCENES);
        let later: Vec<_> = LATER_BATCHES.iter().map(|names| pick(names)).collect();
        let free: Vec<_> = paths
            .iter()
            .filter(|p| !pinned.contains(p) && !aperture_only.contains(p) && !later.iter().any(|l| l.contains(p)))
            .cloned()
            .collect();
        // The scenes with a lobe apart from those without, in both layouts
        // ([`LAYOUTS`]).
        let (plain, lobed) = by_lobe(&free)?;
        for (k, batch) in plain.chunks(6).chain(lobed.chunks(6)).enumerate() {
            measure(board, batch, &one, &work.join(format!("batch{k}")), &mut points)?;
        }
        for (k, batch) in later.iter().enumerate() {
            measure(board, batch, &one, &work.join(format!("later{k}")), &mut points)?;
        }
        for (rays, variants) in ["perspective", "weak"].into_iter().zip(WEAK_VARIANTS) {
            let v = parse(&variants.map(String::from))?;
            measure(board, &pinned, &v, &work.join(rays), &mut points)?;
        }
        // The second layout ([`LAYOUTS`]).
        let mut second = Vec::new();
        let (later_plain, later_lobed) = by_lobe(&later.concat())?;
        let mut k = 0;
        for dealt in [[plain, later_plain].concat(), [lobed, later_lobed].concat()] {
            let n = dealt.len().div_ceil(6);
            for j in 0..n {
                let batch: Vec<_> = dealt.iter().skip(j).step_by(n).cloned().collect();
                measure(board, &batch, &one, &work.join(format!("dealt{k}")), &mut second)?;
                k += 1;
            }
        }
        let both = parse(&WEAK_VARIANTS.concat().into_iter().map(String::from).collect::<Vec<_>>())?;
        measure(board, &pinned, &both, &work.join("both-rays"), &mut second)?;
        merge_layouts(&mut points, &second)?;
        let grids = parse(&with(&["mix32", "i32f32"], &GRIDS))?;
        measure(board, &pick(&SAMPLED_SCENES), &grids, &work.join("sampled"), &mut points)?;
    }
    let apertures = parse(&with(&["mix32", "i32f32"], &APERTURES))?;
    measure(board, &pick(&APERTURE_SCENES), &apertures, &work.join("aperture"), &mut points)?;
    let cal = Calibration {
        board: board.machine().into(),
        points,
    };
    let report = report(&cal, board, out)?;
    outputs.write(
        "costfit.json",
        &serde_json::to_vec_pretty(&cal).map_err(|e| e.to_string())?,
    )?;
    outputs.write("costfit.md", report.as_bytes())?;
    outputs.commit()?;
    Ok(report)
}

/// How far the second layout's counts are from the first's
/// ([`layout_spread`]), relative to the first's.
pub struct LayoutSpread {
    /// Points measured in both.
    pub points: usize,
    /// Root mean square of the relative differences.
    pub rms: f64,
    /// Their mean.
    pub mean: f64,
    /// The largest in size, signed, and its scene and variant.
    pub max: f64,
    /// Where [`LayoutSpread::max`] is.
    pub max_at: (String, String),
}

/// The spread between the layouts of `arithmetic`'s points measured in
/// both; `None` where none was.
pub fn layout_spread(points: &[Point], arithmetic: &str) -> Option<LayoutSpread> {
    let d: Vec<(f64, &Point)> = points
        .iter()
        .filter(|p| p.arithmetic == arithmetic)
        .filter_map(|p| match p.layouts[..] {
            [a, b, ..] => Some(((b - a) / a, p)),
            _ => None,
        })
        .collect();
    let (max, at) = d.iter().copied().max_by(|x, y| x.0.abs().total_cmp(&y.0.abs()))?;
    let n = d.len() as f64;
    Some(LayoutSpread {
        points: d.len(),
        rms: (d.iter().map(|x| x.0 * x.0).sum::<f64>() / n).sqrt(),
        mean: d.iter().map(|x| x.0).sum::<f64>() / n,
        max,
        max_at: (at.scene.clone(), at.variant.clone()),
    })
}

/// Makes each of `points` the mean of its count and `second`'s for the
/// same scene and variant (both kept in [`Point::layouts`]); every point
/// must be in both.
fn merge_layouts(points: &mut [Point], second: &[Point]) -> Result<(), String> {
    if second.len() != points.len() {
        return Err(format!(
            "second layout: {} points, the first {}",
            second.len(),
            points.len()
        ));
    }
    for p in points.iter_mut() {
        let q = second
            .iter()
            .find(|q| q.scene == p.scene && q.variant == p.variant)
            .ok_or_else(|| format!("{} {}: not in the second layout", p.scene, p.variant))?;
        p.layouts = vec![p.measured, q.measured];
        p.measured = (p.measured + q.measured) / 2.0;
    }
    Ok(())
}

/// Renders `scenes` with `variants` on `board` (one firmware) and records
/// a point for each frame.
fn measure(
    board: Board,
    scenes: &[std::path::PathBuf],
    variants: &[Variant],
    dir: &Path,
    points: &mut Vec<Point>,
) -> Result<(), String> {
    let r = hil_variants(board, None, scenes, variants, dir)?;
    for f in r.frames {
        let path = scenes
            .iter()
            .find(|p| p.file_stem().is_some_and(|s| s.to_string_lossy() == f.scene))
            .ok_or_else(|| format!("{}: not in the batch", f.scene))?;
        let scene = load(path)?.core_scene()?;
        let v = Variant::parse(&f.variant)?;
        let opts = variant_options(&scene, &v);
        // The table variant on a scene without distortion repeats the
        // polynomial one.
        if v.name().contains("lut") && scene.distortion().is_none() {
            continue;
        }
        // And without the mean on a scene planned without it (or where it
        // has no light term to leave out: `Features::closed_mean`).
        let planned = variant_options(&scene, &Variant::PLANNED);
        if v.name().ends_with("-nomean") && Features::of_options(&scene, &planned).closed_mean == 0.0 {
            continue;
        }
        points.push(Point {
            scene: f.scene.clone(),
            variant: f.variant.clone(),
            arithmetic: opts.arithmetic.name().into(),
            features: Features::of_options(&scene, &opts).to_array().to_vec(),
            samples: Samples::of_options(&scene, &opts),
            measured: f.instructions_per_pixel.ok_or("no instruction count")?,
            layouts: Vec::new(),
        });
    }
    Ok(())
}

/// The fit and the check against the shipped scenes.
fn report(cal: &Calibration, board: Board, out: &Path) -> Result<String, String> {
    let fast = fit(&cal.points, "fast")?;
    let wide = fit(&cal.points, "wide")?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Cost model fit ({} M3 instructions/pixel, QEMU -icount)\n",
        cal.board
    );
    let _ = writeln!(s, "## Coefficients\n\n| term | fast | wide |\n|---|---|---|");
    for (k, t) in TERMS.iter().enumerate() {
        let _ = writeln!(s, "| {t} | {:.1} | {:.1} |", fast.coef[k], wide.coef[k]);
    }
    let _ = writeln!(
        s,
        "\nA pixel's samples (`SampleCost`): the grid's constants in M3 instructions a pixel, its samples and the aperture as multiples of one sample's cost:\n\n| term | fast | wide |\n|---|---|---|"
    );
    for (k, t) in GRID_TERMS.iter().enumerate() {
        let _ = writeln!(s, "| {t} | {:.3} | {:.3} |", fast.samples.grid[k], wide.samples.grid[k]);
    }
    for (k, t) in APERTURE_TERMS.iter().enumerate() {
        let _ = writeln!(
            s,
            "| {t} | {:.3} | {:.3} |",
            fast.samples.aperture[k], wide.samples.aperture[k]
        );
    }
    let _ = writeln!(
        s,
        "\n```rust\n{}\n{}\n```\n",
        rust_const("FAST_COST", &fast),
        rust_const("WIDE_COST", &wide)
    );
    let _ = writeln!(
        s,
        "## Calibration scenes\n\n| scene | variant | measured | each layout | fitted | error |\n|---|---|---|---|---|---|"
    );
    // The largest error of the one-sample points, and of the others.
    let mut worst = [0.0f64; 2];
    for p in &cal.points {
        let m = if p.arithmetic == "fast" { &fast } else { &wide };
        let pred = m.samples.cost(m.predict_terms(&p.features), &p.samples);
        let e = (pred - p.measured) / p.measured;
        let w = &mut worst[usize::from(!p.is_one_sample())];
        *w = w.max(e.abs());
        let each: Vec<String> = p.layouts.iter().map(|c| format!("{c:.0}")).collect();
        let _ = writeln!(
            s,
            "| {} | {} | {:.0} | {} | {:.0} | {:+.1} % |",
            p.scene,
            p.variant,
            p.measured,
            each.join(" / "),
            pred,
            100.0 * e
        );
    }
    for arithmetic in ["fast", "wide"] {
        if let Some(l) = layout_spread(&cal.points, arithmetic) {
            let _ = writeln!(
                s,
                "\nThe layouts' counts, {arithmetic}: the second's against the first's over {} points, {:.1} % RMS, {:+.1} % at most ({} {}); mean {:+.1} %.",
                l.points,
                100.0 * l.rms,
                100.0 * l.max,
                l.max_at.0,
                l.max_at.1,
                100.0 * l.mean
            );
        }
    }
    let _ = writeln!(
        s,
        "\nLargest calibration error: {:.1} % (one sample), {:.1} % (sample grids and aperture points).\n",
        100.0 * worst[0],
        100.0 * worst[1]
    );
    for arithmetic in ["fast", "wide"] {
        let (rms, max) = left_out_grid_error(&cal.points, arithmetic)?;
        let _ = writeln!(
            s,
            "Sample grids, {arithmetic}, each calibration scene's sampled points predicted by a fit without them: {:.1} % RMS, {:.1} % at most.",
            100.0 * rms,
            100.0 * max
        );
    }
    let _ = writeln!(s);
    // The shipped scenes, default path: the planner's prediction (the
    // committed model) against QEMU.
    let shipped = shipped_scenes()?;
    let _ = writeln!(s, "## Shipped scenes, default path\n");
    let terms = shipped_table(&mut s, board, &shipped, &out.join("work/shipped"), [&fast, &wide])?;
    // Where each prediction comes from: the terms of one sample (before
    // the sample grid's or the aperture's factor), this fit's.
    let _ = write!(s, "\nThe shipped scenes' one-sample terms by this fit (coefficient × feature, instructions a pixel; 0 left blank):\n\n| term |");
    for (scene, _) in &terms {
        let _ = write!(s, " {scene} |");
    }
    let _ = write!(s, "\n|---|{}\n", "---|".repeat(terms.len()));
    for (k, name) in TERMS.iter().enumerate() {
        let _ = write!(s, "| {name} |");
        for (_, t) in &terms {
            match t.get(k) {
                Some(v) if *v != 0.0 => {
                    let _ = write!(s, " {v:.1} |");
                }
                _ => s.push_str(" |"),
            }
        }
        s.push('\n');
    }
    // And with the principal point off the centre, as a calibrated
    // camera's is (the fast loop then mirrors no ray).
    let dir = out.join("work/shipped-off-centre");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut moved = Vec::new();
    for p in &shipped {
        moved.extend(off_centre_copy(p, &dir)?);
    }
    let _ = writeln!(
        s,
        "\n## Shipped scenes with the principal point off the centre\n\nEach shipped scene with `principal_point` \
         moved by ({}, {}) px from the sensor's centre, default path:\n",
        OFF_CENTRE[0],
        OFF_CENTRE[1]
    );
    shipped_table(&mut s, board, &moved, &dir, [&fast, &wide])?;
    Ok(s)
}

/// How far [`off_centre_copy`] moves the principal point from the
/// sensor's centre, pixels (x, y).
const OFF_CENTRE: [f64; 2] = [3.8, 2.2];

/// A copy of the scene at `path` in `dir` (named `NAME-off-centre`) with
/// its principal point [`OFF_CENTRE`] from the sensor's centre; `None` if
/// the scene sets its principal point already.
fn off_centre_copy(path: &Path, dir: &Path) -> Result<Option<std::path::PathBuf>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    if text.contains("principal_point") {
        return Ok(None);
    }
    let r = load(path)?;
    let (w, h) = r.core_scene()?.camera().intrinsics().size();
    let name = format!("{}-off-centre", r.desc.name);
    let (cx, cy) = (
        (f64::from(w) - 1.0) / 2.0 + OFF_CENTRE[0],
        (f64::from(h) - 1.0) / 2.0 + OFF_CENTRE[1],
    );
    let mut out = String::new();
    // (The scene's name is the `name` before any table.)
    let mut top = true;
    for line in text.lines() {
        top &= !line.trim_start().starts_with('[');
        if top && line.starts_with("name = ") {
            let _ = writeln!(out, "name = {name:?}");
            continue;
        }
        let _ = writeln!(out, "{line}");
        if line.trim() == "[camera]" {
            let _ = writeln!(out, "principal_point = [{cx:?}, {cy:?}]");
        }
    }
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, out).map_err(|e| format!("{}: {e}", p.display()))?;
    // (It must load as the scene it copies, moved.)
    let moved = load(&p)?;
    if moved.desc.name != name || moved.core_scene()?.camera().intrinsics().is_centred_x() {
        return Err(format!("{}: the off-centre copy did not take", p.display()));
    }
    Ok(Some(p))
}

/// Renders the scenes at `paths` on `board` (default path, one firmware in
/// `dir`) and writes a table of their predicted (committed model, and the
/// `models` of this fit: fast, wide) against measured cost; returns each
/// scene's one-sample terms under this fit (coefficient × feature).
fn shipped_table(
    s: &mut String,
    board: Board,
    paths: &[std::path::PathBuf],
    dir: &Path,
    [fast, wide]: [&CostModel; 2],
) -> Result<Vec<(String, [f64; COST_TERMS])>, String> {
    let r = hil_variants(board, None, paths, &[Variant::PLANNED], dir)?;
    let _ = writeln!(
        s,
        "| scene | chosen | predicted (committed model) | predicted (this fit) | measured | error (committed) |\n|---|---|---|---|---|---|"
    );
    let mut terms: Vec<(String, [f64; COST_TERMS])> = Vec::new();
    for f in &r.frames {
        let path = paths
            .iter()
            .find(|p| p.file_stem().is_some_and(|s| s.to_string_lossy() == f.scene))
            .ok_or("shipped scene")?;
        let scene = load(path)?.core_scene()?;
        let plan = planner::plan(&scene, &Budget::default());
        let chosen = plan.candidates.get(plan.chosen).ok_or("no candidate")?;
        let model = match chosen.arithmetic {
            Arithmetic::Fast => fast,
            Arithmetic::Wide => wide,
        };
        // A pixel's samples (pixel-area grid, aperture points) as the
        // planner costs them, by this fit's SampleCost.
        let features = Features::of_options(&scene, &plan.options).to_array();
        let fitted = model.samples.cost(model.predict_terms(&features), &plan.samples);
        let mut t = [0.0; COST_TERMS];
        for ((t, c), x) in t.iter_mut().zip(model.coef).zip(features) {
            *t = c * x;
        }
        terms.push((f.scene.clone(), t));
        let measured = f.instructions_per_pixel.ok_or("no instruction count")?;
        let _ = writeln!(
            s,
            "| {} | {} | {:.0} | {:.0} | {:.0} | {:+.1} % |",
            f.scene,
            chosen.name(),
            chosen.m3_instructions_per_pixel,
            fitted,
            measured,
            100.0 * (chosen.m3_instructions_per_pixel - measured) / measured
        );
    }
    Ok(terms)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(scene: &str, measured: f64) -> Point {
        Point {
            scene: scene.into(),
            variant: "mix32-poly".into(),
            arithmetic: "fast".into(),
            features: vec![1.0],
            samples: Samples::ONE,
            measured,
            layouts: Vec::new(),
        }
    }

    #[test]
    fn layouts_merge_into_their_mean_and_spread() {
        let mut first = vec![point("a", 100.0), point("b", 200.0)];
        let second = vec![point("b", 150.0), point("a", 110.0)];
        merge_layouts(&mut first, &second).expect("merge");
        assert_eq!(first[0].layouts, [100.0, 110.0]);
        assert_eq!((first[0].measured, first[1].measured), (105.0, 175.0));
        let l = layout_spread(&first, "fast").expect("spread");
        assert_eq!((l.points, l.max, l.max_at.0.as_str()), (2, -0.25, "b"));
        assert!((l.mean - (-0.075)).abs() < 1e-12 && (l.rms - (0.03625f64).sqrt()).abs() < 1e-12);
        assert!(layout_spread(&first, "wide").is_none());
        // A point missing from either layout is an error, not a mean of one.
        let mut first = vec![point("a", 100.0), point("b", 200.0)];
        let err = merge_layouts(&mut first, &[point("a", 1.0), point("c", 1.0)]).expect_err("c is not b");
        assert!(err.contains("b mix32-poly"), "{err}");
        assert!(merge_layouts(&mut first, &[point("a", 1.0)]).is_err());
    }
}
