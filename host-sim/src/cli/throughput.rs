//! `host-sim throughput`.

/// Host throughput of the default render (plan, prepare and render
/// every frame, lines in parallel on every core, as `render` does),
/// and on one core: frames/s and ns/pixel (medians over the frames),
/// with the core's loops built for the processor's x86-64 level
/// (HILCAM_X86_LEVEL=1 or 3 caps it: the baseline build, x86-64-v3).
#[derive(clap::Args)]
pub struct Args {
    /// Scene file.
    #[arg(long)]
    scene: std::path::PathBuf,
    /// Frames to time (1 to 10 000).
    #[arg(long, default_value_t = 20)]
    frames: u32,
    /// Also write throughput.json into this directory.
    #[arg(long)]
    out: Option<std::path::PathBuf>,
}

/// `throughput.json`.
#[derive(serde::Serialize)]
struct Report {
    scene: String,
    width: u16,
    height: u16,
    plan: String,
    arithmetic: String,
    loops: String,
    frames: u32,
    threads: usize,
    frames_per_second: f64,
    ns_per_pixel: f64,
    frames_per_second_one_thread: f64,
    ns_per_pixel_one_thread: f64,
}

/// The largest frame `throughput` times, pixel bytes (its memory is about
/// twice that: the pixels and their flags).
const MAX_FRAME_BYTES: u64 = 64 << 20;

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args { scene, frames, out } = args;
    if !(1..=10_000).contains(&frames) {
        return Err("--frames: must be 1 to 10000".into());
    }
    let r = host_sim::scene_file::load(&scene)?;
    // Frames are rendered whole into memory (as a camera's frame buffer):
    // capped, so that memory is bounded whatever the scene asks.
    let c = &r.desc.camera;
    let bytes = u64::from(c.width) * u64::from(c.height) * r.format.bytes_per_pixel() as u64;
    if bytes > MAX_FRAME_BYTES {
        return Err(format!(
            "{}: camera.height: a {}x{} {} frame is {bytes} B of pixels; throughput times frames of at most {MAX_FRAME_BYTES} B \
             (e.g. 8192x8192 gray8)",
            scene.display(),
            c.width,
            c.height,
            r.format.name()
        ));
    }
    let s = r.core_scene()?;
    let budget = hilcam::planner::Budget::default();
    // A stream of frames: each planned, prepared and rendered into
    // the same buffers (`collect_into`).
    let time = |parallel: bool| -> Result<(f64, String), String> {
        let mut secs = Vec::new();
        let mut arith = String::new();
        let mut c = host_sim::harness::Collect::default();
        for _ in 0..frames {
            let t = std::time::Instant::now();
            let p = hilcam::planner::plan(&s, &budget);
            let f = hilcam::render::Frame::new(&s, &p.options)
                .map_err(|e| format!("{}: cannot render: {e} ({e:?})", scene.display()))?;
            if parallel {
                host_sim::harness::collect_into(&f, &mut c)?
            } else {
                host_sim::harness::collect_serial_into(&f, &mut c)?
            };
            secs.push(t.elapsed().as_secs_f64());
            std::hint::black_box(&c);
            arith = f.stages().arithmetic.name().to_string();
        }
        secs.sort_by(f64::total_cmp);
        Ok((secs[secs.len() / 2], arith))
    };
    let (w, h) = s.camera().intrinsics().size();
    let px = w as f64 * h as f64;
    // The plan, named: a scene scaled up may plan a grid or the
    // aperture (a blur circle is more pixels), a far slower loop.
    let p0 = hilcam::planner::plan(&s, &budget);
    let o = &p0.options;
    let mut plan = p0
        .candidates
        .get(p0.chosen)
        .map_or_else(|| "?".to_string(), |c| c.name().to_string());
    if o.samples > 1 {
        let rule = if o.adaptive { " adaptive" } else { "" };
        plan.push_str(&format!(", {n}x{n} grid{rule}", n = o.samples));
    }
    if o.aperture > 0 {
        plan.push_str(&format!(", {} aperture points", o.aperture));
    }
    let (par, arith) = time(true)?;
    let loops = host_sim::harness::x86_level().name();
    let (one, _) = time(false)?;
    if let Some(out) = out {
        let report = Report {
            scene: r.desc.name.clone(),
            width: w,
            height: h,
            plan: plan.clone(),
            arithmetic: arith.clone(),
            loops: loops.to_string(),
            frames,
            threads: rayon::current_num_threads(),
            frames_per_second: 1.0 / par,
            ns_per_pixel: par / px * 1e9,
            frames_per_second_one_thread: 1.0 / one,
            ns_per_pixel_one_thread: one / px * 1e9,
        };
        let mut o = host_sim::output::Outputs::prepare(&out)?;
        o.write(
            "throughput.json",
            &serde_json::to_vec_pretty(&report).map_err(|e| e.to_string())?,
        )?;
        o.commit()?;
    }
    Ok(format!(
        "{} {w}x{h} (plan {plan}; {arith} arithmetic, {loops} loops): {:.1} frames/s, {:.1} ns/pixel on {} \
         threads; {:.1} frames/s, {:.1} ns/pixel on one (median of {frames} frames; plan + prepare + render)",
        r.desc.name,
        1.0 / par,
        par / px * 1e9,
        rayon::current_num_threads(),
        1.0 / one,
        one / px * 1e9
    ))
}
