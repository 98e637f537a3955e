//! `host-sim tradeoff`: measures the speed/accuracy trade of the rendering
//! variants ([`crate::variant`]).
//!
//! For every variant and sweep scene: fidelity against the f64 reference
//! (the render metrics), instructions per pixel on the Cortex-M3 and M4F
//! under QEMU `-icount` (firmware built with those variants; each frame is
//! also checked byte for byte against the host render of the same variant),
//! host ns per pixel (median of repeated build + render), table bytes and the
//! firmware's flash. Then growth with resolution and primitive count, and
//! what the planner's pruning saves on every shipped scene. Writes
//! `tradeoff.json`, `tradeoff.md` and `tradeoff.png`.

use crate::harness::{compare, Collect, Metrics};
use crate::hil_cmd::{hil_variants, repo_root, shipped_scenes, Board, HilReport};
use crate::reference::render::RefScene;
use crate::scene_file::{load, Resolved};
use crate::variant::{FrameUser, ScalarKind, Variant, WithScalar};
use hilcam::distortion::MAX_LUT;
use hilcam::planner::{plan, Budget, Plan};
use hilcam::render::{DistortionEval, Frame, LineSink, Override};
use hilcam::scalar::Scalar;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to sweep.
#[derive(Clone, Debug)]
pub struct Config {
    /// Sweep scenes (files); `None`: the tiny generated scene.
    pub scenes: Option<Vec<PathBuf>>,
    /// Variants.
    pub variants: Vec<Variant>,
    /// Boards to run the firmware on.
    pub boards: Vec<Board>,
    /// Host timing repeats.
    pub repeats: usize,
    /// Growth and pruning runs.
    pub growth_and_pruning: bool,
}

fn table(entries: usize, eval: DistortionEval) -> Override {
    Override::Table { entries, eval }
}

impl Config {
    /// The full sweep on the standard and checkerboard scenes.
    pub fn full(boards: Vec<Board>, repeats: usize) -> Config {
        use DistortionEval::{Linear, Nearest};
        let mut variants = vec![Variant::PLANNED];
        let mut overs = vec![];
        overs.extend([16, 64, 256, 1024].map(|n| table(n, Linear)));
        overs.extend([16, 256, 1024].map(|n| table(n, Nearest)));
        overs.push(Override::Polynomial);
        variants.extend(overs.into_iter().map(|over| Variant {
            scalar: ScalarKind::I32F32,
            over,
        }));
        for over in [table(256, Linear), Override::Polynomial] {
            variants.push(Variant {
                scalar: ScalarKind::F32,
                over,
            });
        }
        // The fast arithmetic evaluates the polynomial (no table).
        variants.push(Variant {
            scalar: ScalarKind::Mix32,
            over: Override::Polynomial,
        });
        let root = repo_root().join("scenes");
        Config {
            scenes: Some(vec![
                root.join("standard.toml"),
                root.join("checkerboard-barrel.toml"),
            ]),
            variants,
            boards,
            repeats: repeats.max(1),
            growth_and_pruning: true,
        }
    }

    /// A tiny sweep: a 40×30 standard scene, four variants, no growth or
    /// pruning runs.
    pub fn tiny(boards: Vec<Board>, repeats: usize) -> Config {
        Config {
            scenes: None,
            variants: vec![
                Variant::PLANNED,
                Variant {
                    scalar: ScalarKind::I32F32,
                    over: Override::Polynomial,
                },
                Variant {
                    scalar: ScalarKind::F32,
                    over: Override::Polynomial,
                },
                Variant {
                    scalar: ScalarKind::Mix32,
                    over: Override::Polynomial,
                },
            ],
            boards,
            repeats: repeats.clamp(1, 3),
            growth_and_pruning: false,
        }
    }
}

/// One variant on one scene.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Variant name (`f64-reference` for the reference itself).
    pub variant: String,
    /// Per-pixel number type.
    pub scalar: String,
    /// Scene.
    pub scene: String,
    /// Largest pixel → undistorted error against the reference, px.
    pub max_geom_err_px: f64,
    /// RMS of it, px.
    pub rms_geom_err_px: f64,
    /// Largest |variant − reference| over all pixels, LSB.
    pub max_abs_lsb: u32,
    /// RMS over all pixels, LSB.
    pub rms_lsb: f64,
    /// PSNR over all pixels, dB (null: identical).
    pub psnr_db: Option<f64>,
    /// Largest |variant − reference| over smooth pixels, LSB.
    pub max_abs_lsb_smooth: u32,
    /// RMS over smooth pixels, LSB.
    pub rms_lsb_smooth: f64,
    /// PSNR over smooth pixels, dB (null: identical).
    pub psnr_db_smooth: Option<f64>,
    /// Fraction of pixels identical to the reference.
    pub exact_fraction: f64,
    /// Edge pixels whose values differ from the reference.
    pub edge_pixels_differing: usize,
    /// Instructions per pixel on the Cortex-M3 (QEMU icount; not cycles).
    pub instructions_per_pixel_m3: Option<f64>,
    /// Instructions per pixel on the Cortex-M4F.
    pub instructions_per_pixel_m4f: Option<f64>,
    /// The M3 frame was byte-identical to the host render of the variant.
    pub bit_exact_m3: Option<bool>,
    /// The M4F frame was byte-identical to the host render of the variant.
    pub bit_exact_m4f: Option<bool>,
    /// Host ns per pixel, median of the repeats (prepare + render).
    pub host_ns_per_pixel: f64,
    /// Distortion table bytes.
    pub table_bytes: usize,
    /// Flash of the M3 firmware holding this scalar type's variants, bytes.
    pub flash_bytes_m3: Option<u64>,
    /// Flash of the M4F firmware holding this scalar type's variants, bytes.
    pub flash_bytes_m4f: Option<u64>,
}

