//! `host-sim render`: renders a scene with the core and with the f64
//! reference, compares them, and writes `frame.png`, `reference.png`,
//! `diff.png` and `metrics.json`.

use crate::reference::render::{RefFrame, RefScene};
use crate::scene_file::Resolved;
use hilcam::planner::{self, Budget, Plan};
use hilcam::render::{Frame, LineSink, FLAG_OUTSIDE_FIELD};
use hilcam::scalar::Scalar;
use hilcam::scene::PixelFormat;
use serde::Serialize;
use std::path::Path;

/// A core frame collected line by line.
pub struct Collect {
    /// Bytes of every line, in order.
    pub pixels: Vec<u8>,
    /// Flags of every pixel.
    pub flags: Vec<u8>,
}

impl Collect {
    /// Channel values of every pixel.
    pub fn dn(&self, format: PixelFormat) -> Vec<[u32; 3]> {
        decode_all(format, &self.pixels)
    }
}

impl LineSink for Collect {
    type Error = std::convert::Infallible;
    fn line(&mut self, _y: u16, pixels: &[u8], flags: &[u8]) -> Result<(), Self::Error> {
        self.pixels.extend_from_slice(pixels);
        self.flags.extend_from_slice(flags);
        Ok(())
    }
}

/// One candidate the planner considered, as reported.
#[derive(Clone, Debug, Serialize)]
pub struct CandidateReport {
    /// `fast-poly`, `wide-lut64`, …
    pub name: String,
    /// Why the arithmetic's formats cannot hold the scene (null: they can).
    pub unfit: Option<String>,
    /// Predicted pixel → undistorted error, px.
    pub geom_err_px: f64,
    /// Predicted largest |core − reference| before rounding, LSB.
    pub lsb: f64,
    /// Predicted cost, M3 instructions a pixel (the fitted cost model).
    pub m3_instructions_per_pixel: f64,
    /// Fits and within the budget.
    pub meets_budget: bool,
}

/// The planner's choice, as reported.
#[derive(Clone, Debug, Serialize)]
pub struct PlanReport {
    /// The arithmetic the core rendered with (`fast`, `wide`).
    pub arithmetic: String,
    /// The candidate the planner chose (the frame may be a variant of it).
    pub chosen: String,
    /// Why it was chosen.
    pub why: String,
    /// Every candidate considered.
    pub candidates: Vec<CandidateReport>,
    /// Predicted cost of the chosen candidate, M3 instructions a pixel.
    pub predicted_m3_instructions_per_pixel: f64,
    /// Ray model the core rendered with.
    pub model: String,
    /// Mean depth if weak perspective was chosen, metres.
    pub mean_depth_m: Option<f64>,
    /// Distortion table entries (0: no distortion stage).
    pub lut_entries: usize,
    /// The entries' format, chosen for the camera (e.g. "I4F28").
    pub lut_format: Option<String>,
    /// Predicted pixel → undistorted error, px.
    pub predicted_geom_err_px: f64,
    /// §2 weak-perspective bound over the scene, px (null: unbounded scene).
    pub weak_perspective_err_px: Option<f64>,
    /// Predicted largest |core − reference| before rounding, LSB.
    pub predicted_lsb: f64,
    /// All predictions within the budget.
    pub meets_budget: bool,
    /// The budget.
    pub budget_geom_px: f64,
    /// The budget.
    pub budget_lsb: f64,
}

/// `metrics.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Metrics {
    /// Scene name.
    pub scene: String,
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// Output format.
    pub format: String,
    /// Significant bits per channel (largest channel).
    pub bits: u32,
    /// Stages the core ran.
    pub stages: Vec<String>,
    /// The planner's choice.
    pub plan: PlanReport,
    /// Distortion table bytes.
    pub table_bytes: usize,
    /// Largest |core − reference| over all pixels and channels, LSB.
    pub max_abs_lsb: u32,
    /// RMS difference over all samples, LSB.
    pub rms_lsb: f64,
    /// Fraction of pixels identical in every channel.
    pub exact_fraction: f64,
    /// PSNR over all pixels, dB (per-channel full scale); null when identical.
    pub psnr_db: Option<f64>,
    /// Largest distance between the core's and the reference's pixel →
    /// undistorted image point, over pixels both place in the lens field, px.
    pub max_geom_err_px: f64,
    /// RMS of that distance, px.
    pub rms_geom_err_px: f64,
    /// Pixels a 1/256 px move of whose centre changes what the reference ray
    /// hits (primitive, texture cell) or its in-field flag.
    pub edge_pixels: usize,
    /// Edge pixels whose values differ.
    pub edge_pixels_differing: usize,
    /// `edge_pixels_differing` as a fraction of all pixels.
    pub edge_pixels_differing_fraction: f64,
    /// Largest |core − reference| over smooth (non-edge) pixels, LSB.
    pub max_abs_lsb_smooth: u32,
    /// RMS over smooth pixels, LSB.
    pub rms_lsb_smooth: f64,
    /// PSNR over smooth pixels, dB; null when identical.
    pub psnr_db_smooth: Option<f64>,
    /// Fraction of smooth pixels identical.
    pub exact_fraction_smooth: f64,
    /// Pixels outside the lens field (reference).
    pub outside_field_pixels: usize,
    /// Pixels whose in-field flag differs between core and reference.
    pub field_flags_differing: usize,
}

