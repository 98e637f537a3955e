//! The sweep: renders every variant on every sweep scene on the host and
//! in QEMU, grows the resolution and the primitive count, measures the
//! planner's pruning, and writes the three files.

use super::report::{cheapest, markdown, recommend, Growth, GrowthPoint, Pruning, Report, Row};
use crate::harness::{compare, Collect, Metrics};
use crate::hil_cmd::{hil_variants, HilReport};
use crate::qemu::{repo_root, shipped_scenes, Board};
use crate::reference::render::RefScene;
use crate::scene_file::{load, Resolved};
use crate::variant::{FrameUser, ScalarKind, Variant, WithScalar};
use hilcam::geom::distortion::MAX_LUT;
use hilcam::planner::{plan, Budget, Plan};
use hilcam::render::{DistortionEval, Frame, FrameSink, Override};
use hilcam::num::scalar::Scalar;
use indicatif::{ProgressBar, ProgressStyle};
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
        // The samples-a-pixel axis (camera-model.md §7): the grid on every
        // pixel and with the adaptive rule.
        for (n, adaptive) in [(2, true), (4, true), (8, true), (4, false)] {
            variants.push(Variant {
                scalar: ScalarKind::I32F32,
                over: Override::Samples { n, adaptive },
            });
        }
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
impl FrameSink for Discard {
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
/// frame and rendering every line on one core, in the loops built for
/// this processor (`harness::render_carried`).
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
            let (w, h) = self.scene.camera().intrinsics().size();
            let mut line = vec![0u8; w as usize * self.scene.format().bytes_per_pixel()];
            let mut flags = vec![0u8; w as usize];
            for _ in 0..self.repeats {
                let t = Instant::now();
                let frame = Frame::<S>::build(self.scene, &self.opts).map_err(|e| format!("{e:?}"))?;
                crate::harness::render_carried(&frame, &mut line, &mut flags, &mut [], &mut Discard)
                    .map_err(|e| format!("{e:?}"))?;
                times.push(t.elapsed().as_nanos() as f64 / (w as f64 * h as f64));
            }
            Ok(median(times))
        }
    }
    let scene = r.core_scene()?;
    let opts = v.options(&plan(&scene, &Budget::default()));
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
    let mut rows = host_rows(cfg, &resolved, &pb)?;
    // Firmware: instructions, bit-exactness, flash.
    board_columns(cfg, &scenes, &mut rows, out, &pb)?;
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
    let (mut growth, mut pruning) = (Vec::new(), Vec::new());
    if cfg.growth_and_pruning {
        growth = growth_runs(cfg, &base, rec_m3.as_ref(), out, &pb)?;
        pruning = pruning_runs(cfg, out, &pb)?;
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
    let png = super::plot::plot(&report)?;
    outputs.write("tradeoff.json", &json)?;
    outputs.write("tradeoff.md", md.as_bytes())?;
    outputs.write("tradeoff.png", &png)?;
    outputs.commit()?;
    Ok(md)
}