/// Instructions per frame at one size or primitive count.
#[derive(Clone, Debug, Serialize)]
pub struct GrowthPoint {
    /// Scene.
    pub scene: String,
    /// Pixels.
    pub pixels: u64,
    /// Primitives.
    pub primitives: usize,
    /// Instructions per frame (M3, M4F).
    pub instructions_m3: Option<u64>,
    /// Instructions per frame on the M4F.
    pub instructions_m4f: Option<u64>,
}

/// Growth of one variant.
#[derive(Clone, Debug, Serialize)]
pub struct Growth {
    /// Variant.
    pub variant: String,
    /// 80×60 to 640×480, standard scene.
    pub resolution: Vec<GrowthPoint>,
    /// 1 to 16 primitives, standard scene at 160×120.
    pub primitives: Vec<GrowthPoint>,
    /// Least-squares slope of instructions per frame against pixels (M3).
    pub per_pixel_slope_m3: Option<f64>,
    /// The same on the M4F.
    pub per_pixel_slope_m4f: Option<f64>,
    /// Least-squares slope of instructions per frame against primitives (M3).
    pub per_primitive_slope_m3: Option<f64>,
    /// The same on the M4F.
    pub per_primitive_slope_m4f: Option<f64>,
}

/// What the planner's pruning saves on one scene.
#[derive(Clone, Debug, Serialize)]
pub struct Pruning {
    /// Scene.
    pub scene: String,
    /// Stages the planner dropped (or simplified) for it.
    pub dropped: Vec<String>,
    /// Instructions per pixel, planned / with every stage (M3).
    pub planned_m3: Option<f64>,
    /// With every stage (M3).
    pub all_stages_m3: Option<f64>,
    /// Planned (M4F).
    pub planned_m4f: Option<f64>,
    /// With every stage (M4F).
    pub all_stages_m4f: Option<f64>,
    /// Host ns per pixel, planned.
    pub planned_host_ns: f64,
    /// Host ns per pixel, every stage.
    pub all_stages_host_ns: f64,
    /// Largest |planned − all stages| over all pixels, LSB (the pruning's
    /// own effect on the image).
    pub max_abs_lsb_between: u32,
}

/// A recommendation.
#[derive(Clone, Debug, Serialize)]
pub struct Recommendation {
    /// M0, M3, M4F or host.
    pub target: String,
    /// Variant.
    pub variant: String,
    /// Why.
    pub reason: String,
}

/// `tradeoff.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Every variant on every sweep scene.
    pub variants: Vec<Row>,
    /// Growth runs.
    pub growth: Vec<Growth>,
    /// Pruning runs.
    pub pruning: Vec<Pruning>,
    /// Recommendations.
    pub recommendations: Vec<Recommendation>,
    /// The fixed-point variant with the fewest M3 instructions per pixel of
    /// those within 1 LSB on smooth pixels on every sweep scene.
    pub best_fixed_m3: Option<String>,
    /// On the M3, first sweep scene: the cheapest f32 (soft-float) variant's
    /// instructions per pixel divided by `best_fixed_m3`'s (target ≥ 10).
    pub m3_fixed_speedup_over_f32: Option<f64>,
    /// The same ratio on the M4F (hardware f32).
    pub m4f_fixed_speedup_over_f32: Option<f64>,
    /// The same ratio on the M3 for the cheapest fixed-point variant
    /// whatever its error.
    pub m3_fastest_fixed_speedup_over_f32: Option<f64>,
}