/// Everything one render produced.
pub struct RenderOutput {
    /// Core frame bytes.
    pub core: Collect,
    /// Core values per channel.
    pub core_dn: Vec<[u32; 3]>,
    /// Reference frame.
    pub reference: RefFrame,
    /// Metrics.
    pub metrics: Metrics,
    /// The plan.
    pub plan: Plan,
    /// Output format.
    pub format: PixelFormat,
}

/// Decodes one pixel's bytes into channel values.
pub fn decode(format: PixelFormat, b: &[u8]) -> [u32; 3] {
    match format {
        PixelFormat::Gray8 => [b[0] as u32, 0, 0],
        PixelFormat::Gray16 { .. } => [u16::from_le_bytes([b[0], b[1]]) as u32, 0, 0],
        PixelFormat::Rgb565 => {
            let v = u16::from_le_bytes([b[0], b[1]]) as u32;
            [v >> 11, (v >> 5) & 63, v & 31]
        }
    }
}

/// Decodes frame bytes into channel values, a pixel at a time.
pub fn decode_all(format: PixelFormat, bytes: &[u8]) -> Vec<[u32; 3]> {
    bytes
        .chunks_exact(format.bytes_per_pixel())
        .map(|b| decode(format, b))
        .collect()
}

/// The core's scene, its plan for `budget`, the prepared frame, and the
/// frame rendered line by line (bytes and flags).
pub fn core_render(
    r: &Resolved,
    budget: &Budget,
) -> Result<(hilcam::scene::Scene, Plan, Frame, Collect), String> {
    core_render_variant(r, budget, &crate::variant::Variant::PLANNED)
}

/// [`core_render`] with per-pixel values in `S` and the options of
/// `variant`.
pub fn core_render_variant<S: Scalar>(
    r: &Resolved,
    budget: &Budget,
    variant: &crate::variant::Variant,
) -> Result<(hilcam::scene::Scene, Plan, Frame<S>, Collect), String> {
    let scene = r.core_scene()?;
    let plan = planner::plan(&scene, budget);
    let frame = Frame::<S>::build(&scene, &variant.options(plan.options))
        .map_err(|e| format!("{}: cannot render: {e:?}", r.desc.name))?;
    let core = collect(&frame).map_err(|e| format!("{}: {e}", r.desc.name))?;
    Ok((scene, plan, frame, core))
}

/// Renders a prepared frame into memory, its lines in parallel on every
/// core (rayon): each line is rendered straight into its place, so the
/// bytes are those of [`collect_serial`] (tested).
pub fn collect<S: Scalar>(frame: &Frame<S>) -> Result<Collect, String> {
    use rayon::prelude::*;
    let (w, h) = frame.size();
    let lb = frame.line_bytes();
    let mut core = Collect {
        pixels: vec![0u8; lb * h as usize],
        flags: vec![0u8; w as usize * h as usize],
    };
    if lb == 0 || w == 0 {
        return Ok(core);
    }
    core.pixels
        .par_chunks_mut(lb)
        .zip(core.flags.par_chunks_mut(w as usize))
        .enumerate()
        .try_for_each(|(j, (p, f))| frame.render_line(j as u16, p, f))
        .map_err(|e| format!("render failed: {e:?}"))?;
    Ok(core)
}

/// Renders a prepared frame into memory a line at a time through the
/// core's [`LineSink`] (one core).
pub fn collect_serial<S: Scalar>(frame: &Frame<S>) -> Result<Collect, String> {
    let (w, h) = frame.size();
    let mut line = vec![0u8; frame.line_bytes()];
    let mut flags = vec![0u8; w as usize];
    let mut core = Collect {
        pixels: Vec::with_capacity(frame.line_bytes() * h as usize),
        flags: Vec::with_capacity(w as usize * h as usize),
    };
    frame
        .render(&mut line, &mut flags, &mut core)
        .map_err(|e| format!("render failed: {e:?}"))?;
    Ok(core)
}

