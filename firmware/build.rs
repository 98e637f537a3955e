//! Picks the board's memory map, and turns every scene in ../scenes into
//! Rust code that builds it with the core's scene builders — the same calls,
//! with the same f64 values, that host-sim makes — so the firmware renders
//! exactly what the host renders.

use host_sim::scene_file::{load, LightDesc, Pose};
use host_sim::variant::Variant;
use std::fmt::Write as _;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR"));
    let mps2 = std::env::var_os("CARGO_FEATURE_BOARD_MPS2_AN386").is_some();
    let memory = if mps2 {
        "memory-mps2-an386.x"
    } else {
        "../memory.x"
    };
    std::fs::copy(memory, out.join("memory.x")).expect("memory map");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={memory}");
    println!("cargo:rerun-if-changed=../scenes");

    // HILCAM_SCENES: newline-separated scene files (host-sim hil --scene);
    // otherwise every scene in ../scenes, sorted by file name.
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
            v
        }
    };
    let mut code = String::new();
    let mut names = Vec::new();
    let (mut max_w, mut max_line) = (0usize, 0usize);
    for (i, p) in paths.iter().enumerate() {
        println!("cargo:rerun-if-changed={}", p.display());
        let r = load(p).unwrap_or_else(|e| panic!("{e}"));
        let c = &r.desc.camera;
        names.push(r.desc.name.clone());
        max_w = max_w.max(c.width as usize);
        max_line = max_line.max(c.width as usize * r.format.bytes_per_pixel());
        let pitch = c.pitch.get();
        let pose = match r.pose {
            Pose::LookAt { eye, target, up } => format!("Extrinsics::look_at({eye:?}, {target:?}, {up:?})"),
            Pose::Ypr { position, angles } => format!(
                "Extrinsics::from_yaw_pitch_roll({:?}, {:?}, {:?}, {position:?})",
                angles[0], angles[1], angles[2]
            ),
            Pose::Matrix { position, rotation } => {
                format!("Extrinsics::from_matrix({rotation:?}, {position:?})")
            }
        };
        let model = match c.orthographic_scale {
            Some(m) if c.model == "orthographic" => {
                format!("Model::orthographic({m:?}).map_err(|_| \"model\")?")
            }
            _ => "Model::Perspective".to_string(),
        };
        let aperture = match (c.f_number, c.aperture) {
            (Some(n), _) => format!("Aperture::FNumber({n:?})"),
            (None, Some(d)) => format!("Aperture::Diameter({d:?})"),
            _ => unreachable!("validated by load"),
        };
        let distortion = match c.distortion {
            Some([k1, k2]) => format!("Distortion::new({k1:?}, {k2:?}).map_err(|_| \"distortion\")?"),
            None => "Distortion::NONE".to_string(),
        };
        let _ = writeln!(
            code,
            "#[inline(never)]\nfn scene_{i}() -> Result<Scene, &'static str> {{"
        );
        let _ = writeln!(
            code,
            "    let intr = IntrinsicsConfig {{ focal_length: {:?}, pitch: {:?}, size: ({}, {}), principal_point: {:?} }};",
            c.focal_length,
            pitch,
            c.width,
            c.height,
            c.principal_point.map(|[x, y]| (x, y))
        );
        let _ = writeln!(code, "    let pose = {pose}.map_err(|_| \"pose\")?;");
        let _ = writeln!(
            code,
            "    let lens = LensConfig {{ aperture: {aperture}, focus_distance: {:?}, tolerable_blur: {:?} }};",
            c.focus_distance, c.tolerable_blur
        );
        let _ = writeln!(
            code,
            "    let camera = Camera::new(&intr, &lens, pose, {model}).map_err(|_| \"camera\")?;"
        );
        let env = &r.desc.environment;
        let _ = writeln!(
            code,
            "    let mut s = Scene::new(camera, {distortion}, PixelFormat::{:?}, {:?}, {:?}, {:?}).map_err(|_| \"scene\")?;",
            r.format,
            r.desc.output.exposure,
            env.ambient.rgb(),
            env.background.rgb()
        );
        for m in &r.desc.materials {
            let _ = writeln!(
                code,
                "    s.add_material({:?}, {:?}, {:?}, {}).map_err(|_| \"material\")?;",
                m.albedo.rgb(),
                m.specular.rgb(),
                m.mix,
                m.exponent
            );
        }
        for p in &r.primitives {
            let checker = match p.checker {
                Some((cell, u_axis, m)) => {
                    format!("Some(CheckerSpec {{ cell: {cell:?}, u_axis: {u_axis:?}, material: {m} }})")
                }
                None => "None".into(),
            };
            let _ = writeln!(
                code,
                "    s.add_primitive(ShapeSpec::{:?}, {}, {checker}).map_err(|_| \"primitive\")?;",
                p.shape, p.material
            );
        }
        for l in &r.lights {
            match l {
                LightDesc::Point { position, intensity } => {
                    let _ = writeln!(
                        code,
                        "    s.add_point_light({position:?}, {:?}).map_err(|_| \"light\")?;",
                        intensity.rgb()
                    );
                }
                LightDesc::Directional {
                    direction,
                    irradiance,
                } => {
                    let _ = writeln!(
                        code,
                        "    s.add_directional_light({direction:?}, {:?}).map_err(|_| \"light\")?;",
                        irradiance.rgb()
                    );
                }
            }
        }
        if let Some(sm) = r.desc.sampling {
            let _ = writeln!(
                code,
                "    s.set_sampling({:?}, {}).map_err(|_| \"sampling\")?;",
                sm.edge_error, sm.adaptive
            );
        }
        if let Some(n) = r.desc.noise {
            let _ = writeln!(
                code,
                "    s.set_noise({:?}, {:?}, {:?}, {}).map_err(|_| \"noise\")?;",
                n.saturation, n.dark_noise, n.dark_offset, n.seed
            );
        }
        let _ = writeln!(code, "    Ok(s)\n}}\n");
    }
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
    let _ = writeln!(
        code,
        "/// Builds scene `i`.\npub fn build(i: usize) -> Result<Scene, &'static str> {{\n    match i {{"
    );
    for i in 0..names.len() {
        let _ = writeln!(code, "        {i} => scene_{i}(),");
    }
    let _ = writeln!(code, "        _ => Err(\"no such scene\"),\n    }}\n}}");

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
    let needs_plan = variants.iter().any(Variant::needs_plan);
    let _ = writeln!(
        code,
        "/// Some variant takes the planner's arithmetic or distortion choice.\npub const NEEDS_PLAN: bool = {needs_plan};"
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
        "/// Renders with variant `v`.\npub fn render_variant<R: super::Runner>(v: usize, planned: &Options, r: &mut R) -> Result<u64, &'static str> {{\n    match v {{"
    );
    for (i, v) in variants.iter().enumerate() {
        let _ = writeln!(
            code,
            "        {i} => r.run::<{}>(&{}),",
            v.scalar.type_path(),
            v.options_expr("planned")
        );
    }
    let _ = writeln!(code, "        _ => Err(\"no such variant\"),\n    }}\n}}");
    std::fs::write(out.join("scenes.rs"), code).expect("scenes.rs");
}