impl Row {
    /// A row with the metrics `m` of `variant` against the reference (`None`:
    /// the reference itself, exact by definition); device figures are filled
    /// in after the firmware runs.
    fn new(
        variant: String,
        scalar: &str,
        scene: &str,
        m: Option<&Metrics>,
        host_ns: f64,
        table_bytes: usize,
    ) -> Row {
        Row {
            variant,
            scalar: scalar.into(),
            scene: scene.into(),
            max_geom_err_px: m.map_or(0.0, |m| m.max_geom_err_px),
            rms_geom_err_px: m.map_or(0.0, |m| m.rms_geom_err_px),
            max_abs_lsb: m.map_or(0, |m| m.max_abs_lsb),
            rms_lsb: m.map_or(0.0, |m| m.rms_lsb),
            psnr_db: m.and_then(|m| m.psnr_db),
            max_abs_lsb_smooth: m.map_or(0, |m| m.max_abs_lsb_smooth),
            rms_lsb_smooth: m.map_or(0.0, |m| m.rms_lsb_smooth),
            psnr_db_smooth: m.and_then(|m| m.psnr_db_smooth),
            exact_fraction: m.map_or(1.0, |m| m.exact_fraction),
            edge_pixels_differing: m.map_or(0, |m| m.edge_pixels_differing),
            instructions_per_pixel_m3: None,
            instructions_per_pixel_m4f: None,
            bit_exact_m3: None,
            bit_exact_m4f: None,
            host_ns_per_pixel: host_ns,
            table_bytes,
            flash_bytes_m3: None,
            flash_bytes_m4f: None,
        }
    }

    fn is_fixed_point(&self) -> bool {
        self.scalar != "f32" && self.scalar != "f64"
    }
}

/// The distinct number types of `variants`, in order.
fn scalar_kinds(variants: &[Variant]) -> Vec<ScalarKind> {
    let mut kinds: Vec<ScalarKind> = Vec::new();
    for v in variants {
        if !kinds.contains(&v.scalar) {
            kinds.push(v.scalar);
        }
    }
    kinds
}

struct Discard;
impl LineSink for Discard {
    type Error = std::convert::Infallible;
    fn line(&mut self, _: u16, _: &[u8], _: &[u8]) -> Result<(), Self::Error> {
        Ok(())
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Host ns per pixel of a variant: median over `repeats` of preparing the
/// frame and rendering every line.
fn host_ns_per_pixel(v: &Variant, r: &Resolved, repeats: usize) -> Result<f64, String> {
    struct Time<'a> {
        scene: &'a hilcam::scene::Scene,
        opts: hilcam::render::Options,
        repeats: usize,
    }
    impl WithScalar for Time<'_> {
        type Out = Result<f64, String>;
        fn run<S: Scalar>(self) -> Self::Out {
            let mut times = Vec::new();
            let (w, h) = self.scene.camera.intrinsics.size();
            let mut line = vec![0u8; w as usize * self.scene.format.bytes_per_pixel()];
            let mut flags = vec![0u8; w as usize];
            for _ in 0..self.repeats {
                let t = Instant::now();
                let frame = Frame::<S>::build(self.scene, &self.opts).map_err(|e| format!("{e:?}"))?;
                frame
                    .render(&mut line, &mut flags, &mut Discard)
                    .map_err(|e| format!("{e:?}"))?;
                times.push(t.elapsed().as_nanos() as f64 / (w as f64 * h as f64));
            }
            Ok(median(times))
        }
    }
    let scene = r.core_scene()?;
    let opts = v.options(plan(&scene, &Budget::default()).options);
    v.scalar.dispatch(Time {
        scene: &scene,
        opts,
        repeats,
    })
}

/// Host ns per pixel of the f64 reference (`pixel` over the frame, after
/// `RefScene::new`; the edge classification is not timed).
fn reference_ns_per_pixel(r: &Resolved, repeats: usize) -> f64 {
    let (w, h) = (r.desc.camera.width as usize, r.desc.camera.height as usize);
    let mut times = Vec::new();
    let mut sink = 0u64;
    for _ in 0..repeats {
        let t = Instant::now();
        let rs = RefScene::new(r);
        for j in 0..h {
            for i in 0..w {
                sink = sink.wrapping_add(rs.pixel(i as f64, j as f64).0[0] as u64);
            }
        }
        times.push(t.elapsed().as_nanos() as f64 / (w * h) as f64);
    }
    std::hint::black_box(sink);
    median(times)
}

/// The render metrics of a variant (and its table bytes).
struct Measure<'a> {
    r: &'a Resolved,
    rs: &'a RefScene,
    reference: &'a crate::reference::render::RefFrame,
}

impl FrameUser for Measure<'_> {
    type Out = (Metrics, usize);
    fn use_frame<S: Scalar>(self, plan: &Plan, frame: &Frame<S>, core: Collect) -> Self::Out {
        let m = compare(
            self.r,
            self.rs,
            self.reference,
            plan,
            &Budget::default(),
            frame,
            &core,
        );
        (m, frame.table_bytes())
    }
}