/// Every scene's reference and variants rendered on the host: a row each,
/// with its fidelity and its time.
fn host_rows(cfg: &Config, resolved: &[Resolved], pb: &ProgressBar) -> Result<Vec<Row>, String> {
    let mut rows = Vec::new();
    for r in resolved {
        pb.set_message(format!("host, {}: reference", r.desc.name));
        let rs = RefScene::new(r);
        let reference = rs.render();
        let ns = reference_ns_per_pixel(r, cfg.repeats);
        rows.push(Row::new("f64-reference".into(), "f64", &r.desc.name, None, ns, 0));
        pb.inc(1);
        for v in &cfg.variants {
            pb.set_message(format!("host, {}: {}", r.desc.name, v.name()));
            // A variant with its own sample pattern is compared with the
            // reference sampled the same way.
            let own;
            let (rs_v, reference_v) = if v.pattern(r) == rs.pattern {
                (&rs, &reference)
            } else {
                let rv = rs.with_pattern(v.pattern(r));
                let f = rv.render();
                own = (rv, f);
                (&own.0, &own.1)
            };
            let (m, table_bytes) = v.render(
                r,
                &Budget::default(),
                Measure {
                    r,
                    rs: rs_v,
                    reference: reference_v,
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

    Ok(rows)
}

/// Each board's instructions, bit-exactness and flash, into `rows`.
fn board_columns(
    cfg: &Config,
    scenes: &[PathBuf],
    rows: &mut [Row],
    out: &Path,
    pb: &ProgressBar,
) -> Result<(), String> {
    for &board in &cfg.boards {
        let (runs, flash) = firmware_runs(board, scenes, &cfg.variants, out, pb)?;
        let m3 = board.core() == "M3";
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

    Ok(())
}

/// Instructions a pixel against resolution and against the primitives'
/// count, the planned variant's and the recommended one's.
fn growth_runs(
    cfg: &Config,
    base: &str,
    rec_m3: Option<&String>,
    out: &Path,
    pb: &ProgressBar,
) -> Result<Vec<Growth>, String> {
    let mut growth = Vec::new();
    let gdir = out.join("scenes");
    let mut res_scenes = Vec::new();
    for w in [80u32, 160, 320, 640] {
        let name = format!("standard-{w}x{}", w * 3 / 4);
        res_scenes.push(write_scene(&gdir, &name, &derive_scene(base, &name, w, 3)?)?);
    }
    let mut prim_scenes = Vec::new();
    for n in [1usize, 2, 4, 8, 16] {
        let name = format!("standard-{n}-primitives");
        prim_scenes.push(write_scene(&gdir, &name, &derive_scene(base, &name, 160, n)?)?);
    }
    let all: Vec<PathBuf> = res_scenes.iter().chain(&prim_scenes).cloned().collect();
    let all_r: Vec<Resolved> = all.iter().map(|p| load(p)).collect::<Result<_, _>>()?;
    let mut gvariants = vec![Variant::PLANNED];
    if let Some(rec) = rec_m3.and_then(|n| Variant::parse(n).ok()) {
        if rec != Variant::PLANNED {
            gvariants.push(rec);
        }
    }
    let per_board = runs_per_board(&cfg.boards, "growth", &all, &gvariants, out, pb)?;
    let ins = |board: Option<Board>, scene: &str, v: &str| lookup(&per_board, board?, scene, v).map(|r| r.1);
    for v in &gvariants {
        let point = |r: &Resolved| GrowthPoint {
            scene: r.desc.name.clone(),
            pixels: r.desc.camera.width as u64 * r.desc.camera.height as u64,
            primitives: r.primitives.len(),
            instructions_m3: ins(Board::by_core("M3"), &r.desc.name, &v.name()),
            instructions_m4f: ins(Board::by_core("M4F"), &r.desc.name, &v.name()),
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

    Ok(growth)
}

/// What the planner's pruning saves: every shipped scene planned against
/// every stage kept.
fn pruning_runs(cfg: &Config, out: &Path, pb: &ProgressBar) -> Result<Vec<Pruning>, String> {
    let mut pruning = Vec::new();
    // Pruning: every shipped scene, planned vs every stage.
    let shipped = shipped_scenes()?;
    let shipped_r: Vec<Resolved> = shipped.iter().map(|p| load(p)).collect::<Result<_, _>>()?;
    // The same arithmetic as planned, nothing pruned.
    let all_stages = Variant {
        scalar: ScalarKind::Planned,
        over: Override::AllStages,
    };
    let pv = [Variant::PLANNED, all_stages];
    let per_board = runs_per_board(&cfg.boards, "pruning", &shipped, &pv, out, pb)?;
    let ipp =
        |board: Option<Board>, scene: &str, v: &Variant| lookup(&per_board, board?, scene, &v.name()).map(|r| r.0);
    for r in &shipped_r {
        let name = r.desc.name.clone();
        let scene = r.core_scene()?;
        let p = plan(&scene, &Budget::default()).options;
        let planned = Frame::<hilcam::num::scalar::I32F32>::build(&scene, &p).map_err(|e| format!("{e:?}"))?;
        let full = Frame::<hilcam::num::scalar::I32F32>::build(&scene, &p.with(Override::AllStages))
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
        // Per channel value (DN), not per byte: a byte of an RGB565 or
        // Gray16 pixel is not a value.
        let max_between = pa
            .dn(scene.format())
            .iter()
            .zip(&pb_.dn(scene.format()))
            .flat_map(|(x, y)| x.iter().zip(y).map(|(a, b)| a.abs_diff(*b)))
            .max()
            .unwrap_or(0);
        pruning.push(Pruning {
            dropped,
            planned_m3: ipp(Board::by_core("M3"), &name, &Variant::PLANNED),
            all_stages_m3: ipp(Board::by_core("M3"), &name, &all_stages),
            planned_m4f: ipp(Board::by_core("M4F"), &name, &Variant::PLANNED),
            all_stages_m4f: ipp(Board::by_core("M4F"), &name, &all_stages),
            planned_host_ns: host_ns_per_pixel(&Variant::PLANNED, r, cfg.repeats)?,
            all_stages_host_ns: host_ns_per_pixel(&all_stages, r, cfg.repeats)?,
            max_abs_lsb_between: max_between,
            scene: name,
        });
    }
    Ok(pruning)
}