/// Renders with both, and compares.
pub fn render(r: &Resolved, budget: &Budget) -> Result<RenderOutput, String> {
    let (scene, plan, frame, core) = core_render(r, budget)?;
    let rs = RefScene::new(r);
    let reference = rs.render();
    let format = scene.format;
    let core_dn = core.dn(format);
    let metrics = compare(r, &rs, &reference, &plan, budget, &frame, &core);
    Ok(RenderOutput {
        core,
        core_dn,
        reference,
        metrics,
        plan,
        format,
    })
}

/// The render metrics of a core frame against the reference frame of the
/// same scene.
// `k` indexes four parallel per-pixel arrays.
#[allow(clippy::needless_range_loop)]
pub fn compare<S: Scalar>(
    r: &Resolved,
    rs: &RefScene,
    reference: &RefFrame,
    plan: &Plan,
    budget: &Budget,
    frame: &Frame<S>,
    core: &Collect,
) -> Metrics {
    let (w, h) = frame.size();
    let (w, h) = (w as usize, h as usize);
    let format = r.format;
    let core_dn = core.dn(format);

    // Geometry: the core's pixel → undistorted mapping against the reference.
    let (fx, fy) = (rs.sensor.f / rs.sensor.sx, rs.sensor.f / rs.sensor.sy);
    let mut max_geom: f64 = 0.0;
    let (mut sq_geom, mut n_geom) = (0.0, 0usize);
    for j in 0..h {
        for i in 0..w {
            if let (Some((cx, cy)), Some((rx, ry))) = (
                frame.undistorted(i as u16, j as u16),
                reference.undistorted[j * w + i],
            ) {
                let e = ((cx.to_f64() - rx) * fx).hypot((cy.to_f64() - ry) * fy);
                max_geom = max_geom.max(e);
                sq_geom += e * e;
                n_geom += 1;
            }
        }
    }
    let channels = format.channels();
    let dn_max: Vec<f64> = (0..channels).map(|c| format.dn_max(c) as f64).collect();
    let (mut max_all, mut max_smooth) = (0u32, 0u32);
    let (mut sq_all, mut sq_smooth, mut nsq_all, mut nsq_smooth) = (0.0, 0.0, 0.0, 0.0);
    let (mut exact, mut exact_smooth, mut smooth, mut edges, mut edges_diff) =
        (0usize, 0usize, 0usize, 0usize, 0usize);
    let mut flags_diff = 0;
    for k in 0..w * h {
        let (c, rf) = (core_dn[k], reference.dn[k]);
        let mut same = true;
        let mut pmax = 0;
        let (mut psq, mut pnsq) = (0.0, 0.0);
        for ch in 0..channels {
            let d = c[ch].abs_diff(rf[ch]);
            same &= d == 0;
            pmax = pmax.max(d);
            psq += (d as f64).powi(2);
            pnsq += (d as f64 / dn_max[ch]).powi(2);
        }
        let core_in = core.flags[k] & FLAG_OUTSIDE_FIELD == 0;
        if core_in != reference.in_field[k] {
            flags_diff += 1;
        }
        max_all = max_all.max(pmax);
        sq_all += psq;
        nsq_all += pnsq;
        exact += same as usize;
        if reference.edge[k] {
            edges += 1;
            edges_diff += (!same) as usize;
        } else {
            smooth += 1;
            max_smooth = max_smooth.max(pmax);
            sq_smooth += psq;
            nsq_smooth += pnsq;
            exact_smooth += same as usize;
        }
    }
    let n_all = (w * h * channels) as f64;
    let n_smooth = (smooth * channels).max(1) as f64;
    let psnr = |nsq: f64, n: f64| (nsq > 0.0).then(|| 10.0 * (n / nsq).log10());
    let bits = (0..channels)
        .map(|c| 32 - format.dn_max(c).leading_zeros())
        .max()
        .unwrap_or(8);
    let stages = frame.stages();
    Metrics {
        scene: r.desc.name.clone(),
        width: w,
        height: h,
        format: format.name().into(),
        bits,
        stages: stages.names().iter().map(|s| s.to_string()).collect(),
        plan: PlanReport {
            arithmetic: stages.arithmetic.name().into(),
            chosen: plan
                .candidates
                .get(plan.chosen)
                .map_or_else(String::new, |c| c.name().to_string()),
            why: plan_why(plan, budget),
            candidates: plan
                .candidates
                .iter()
                .map(|c| CandidateReport {
                    name: c.name().to_string(),
                    unfit: c.fits.err().map(|u| u.reason().to_string()),
                    geom_err_px: c.geom_err_px,
                    lsb: c.lsb,
                    m3_instructions_per_pixel: c.m3_instructions_per_pixel,
                    meets_budget: c.meets(budget),
                })
                .collect(),
            predicted_m3_instructions_per_pixel: plan.predicted_m3_instructions_per_pixel,
            model: stages.model.name().trim_start_matches("rays:").into(),
            mean_depth_m: match stages.model {
                hilcam::render::RenderModel::WeakPerspective { mean_depth } => Some(mean_depth.to_num()),
                _ => None,
            },
            lut_entries: stages.distortion_lut.unwrap_or(0),
            lut_format: frame.table_frac_bits().map(|f| format!("I{}F{}", 32 - f, f)),
            predicted_geom_err_px: plan.predicted_geom_err_px,
            weak_perspective_err_px: plan.weak_perspective_err_px,
            predicted_lsb: plan.predicted_lsb,
            meets_budget: plan.meets_budget,
            budget_geom_px: budget.max_geom_err_px,
            budget_lsb: budget.max_lsb,
        },
        table_bytes: frame.table_bytes(),
        max_abs_lsb: max_all,
        rms_lsb: (sq_all / n_all).sqrt(),
        exact_fraction: exact as f64 / (w * h) as f64,
        psnr_db: psnr(nsq_all, n_all),
        max_geom_err_px: max_geom,
        rms_geom_err_px: (sq_geom / n_geom.max(1) as f64).sqrt(),
        edge_pixels: edges,
        edge_pixels_differing: edges_diff,
        edge_pixels_differing_fraction: edges_diff as f64 / (w * h) as f64,
        max_abs_lsb_smooth: max_smooth,
        rms_lsb_smooth: (sq_smooth / n_smooth).sqrt(),
        psnr_db_smooth: psnr(nsq_smooth, n_smooth),
        exact_fraction_smooth: exact_smooth as f64 / smooth.max(1) as f64,
        outside_field_pixels: reference.in_field.iter().filter(|f| !**f).count(),
        field_flags_differing: flags_diff,
    }
}