/// Edits the standard scene's text: size (same field of view), name, and
/// the primitive count (the first primitives of the file, then spheres).
fn derive_scene(base: &str, name: &str, width: u32, primitives: usize) -> Result<String, String> {
    let mut t: toml::Table = base.parse().map_err(|e| format!("standard.toml: {e}"))?;
    t.insert("name".into(), toml::Value::String(name.into()));
    let cam = t
        .get_mut("camera")
        .and_then(toml::Value::as_table_mut)
        .ok_or("standard.toml: camera")?;
    let w0 = cam
        .get("width")
        .and_then(toml::Value::as_integer)
        .ok_or("camera.width")? as f64;
    let pitch = cam
        .get("pitch")
        .and_then(toml::Value::as_float)
        .ok_or("camera.pitch")?;
    cam.insert("width".into(), toml::Value::Integer(width as i64));
    cam.insert("height".into(), toml::Value::Integer((width * 3 / 4) as i64));
    cam.insert("pitch".into(), toml::Value::Float(pitch * w0 / width as f64));
    let prims = t
        .get_mut("primitives")
        .and_then(toml::Value::as_array_mut)
        .ok_or("standard.toml: primitives")?;
    prims.truncate(primitives);
    let mut k = 0;
    while prims.len() < primitives {
        let mut s = toml::Table::new();
        s.insert("kind".into(), "sphere".into());
        s.insert("material".into(), "matte".into());
        let (x, z) = (-1.2 + 0.6 * (k % 5) as f64, 0.9 + 0.6 * (k / 5) as f64);
        s.insert(
            "centre".into(),
            toml::Value::Array(vec![x.into(), 0.12.into(), z.into()]),
        );
        s.insert("radius".into(), 0.12.into());
        prims.push(toml::Value::Table(s));
        k += 1;
    }
    toml::to_string(&t).map_err(|e| e.to_string())
}

fn write_scene(dir: &Path, name: &str, text: &str) -> Result<PathBuf, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))?;
    Ok(p)
}

/// Firmware runs: per board, per scalar type (one build each, so that its
/// flash is that type's). Returns (scene, variant) → (instructions/pixel,
/// instructions, bit_exact) and scalar → flash, per board.
type Runs = HashMap<(String, String), (f64, u64, bool)>;

/// A hil report's frames as [`Runs`].
fn runs_of(report: HilReport) -> Runs {
    let mut runs = Runs::new();
    for f in report.frames {
        let px = f.width as f64 * f.height as f64;
        if let Some(ins) = f.instructions {
            runs.insert((f.scene, f.variant), (ins as f64 / px, ins, f.bit_exact));
        }
    }
    runs
}

/// Runs `scenes` × `variants` in one firmware on every board; `label` names
/// the output folder `hil/<board>-<label>`.
fn runs_per_board(
    boards: &[Board],
    label: &str,
    scenes: &[PathBuf],
    variants: &[Variant],
    out: &Path,
    pb: &ProgressBar,
) -> Result<Vec<(Board, Runs)>, String> {
    let mut per_board = Vec::new();
    for &board in boards {
        pb.set_message(format!("{} firmware, {label}", board.machine()));
        let dir = out.join("hil").join(format!("{}-{label}", board.machine()));
        per_board.push((board, runs_of(hil_variants(board, None, scenes, variants, &dir)?)));
        pb.inc(1);
    }
    Ok(per_board)
}

/// What `per_board` measured for `scene` and `variant` on `board`.
fn lookup<'a>(
    per_board: &'a [(Board, Runs)],
    board: Board,
    scene: &str,
    variant: &str,
) -> Option<&'a (f64, u64, bool)> {
    per_board
        .iter()
        .find(|(b, _)| *b == board)
        .and_then(|(_, r)| r.get(&(scene.to_string(), variant.to_string())))
}

fn firmware_runs(
    board: Board,
    scenes: &[PathBuf],
    variants: &[Variant],
    out: &Path,
    pb: &ProgressBar,
) -> Result<(Runs, HashMap<ScalarKind, u64>), String> {
    let mut runs = Runs::new();
    let mut flash = HashMap::new();
    for k in scalar_kinds(variants) {
        let group: Vec<Variant> = variants.iter().filter(|v| v.scalar == k).copied().collect();
        pb.set_message(format!("{} firmware, {}", board.machine(), k.name()));
        let dir = out.join("hil").join(format!("{}-{}", board.machine(), k.name()));
        let report = hil_variants(board, None, scenes, &group, &dir)?;
        flash.insert(k, report.flash_bytes);
        runs.extend(runs_of(report));
        pb.inc(1);
    }
    Ok((runs, flash))
}

