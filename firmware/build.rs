//! Writes the board's memory map and UART constants (from boards.toml,
//! `HILCAM_BOARD`), and encodes every scene in ../scenes as
//! scene data (`hilcam::scene::data`, postcard) — the blobs the firmware
//! holds in flash and builds with the core at run time, from the same f64
//! values host-sim builds its scenes from, so the firmware renders exactly
//! what the host renders. No code is generated per scene.

use host_sim::scene_file::load;
use host_sim::variant::Variant;
use std::fmt::Write as _;
use std::path::PathBuf;

/// The most RAM the sampled loop's corner-key carry may take, bytes.
const CORNER_KEYS_MAX_BYTES: usize = 4096;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR"));
    // The board (firmware/boards.toml): its memory map for the linker, its
    // UART's kind (a cfg) and base, and its SysTick period.
    println!("cargo:rerun-if-env-changed=HILCAM_BOARD");
    println!("cargo:rerun-if-changed=boards.toml");
    println!("cargo::rustc-check-cfg=cfg(hilcam_uart, values(\"pl011\", \"cmsdk\", \"nrf51\"))");
    let name = std::env::var("HILCAM_BOARD").unwrap_or_else(|_| "lm3s6965evb".into());
    let board = host_sim::boards::Board::parse(&name).unwrap_or_else(|e| panic!("HILCAM_BOARD: {e}"));
    let spec = board.spec();
    if std::env::var("TARGET").is_ok_and(|t| t != spec.target) {
        panic!(
            "HILCAM_BOARD={name} is built for {}, not {}",
            spec.target,
            std::env::var("TARGET").unwrap_or_default()
        );
    }
    std::fs::write(out.join("memory.x"), host_sim::boards::memory_x(spec)).expect("memory.x");
    println!("cargo::rustc-cfg=hilcam_uart=\"{}\"", spec.uart.name());
    std::fs::write(
        out.join("board.rs"),
        format!(
            "/// UART0's base address ({name}).\nconst UART_BASE: usize = {:#x};\n/// SysTick's period, ps.\npub const SYSTICK_PS: u64 = {};\n\
             /// The board this firmware is built for, read from the ELF by the host\n\
             /// (`host_sim::qemu::check_elf`) before QEMU runs it.\n\
             #[used]\n#[unsafe(no_mangle)]\npub static HILCAM_BOARD: [u8; {}] = *b\"{name}\";\n",
            spec.uart_base,
            board.systick_ps(),
            name.len()
        ),
    )
    .expect("board.rs");
    // cortex-m-rt's "device" feature includes device.x for the interrupt
    // handlers' weak aliases: the firmware enables none (main.rs).
    std::fs::write(out.join("device.x"), "/* no device interrupt handlers */\n").expect("device.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../scenes");

    // HILCAM_SCENES: newline-separated scene files (host-sim hil --scene);
    // otherwise every scene in ../scenes the board holds, sorted by file
    // name.
    println!("cargo:rerun-if-env-changed=HILCAM_SCENES");
    let paths: Vec<PathBuf> = match std::env::var("HILCAM_SCENES") {
        Ok(list) if !list.trim().is_empty() => list.lines().map(PathBuf::from).collect(),
        _ => {
            let mut v: Vec<PathBuf> = std::fs::read_dir("../scenes")
                .expect("../scenes")
                .map(|e| e.expect("entry").path())
                .filter(|p| p.extension().is_some_and(|e| e == "toml"))
                .collect();
            v.sort();
            // (Less those the board leaves out: boards.toml skip_scenes.)
            board.held(v)
        }
    };
    let mut code = String::new();
    let mut names = Vec::new();
    let mut resolved = Vec::new();
    let mut blobs = Vec::new();
    let (mut max_w, mut max_line) = (0usize, 0usize);
    // The capacities of the core this firmware links (checked below).
    const CAPACITIES: [&str; 3] = [
        "HILCAM_MAX_MATERIALS",
        "HILCAM_MAX_PRIMITIVES",
        "HILCAM_MAX_LIGHTS",
    ];
    for var in CAPACITIES {
        println!("cargo:rerun-if-env-changed={var}");
    }
    for (i, p) in paths.iter().enumerate() {
        println!("cargo:rerun-if-changed={}", p.display());
        let r = load(p).unwrap_or_else(|e| panic!("{e}"));
        // More materials, primitives or lights than the core this firmware
        // links holds (its HILCAM_MAX_*, which host-sim sets from the
        // scenes; the host's core, which loaded the scene, holds the most)
        // is refused, naming the list and the limit.
        let counts = [
            ("materials", r.desc.materials.len()),
            ("primitives", r.desc.primitives.len()),
            ("lights", r.desc.lights.len()),
        ];
        for (var, (list, n)) in CAPACITIES.into_iter().zip(counts) {
            let Ok(v) = std::env::var(var) else { continue };
            let most: usize = v.parse().unwrap_or_else(|_| panic!("{var}={v}: not a number"));
            assert!(
                n <= most,
                "{}: {n} {list}, over the {most} this firmware holds ({var})",
                p.display()
            );
        }
        let c = &r.desc.camera;
        names.push(r.desc.name.clone());
        max_w = max_w.max(c.width as usize);
        max_line = max_line.max(c.width as usize * r.format.bytes_per_pixel());
        let bytes = r.scene_bytes().unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        let file = format!("scene_{i}.bin");
        std::fs::write(out.join(&file), bytes).expect("scene blob");
        blobs.push(format!("include_bytes!(concat!(env!(\"OUT_DIR\"), \"/{file}\"))"));
        resolved.push(r);
    }
    let _ = writeln!(
        code,
        "/// The scenes, encoded (`hilcam::scene::data`), in scene-id order.\npub static BLOBS: [&[u8]; {}] = [{}];",
        blobs.len(),
        blobs.join(", ")
    );
    let _ = writeln!(
        code,
        "/// Scene names, in scene-id order (the sorted file names of scenes/)."
    );
    let _ = writeln!(code, "pub const NAMES: [&str; {}] = {:?};", names.len(), names);
    let _ = writeln!(
        code,
        "/// Widest sensor, pixels.\npub const MAX_WIDTH: usize = {max_w};"
    );
    let _ = writeln!(
        code,
        "/// Longest line, bytes.\npub const MAX_LINE_BYTES: usize = {max_line};"
    );
    // HILCAM_VARIANTS: variant names (host-sim tradeoff), separated by commas
    // or newlines; otherwise the planned renderer only.
    println!("cargo:rerun-if-env-changed=HILCAM_VARIANTS");
    let variants: Vec<Variant> = match std::env::var("HILCAM_VARIANTS") {
        Ok(list) if !list.trim().is_empty() => list
            .split([',', '\n'])
            .map(str::trim)
            .filter(|v| !v.is_empty())
            .map(|v| Variant::parse(v).unwrap_or_else(|e| panic!("HILCAM_VARIANTS: {e}")))
            .collect(),
        _ => vec![Variant::PLANNED],
    };
    // The distortion table the frame holds: the most entries any scene's
    // variant renders with (0: none), so that the plans made here with the
    // default budget fit it. And the line loops those variants render
    // with: only those are compiled into the firmware.
    let mut table = 0usize;
    let mut lines = std::collections::BTreeSet::new();
    // And the corner keys the sampled fast loop carries from line to line
    // (`hilcam::render::sensor::sampling::Corners`): a sensor's width plus one, for the
    // widest scene rendered with the adaptive rule on that loop (0: none).
    let mut corner_keys = 0usize;
    // The wide loops' stages those frames use (sampling, aperture rays,
    // the specular lobe): the others are left out of the wide loop too.
    let (mut wide_sampled, mut wide_aperture, mut wide_specular) = (false, false, false);
    // And the fast loops' specular lobe, for one channel and for RGB565.
    let (mut gray_specular, mut rgb_specular) = (false, false);
    for r in &resolved {
        for v in &variants {
            let budget = hilcam::planner::Budget::default();
            if let Ok((_, _, f)) =
                host_sim::harness::prepare::<hilcam::num::scalar::I32F32>(r, &budget, |p| v.options(p))
            {
                table = table.max(f.stages().distortion_lut.unwrap_or(0));
                lines.insert(f.line_loop());
                let st = f.stages();
                // The fast sampled loop (the aperture loop takes pixel
                // centres only) with the adaptive rule.
                let fast = st.arithmetic == hilcam::render::Arithmetic::Fast && st.aperture == 0;
                if fast && st.samples > 1 && st.adaptive {
                    corner_keys = corner_keys.max(f.size().0 as usize + 1);
                }
                if st.arithmetic == hilcam::render::Arithmetic::Fast && st.specular {
                    match st.format.channels() {
                        3 => rgb_specular = true,
                        _ => gray_specular = true,
                    }
                }
                if st.arithmetic == hilcam::render::Arithmetic::Wide {
                    wide_sampled |= st.samples > 1;
                    wide_aperture |= st.aperture > 0;
                    wide_specular |= st.specular;
                }
            }
        }
    }
    // The carry saves a row of corner rays a line; it is left out (the loop
    // traces both rows) where its keys would take over 4 KiB, a quarter of
    // the 16 KiB every board's firmware stays within: a 640-wide sampled
    // frame's 5 KB overflowed the M0's stack (and left the M3 44 B short
    // of 16 KiB).
    if corner_keys * 8 > CORNER_KEYS_MAX_BYTES {
        corner_keys = 0;
    }
    let _ = writeln!(
        code,
        "/// Corner keys the sampled loop carries from line to line (8 bytes each).\npub const CORNER_KEYS: usize = {corner_keys};"
    );
    let _ = writeln!(
        code,
        "/// The line loops the scenes' variants render with; the others are left out.\npub struct Built;\nimpl hilcam::render::Lines for Built {{"
    );
    for l in hilcam::render::LineLoop::ALL {
        let _ = writeln!(code, "    const {}: bool = {};", l.constant(), lines.contains(&l));
    }
    let _ = writeln!(code, "    const FAST_GRAY_SPECULAR: bool = {gray_specular};");
    let _ = writeln!(code, "    const FAST_RGB_SPECULAR: bool = {rgb_specular};");
    let _ = writeln!(code, "    const WIDE_SAMPLED: bool = {wide_sampled};");
    let _ = writeln!(code, "    const WIDE_APERTURE: bool = {wide_aperture};");
    let _ = writeln!(code, "    const WIDE_SPECULAR: bool = {wide_specular};");
    let _ = writeln!(code, "}}");
    let _ = writeln!(
        code,
        "/// Most distortion-table entries any scene's variant renders with.\npub const TABLE: usize = {table};"
    );
    // Each scene's options for each variant, from its plan (the core's
    // planner, run here on the host with the default budget, as host-sim
    // plans the frames it compares): the firmware renders them and holds
    // no planner.
    let options: Vec<String> = resolved
        .iter()
        .map(|r| {
            let scene = r.core_scene().unwrap_or_else(|e| panic!("{}: {e}", r.desc.name));
            let plan = hilcam::planner::plan(&scene, &hilcam::planner::Budget::default());
            let each: Vec<String> = variants.iter().map(|v| options_literal(&v.options(&plan))).collect();
            format!("[{}]", each.join(", "))
        })
        .collect();
    let _ = writeln!(
        code,
        "/// Each scene's options for each variant (the core's planner, run at build time, and the variant's \
         departure from its plan), in scene-id order.\npub const OPTIONS: [[Options; {}]; {}] = [\n    {}\n];",
        variants.len(),
        options.len(),
        options.join(",\n    ")
    );
    let names: Vec<String> = variants.iter().map(Variant::name).collect();
    let _ = writeln!(
        code,
        "/// Variants every scene is rendered with, in order.\npub const VARIANTS: [&str; {}] = {:?};",
        names.len(),
        names
    );
    let _ = writeln!(
        code,
        "/// Renders with variant `v`'s number type and `opts`.\npub fn render_variant<R: super::Runner>(v: usize, opts: &Options, r: &mut R) -> Result<u64, &'static str> {{\n    match v {{"
    );
    for (i, v) in variants.iter().enumerate() {
        let _ = writeln!(code, "        {i} => r.run::<{}>(opts),", v.scalar.type_path());
    }
    let _ = writeln!(code, "        _ => Err(\"no such variant\"),\n    }}\n}}");
    std::fs::write(out.join("scenes.rs"), code).expect("scenes.rs");
}

/// `o` as a Rust expression (every field of `Options` is public).
fn options_literal(o: &hilcam::render::Options) -> String {
    use hilcam::render::RenderModel;
    let model = match o.model {
        RenderModel::Perspective => "RenderModel::Perspective".to_string(),
        RenderModel::WeakPerspective { mean_depth } => format!(
            "RenderModel::WeakPerspective {{ mean_depth: hilcam::num::Len::from_bits({}) }}",
            mean_depth.to_bits()
        ),
        RenderModel::Orthographic { scale } => format!(
            "RenderModel::Orthographic {{ scale: hilcam::num::Norm::from_bits({}) }}",
            scale.to_bits()
        ),
    };
    format!(
        "Options {{ model: {model}, lut_entries: {}, distortion_eval: DistortionEval::{:?}, keep_all_stages: {}, \
         arithmetic: Arithmetic::{:?}, relative_illumination: {}, samples: {}, adaptive: {}, aperture: {}, \
         closed_mean: hilcam::render::ClosedMean::{:?} }}",
        o.lut_entries, o.distortion_eval, o.keep_all_stages, o.arithmetic, o.relative_illumination, o.samples,
        o.adaptive, o.aperture, o.closed_mean
    )
}