/// Encodes frame bytes (as the core produces them) as a PNG.
pub fn encode_png(format: PixelFormat, w: usize, h: usize, bytes: &[u8]) -> Result<Vec<u8>, String> {
    let bpp = format.bytes_per_pixel();
    if bytes.len() != w * h * bpp {
        return Err(format!(
            "frame of {} bytes is not {w}x{h} {}",
            bytes.len(),
            format.name()
        ));
    }
    let dn = decode_all(format, bytes);
    png(format, w, h, &dn)
}

/// Encodes channel values as a PNG (8-bit gray, 16-bit gray scaled to the
/// full 16 bits, or 8-bit RGB).
fn png(format: PixelFormat, w: usize, h: usize, dn: &[[u32; 3]]) -> Result<Vec<u8>, String> {
    let mut out = std::io::Cursor::new(Vec::new());
    let (w32, h32) = (w as u32, h as u32);
    let res = match format {
        PixelFormat::Gray8 => {
            let data: Vec<u8> = dn.iter().map(|p| p[0] as u8).collect();
            image::GrayImage::from_raw(w32, h32, data).map(|i| i.write_to(&mut out, image::ImageFormat::Png))
        }
        PixelFormat::Gray16 { bits } => {
            let data: Vec<u16> = dn.iter().map(|p| (p[0] << (16 - bits as u32)) as u16).collect();
            image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(w32, h32, data)
                .map(|i| i.write_to(&mut out, image::ImageFormat::Png))
        }
        PixelFormat::Rgb565 => {
            let data: Vec<u8> = dn
                .iter()
                .flat_map(|p| {
                    [
                        (p[0] * 255 / 31) as u8,
                        (p[1] * 255 / 63) as u8,
                        (p[2] * 255 / 31) as u8,
                    ]
                })
                .collect();
            image::RgbImage::from_raw(w32, h32, data).map(|i| i.write_to(&mut out, image::ImageFormat::Png))
        }
    };
    match res {
        Some(Ok(())) => Ok(out.into_inner()),
        Some(Err(e)) => Err(format!("PNG encoding failed: {e}")),
        None => Err("PNG encoding failed: buffer size".into()),
    }
}