fn slope(points: &[(f64, f64)]) -> Option<f64> {
    let n = points.len() as f64;
    if points.len() < 2 {
        return None;
    }
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Runs the sweep and writes the three files into `out`.
pub fn run(cfg: &Config, out: &Path) -> Result<String, String> {
    let mut outputs = crate::output::Outputs::prepare(out)?;
    let base_path = repo_root().join("scenes/standard.toml");
    let base = std::fs::read_to_string(&base_path).map_err(|e| format!("{}: {e}", base_path.display()))?;
    let scenes: Vec<PathBuf> = match &cfg.scenes {
        Some(s) => s.clone(),
        None => vec![write_scene(
            &out.join("scenes"),
            "tiny",
            &derive_scene(&base, "tiny", 40, 3)?,
        )?],
    };
    let resolved: Vec<Resolved> = scenes.iter().map(|p| load(p)).collect::<Result<_, _>>()?;
    let kinds = scalar_kinds(&cfg.variants).len();
    let extra = if cfg.growth_and_pruning { 3 } else { 0 };
    let steps = resolved.len() * (cfg.variants.len() + 1) + cfg.boards.len() * (kinds + extra);
    let pb = ProgressBar::new(steps as u64);
    pb.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {elapsed_precise} {msg}")
            .map_err(|e| e.to_string())?,
    );

    // Host: fidelity and timing.
    let mut rows = Vec::new();
    for r in &resolved {
        pb.set_message(format!("host, {}: reference", r.desc.name));
        let rs = RefScene::new(r);
        let reference = rs.render();
        let ns = reference_ns_per_pixel(r, cfg.repeats);
        rows.push(Row::new("f64-reference".into(), "f64", &r.desc.name, None, ns, 0));
        pb.inc(1);
        for v in &cfg.variants {
            pb.set_message(format!("host, {}: {}", r.desc.name, v.name()));
            let (m, table_bytes) = v.render(
                r,
                &Budget::default(),
                Measure {
                    r,
                    rs: &rs,
                    reference: &reference,
                },
            )?;
            let ns = host_ns_per_pixel(v, r, cfg.repeats)?;
            rows.push(Row::new(
                v.name(),
                v.scalar.name(),
                &r.desc.name,
                Some(&m),
                ns,
                table_bytes,
            ));
            pb.inc(1);
        }
    }

    // Firmware: instructions, bit-exactness, flash.
    for &board in &cfg.boards {
        let (runs, flash) = firmware_runs(board, &scenes, &cfg.variants, out, &pb)?;
        let m3 = board == Board::Lm3s6965evb;
        for row in rows.iter_mut() {
            let Some(v) = cfg.variants.iter().find(|v| v.name() == row.variant) else {
                continue;
            };
            let run = runs.get(&(row.scene.clone(), row.variant.clone()));
            let fl = flash.get(&v.scalar).copied();
            if m3 {
                row.instructions_per_pixel_m3 = run.map(|r| r.0);
                row.bit_exact_m3 = Some(run.is_some_and(|r| r.2));
                row.flash_bytes_m3 = fl;
            } else {
                row.instructions_per_pixel_m4f = run.map(|r| r.0);
                row.bit_exact_m4f = Some(run.is_some_and(|r| r.2));
                row.flash_bytes_m4f = fl;
            }
        }
    }

    let first = resolved.first().map(|r| r.desc.name.clone()).unwrap_or_default();
    let fixed_rows: Vec<Row> = rows.iter().filter(|r| r.is_fixed_point()).cloned().collect();
    let best_fixed_m3 = cheapest(&fixed_rows, &resolved, |r| r.instructions_per_pixel_m3, false);
    let fastest_fixed_m3 = cheapest(&fixed_rows, &resolved, |r| r.instructions_per_pixel_m3, true);
    let recommendations = recommend(
        &rows,
        &resolved,
        best_fixed_m3.as_deref(),
        fastest_fixed_m3.as_deref(),
    );
    let ratio = |fixed: Option<&String>, m3: bool| -> Option<f64> {
        let ipp = |r: &Row| {
            if m3 {
                r.instructions_per_pixel_m3
            } else {
                r.instructions_per_pixel_m4f
            }
        };
        let f32_best = rows
            .iter()
            .filter(|r| r.scalar == "f32" && r.scene == first)
            .filter_map(ipp)
            .fold(f64::INFINITY, f64::min);
        let fixed = rows
            .iter()
            .find(|r| Some(&r.variant) == fixed && r.scene == first)
            .and_then(ipp)?;
        f32_best.is_finite().then(|| f32_best / fixed)
    };
    let speedups = (
        ratio(best_fixed_m3.as_ref(), true),
        ratio(best_fixed_m3.as_ref(), false),
        ratio(fastest_fixed_m3.as_ref(), true),
    );
    let rec_m3 = best_fixed_m3.clone();

    // Growth and pruning.
    let mut growth = Vec::new();
    let mut pruning = Vec::new();
    if cfg.growth_and_pruning {
        let gdir = out.join("scenes");
        let mut res_scenes = Vec::new();
        for w in [80u32, 160, 320, 640] {
            let name = format!("standard-{w}x{}", w * 3 / 4);
            res_scenes.push(write_scene(&gdir, &name, &derive_scene(&base, &name, w, 3)?)?);
        }
        let mut prim_scenes = Vec::new();
        for n in [1usize, 2, 4, 8, 16] {
            let name = format!("standard-{n}-primitives");
            prim_scenes.push(write_scene(&gdir, &name, &derive_scene(&base, &name, 160, n)?)?);
        }
        let all: Vec<PathBuf> = res_scenes.iter().chain(&prim_scenes).cloned().collect();
        let all_r: Vec<Resolved> = all.iter().map(|p| load(p)).collect::<Result<_, _>>()?;
        let mut gvariants = vec![Variant::PLANNED];
        if let Some(rec) = rec_m3.as_ref().and_then(|n| Variant::parse(n).ok()) {
            if rec != Variant::PLANNED {
                gvariants.push(rec);
            }
        }
        let per_board = runs_per_board(&cfg.boards, "growth", &all, &gvariants, out, &pb)?;
        let ins = |board: Board, scene: &str, v: &str| lookup(&per_board, board, scene, v).map(|r| r.1);
        for v in &gvariants {
            let point = |r: &Resolved| GrowthPoint {
                scene: r.desc.name.clone(),
                pixels: r.desc.camera.width as u64 * r.desc.camera.height as u64,
                primitives: r.primitives.len(),
                instructions_m3: ins(Board::Lm3s6965evb, &r.desc.name, &v.name()),
                instructions_m4f: ins(Board::Mps2An386, &r.desc.name, &v.name()),
            };
            let resolution: Vec<GrowthPoint> = all_r.iter().take(res_scenes.len()).map(point).collect();
            let primitives: Vec<GrowthPoint> = all_r.iter().skip(res_scenes.len()).map(point).collect();
            let fit = |pts: &[GrowthPoint], x: fn(&GrowthPoint) -> f64, m3: bool| {
                let p: Vec<(f64, f64)> = pts
                    .iter()
                    .filter_map(|g| {
                        let y = if m3 { g.instructions_m3 } else { g.instructions_m4f };
                        y.map(|y| (x(g), y as f64))
                    })
                    .collect();
                slope(&p)
            };
            growth.push(Growth {
                variant: v.name(),
                per_pixel_slope_m3: fit(&resolution, |g| g.pixels as f64, true),
                per_pixel_slope_m4f: fit(&resolution, |g| g.pixels as f64, false),
                per_primitive_slope_m3: fit(&primitives, |g| g.primitives as f64, true),
                per_primitive_slope_m4f: fit(&primitives, |g| g.primitives as f64, false),
                resolution,
                primitives,
            });
        }

        // Pruning: every shipped scene, planned vs every stage.
        let shipped = shipped_scenes()?;
        let shipped_r: Vec<Resolved> = shipped.iter().map(|p| load(p)).collect::<Result<_, _>>()?;
        // The same arithmetic as planned, nothing pruned.
        let all_stages = Variant {
            scalar: ScalarKind::Planned,
            over: Override::AllStages,
        };
        let pv = [Variant::PLANNED, all_stages];
        let per_board = runs_per_board(&cfg.boards, "pruning", &shipped, &pv, out, &pb)?;
        let ipp =
            |board: Board, scene: &str, v: &Variant| lookup(&per_board, board, scene, &v.name()).map(|r| r.0);
        for r in &shipped_r {
            let name = r.desc.name.clone();
            let scene = r.core_scene()?;
            let p = plan(&scene, &Budget::default()).options;
            let planned = Frame::<hilcam::scalar::I32F32>::build(&scene, &p).map_err(|e| format!("{e:?}"))?;
            let full = Frame::<hilcam::scalar::I32F32>::build(&scene, &p.with(Override::AllStages))
                .map_err(|e| format!("{e:?}"))?;
            let (a, b) = (planned.stages(), full.stages());
            let mut dropped = Vec::new();
            for s in b.names() {
                if !s.starts_with("rays:") && !a.names().contains(&s) {
                    dropped.push(s.to_string());
                }
            }
            if a.model != b.model {
                dropped.push(format!("{} instead of {}", a.model.name(), b.model.name()));
            }
            if a.distortion_lut != b.distortion_lut && a.distortion.is_some() {
                dropped.push(format!(
                    "distortion table of {} entries instead of {MAX_LUT}",
                    a.distortion_lut.unwrap_or(0)
                ));
            }
            let pa = crate::harness::collect(&planned)?;
            let pb_ = crate::harness::collect(&full)?;
            let max_between = pa
                .pixels
                .iter()
                .zip(&pb_.pixels)
                .map(|(x, y)| x.abs_diff(*y) as u32)
                .max()
                .unwrap_or(0);
            pruning.push(Pruning {
                dropped,
                planned_m3: ipp(Board::Lm3s6965evb, &name, &Variant::PLANNED),
                all_stages_m3: ipp(Board::Lm3s6965evb, &name, &all_stages),
                planned_m4f: ipp(Board::Mps2An386, &name, &Variant::PLANNED),
                all_stages_m4f: ipp(Board::Mps2An386, &name, &all_stages),
                planned_host_ns: host_ns_per_pixel(&Variant::PLANNED, r, cfg.repeats)?,
                all_stages_host_ns: host_ns_per_pixel(&all_stages, r, cfg.repeats)?,
                max_abs_lsb_between: max_between,
                scene: name,
            });
        }
        pb.inc(1);
    }
    pb.finish_and_clear();

    let report = Report {
        best_fixed_m3,
        m3_fixed_speedup_over_f32: speedups.0,
        m4f_fixed_speedup_over_f32: speedups.1,
        m3_fastest_fixed_speedup_over_f32: speedups.2,
        variants: rows,
        growth,
        pruning,
        recommendations,
    };
    let json = serde_json::to_vec_pretty(&report).map_err(|e| e.to_string())?;
    let md = markdown(&report);
    let png = crate::tradeoff_plot::plot(&report)?;
    outputs.write("tradeoff.json", &json)?;
    outputs.write("tradeoff.md", md.as_bytes())?;
    outputs.write("tradeoff.png", &png)?;
    outputs.commit()?;
    Ok(md)
}