/// The diff heat map: black where core and reference agree; 1 LSB dark red,
/// 2 red, 4 yellow, 8 or more white; identical edge pixels dark blue.
fn diff_png(o: &RenderOutput) -> Result<Vec<u8>, String> {
    let (w, h) = (o.metrics.width, o.metrics.height);
    let mut data = Vec::with_capacity(w * h * 3);
    for k in 0..w * h {
        let d = (0..o.format.channels())
            .map(|c| o.core_dn[k][c].abs_diff(o.reference.dn[k][c]))
            .max()
            .unwrap_or(0);
        let rgb = match d {
            0 if o.reference.edge[k] => [0, 0, 90],
            0 => [0, 0, 0],
            1 => [140, 0, 0],
            2..=3 => [255, 0, 0],
            4..=7 => [255, 255, 0],
            _ => [255, 255, 255],
        };
        data.extend_from_slice(&rgb);
    }
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbImage::from_raw(w as u32, h as u32, data)
        .ok_or("diff: buffer size")?
        .write_to(&mut out, image::ImageFormat::Png)
        .map_err(|e| format!("PNG encoding failed: {e}"))?;
    Ok(out.into_inner())
}

/// Writes the four files into `dir` (created if needed). Everything is
/// encoded before the first file is written.
pub fn write(dir: &Path, o: &RenderOutput) -> Result<(), String> {
    let (w, h) = (o.metrics.width, o.metrics.height);
    let files = [
        ("frame.png", png(o.format, w, h, &o.core_dn)?),
        ("reference.png", png(o.format, w, h, &o.reference.dn)?),
        ("diff.png", diff_png(o)?),
        (
            "metrics.json",
            serde_json::to_vec_pretty(&o.metrics).map_err(|e| format!("metrics: {e}"))?,
        ),
    ];
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for (name, bytes) in files {
        let p = dir.join(name);
        std::fs::write(&p, bytes).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    Ok(())
}

/// Why the planner chose what it chose, in a sentence.
pub fn plan_why(plan: &Plan, budget: &Budget) -> String {
    let Some(c) = plan.candidates.get(plan.chosen) else {
        return "no candidate".into();
    };
    let within = plan.candidates.iter().filter(|c| c.meets(budget)).count();
    if c.meets(budget) {
        format!(
            "{} is the cheapest of {within} candidate(s) within the budget ({:.0} predicted M3 \
             instructions/pixel; {:.2e} px, {:.3} LSB before rounding)",
            c.name(),
            c.m3_instructions_per_pixel,
            c.geom_err_px,
            c.lsb
        )
    } else {
        format!(
            "no candidate meets the budget ({} px, {} LSB): {} is the most accurate that fits \
             ({:.2e} px, {:.3} LSB before rounding)",
            budget.max_geom_err_px,
            budget.max_lsb,
            c.name(),
            c.geom_err_px,
            c.lsb
        )
    }
}

/// The plan as text: the choice, why, and every candidate.
pub fn plan_text(p: &PlanReport) -> String {
    let mut s = format!("  plan: {} — {}\n", p.chosen, p.why);
    for c in &p.candidates {
        s.push_str(&format!(
            "    {:<18} geom {:.2e} px  {:>9.4} LSB  {:>7.0} M3 instr/px  {}\n",
            c.name,
            c.geom_err_px,
            c.lsb,
            c.m3_instructions_per_pixel,
            match (&c.unfit, c.meets_budget) {
                (Some(why), _) => format!("unfit: {why}"),
                (None, true) => "within budget".to_string(),
                (None, false) => "over budget".to_string(),
            }
        ));
    }
    s
}

/// A one-line summary.
pub fn summary(m: &Metrics) -> String {
    let psnr = |p: Option<f64>| p.map_or("identical".to_string(), |p| format!("{p:.1} dB"));
    format!(
        "{:<18} {}x{} {:<7} {:<4} model={:<16} lut={:<4} geom={:.2e}px max_lsb={} smooth: max_lsb={} psnr={} \
         exact={:.4} edges={} differing={} ({:.3}%)",
        m.scene,
        m.width,
        m.height,
        m.format,
        m.plan.arithmetic,
        m.plan.model,
        m.plan.lut_entries,
        m.max_geom_err_px,
        m.max_abs_lsb,
        m.max_abs_lsb_smooth,
        psnr(m.psnr_db_smooth),
        m.exact_fraction,
        m.edge_pixels,
        m.edge_pixels_differing,
        100.0 * m.edge_pixels_differing_fraction
    )
}