/// The cheapest variant (by `cost` on the first sweep scene) whose smooth
/// pixels are within 1 LSB of the reference on every sweep scene (any
/// variant with `any_error`).
fn cheapest(
    rows: &[Row],
    scenes: &[Resolved],
    cost: impl Fn(&Row) -> Option<f64>,
    any_error: bool,
) -> Option<String> {
    let mut names: Vec<&str> = rows.iter().map(|r| r.variant.as_str()).collect();
    names.dedup();
    let first = scenes.first().map(|r| r.desc.name.as_str())?;
    names
        .into_iter()
        .filter(|n| *n != "f64-reference")
        .filter(|n| {
            rows.iter()
                .filter(|r| r.variant == *n)
                .all(|r| any_error || r.max_abs_lsb_smooth <= 1)
        })
        .filter_map(|n| {
            let row = rows.iter().find(|r| r.variant == n && r.scene == first)?;
            cost(row).map(|c| (n, c))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(n, _)| n.to_string())
}

/// The recommendations, given the cheapest fixed-point variant on the M3
/// within 1 LSB (`best_fixed`) and of all (`fastest_fixed`).
fn recommend(
    rows: &[Row],
    scenes: &[Resolved],
    best_fixed: Option<&str>,
    fastest_fixed: Option<&str>,
) -> Vec<Recommendation> {
    let first = scenes.first().map(|s| s.desc.name.as_str()).unwrap_or("");
    let row = |name: &str| rows.iter().find(|r| r.variant == name && r.scene == first);
    let fmt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.0}"));
    let mut out = Vec::new();
    let fixed_note = format!(
        "the cheapest fixed-point variant within 1 LSB is {} ({} instructions/pixel); the cheapest fixed-point \
         variant of all is {} ({} instructions/pixel, max {} LSB on smooth pixels)",
        best_fixed.unwrap_or("-"),
        fmt(best_fixed.and_then(row).and_then(|r| r.instructions_per_pixel_m3)),
        fastest_fixed.unwrap_or("-"),
        fmt(fastest_fixed.and_then(row).and_then(|r| r.instructions_per_pixel_m3)),
        fastest_fixed
            .map(|n| rows.iter().filter(|r| r.variant == n).map(|r| r.max_abs_lsb_smooth).max().unwrap_or(0))
            .unwrap_or(0),
    );
    if let Some(v) = cheapest(rows, scenes, |r| r.instructions_per_pixel_m3, false) {
        out.push(Recommendation {
            target: "M3".into(),
            reason: format!(
                "fewest M3 instructions per pixel ({}) of all variants within 1 LSB on smooth pixels on every sweep \
                 scene; {fixed_note}",
                fmt(row(&v).and_then(|r| r.instructions_per_pixel_m3))
            ),
            variant: v.clone(),
        });
        out.push(Recommendation {
            target: "M0".into(),
            reason:
                "not measured (no QEMU M0 board with a UART the firmware drives): the M3's choice, since the \
                     M0 has no FPU either; without a 32 × 32 → 64-bit multiply each of the fixed-point \
                     products takes several 32-bit multiplies there, and soft-float costs it more as well"
                    .into(),
            variant: v,
        });
    }
    if let Some(v) = cheapest(rows, scenes, |r| r.instructions_per_pixel_m4f, false) {
        let m4f = |n: &str| row(n).and_then(|r| r.instructions_per_pixel_m4f);
        let f32_best = cheapest(
            &rows
                .iter()
                .filter(|r| r.scalar == "f32")
                .cloned()
                .collect::<Vec<_>>(),
            scenes,
            |r| r.instructions_per_pixel_m4f,
            false,
        );
        let verdict = if row(&v).is_some_and(|r| r.scalar == "f32") {
            "hardware f32 wins there".to_string()
        } else {
            format!(
                "fixed point beats the FPU there: the best f32 variant, {}, needs {}",
                f32_best.as_deref().unwrap_or("-"),
                fmt(f32_best.as_deref().and_then(m4f))
            )
        };
        out.push(Recommendation {
            target: "M4F".into(),
            reason: format!(
                "fewest M4F instructions per pixel ({}) of all variants within 1 LSB on smooth pixels on every \
                 sweep scene; {verdict}",
                fmt(m4f(&v))
            ),
            variant: v,
        });
    }
    let host_fast = cheapest(rows, scenes, |r| Some(r.host_ns_per_pixel), false);
    let planned_ns = row(&Variant::PLANNED.name()).map(|r| r.host_ns_per_pixel);
    out.push(Recommendation {
        target: "host".into(),
        variant: Variant::PLANNED.name(),
        reason: format!(
            "the default: the planner's choice ({} ns/pixel on one core here; `host-sim render` renders lines on \
             every core), whose error it predicts and bounds (1/256 px, 1 LSB) and which the firmware renders \
             byte for byte; the fastest variant within 1 LSB on the sweep scenes is {} ({} ns/pixel)",
            fmt(planned_ns),
            host_fast.as_deref().unwrap_or("-"),
            fmt(host_fast.as_deref().and_then(row).map(|r| r.host_ns_per_pixel)),
        ),
    });
    out
}

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("-".into(), |v| format!("{v:.prec$}"))
}

/// `tradeoff.md`.
pub fn markdown(r: &Report) -> String {
    let mut s = String::new();
    s.push_str(
        "| scene | variant | max geom px | rms geom px | max LSB | max LSB smooth | rms LSB | PSNR dB | PSNR smooth dB | exact | edge differing | M3 instr/px | M4F instr/px | bit-exact M3/M4F | host ns/px | table B | flash M3 B |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let psnr = |p: Option<f64>| p.map_or("identical".into(), |p| format!("{p:.1}"));
    let be = |b: Option<bool>| b.map_or("-".into(), |b| if b { "yes".into() } else { "NO".to_string() });
    for v in &r.variants {
        s.push_str(&format!(
            "| {} | {} | {:.2e} | {:.2e} | {} | {} | {:.3} | {} | {} | {:.4} | {} | {} | {} | {}/{} | {:.0} | {} | {} |\n",
            v.scene,
            v.variant,
            v.max_geom_err_px,
            v.rms_geom_err_px,
            v.max_abs_lsb,
            v.max_abs_lsb_smooth,
            v.rms_lsb,
            psnr(v.psnr_db),
            psnr(v.psnr_db_smooth),
            v.exact_fraction,
            v.edge_pixels_differing,
            opt(v.instructions_per_pixel_m3, 0),
            opt(v.instructions_per_pixel_m4f, 0),
            be(v.bit_exact_m3),
            be(v.bit_exact_m4f),
            v.host_ns_per_pixel,
            v.table_bytes,
            v.flash_bytes_m3.map_or("-".into(), |f| f.to_string()),
        ));
    }
    s.push_str(&format!(
        "\nCheapest f32 variant's instructions per pixel / {}'s (the cheapest fixed-point variant within 1 LSB on \
         smooth pixels): M3 (soft-float) {}, M4F (hardware f32) {}. The same on the M3 for the cheapest fixed-point \
         variant whatever its error: {}.\n",
        r.best_fixed_m3.as_deref().unwrap_or("-"),
        opt(r.m3_fixed_speedup_over_f32, 2),
        opt(r.m4f_fixed_speedup_over_f32, 2),
        opt(r.m3_fastest_fixed_speedup_over_f32, 2)
    ));
    for g in &r.growth {
        s.push_str(&format!(
            "\n**Growth, {}** (least-squares slopes): {} instructions per extra pixel on the M3, {} on the M4F; {} \
             per extra primitive per 160x120 frame on the M3 ({} per pixel), {} on the M4F\n\n| scene | pixels | \
             primitives | M3 instructions | M4F instructions |\n|---|---|---|---|---|\n",
            g.variant,
            opt(g.per_pixel_slope_m3, 0),
            opt(g.per_pixel_slope_m4f, 0),
            opt(g.per_primitive_slope_m3, 0),
            opt(g.per_primitive_slope_m3.map(|v| v / 19200.0), 0),
            opt(g.per_primitive_slope_m4f, 0)
        ));
        for p in g.resolution.iter().chain(&g.primitives) {
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} |\n",
                p.scene,
                p.pixels,
                p.primitives,
                p.instructions_m3.map_or("-".into(), |v| v.to_string()),
                p.instructions_m4f.map_or("-".into(), |v| v.to_string())
            ));
        }
    }
    if !r.pruning.is_empty() {
        s.push_str(
            "\n**Pruning** (planned vs planned-all-stages: the same arithmetic, nothing pruned)\n\n| scene | dropped by the planner | M3 planned | M3 all stages | M4F planned | M4F all stages | host ns planned | host ns all | max LSB between |\n|---|---|---|---|---|---|---|---|---|\n",
        );
        for p in &r.pruning {
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {:.0} | {:.0} | {} |\n",
                p.scene,
                if p.dropped.is_empty() {
                    "nothing".into()
                } else {
                    p.dropped.join(", ")
                },
                opt(p.planned_m3, 0),
                opt(p.all_stages_m3, 0),
                opt(p.planned_m4f, 0),
                opt(p.all_stages_m4f, 0),
                p.planned_host_ns,
                p.all_stages_host_ns,
                p.max_abs_lsb_between
            ));
        }
    }
    s.push_str("\n**Recommendations**\n\n");
    for rec in &r.recommendations {
        s.push_str(&format!("- {}: `{}` — {}\n", rec.target, rec.variant, rec.reason));
    }
    s
}
