//! `host-sim export`.

use host_sim::output::Outputs;

/// Export a scene's camera for calibration tools: opencv.yaml (OpenCV
/// FileStorage: camera matrix, distortion refitted in OpenCV's direction,
/// rotation and translation), ros.yaml (ROS CameraInfo) and export.json
/// (the fit's largest residual in px, and world points with the pixels
/// the emulator images them at).
#[derive(clap::Args)]
pub struct Args {
    /// Scene file.
    #[arg(long)]
    scene: std::path::PathBuf,
    /// Output directory.
    #[arg(long)]
    out: std::path::PathBuf,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args { scene, out } = args;
    let r = host_sim::scene_file::load(&scene)?;
    let e = host_sim::export::export(&r).map_err(|e| format!("{}: {e}", scene.display()))?;
    let mut o = Outputs::prepare(&out)?;
    o.write("opencv.yaml", host_sim::export::opencv_yaml(&e).as_bytes())?;
    o.write("ros.yaml", host_sim::export::ros_yaml(&e).as_bytes())?;
    o.write(
        "export.json",
        &serde_json::to_vec_pretty(&e).map_err(|e| e.to_string())?,
    )?;
    o.commit()?;
    if !e.within_tolerance {
        eprintln!(
            "warning: {}: OpenCV's {} model fits this camera's distortion to {:.3} px at worst, over the {} px \
             a calibration test expects (export.json: within_tolerance false)",
            scene.display(),
            e.distortion.model,
            e.distortion.residual_px,
            e.residual_tolerance_px
        );
    }
    Ok(format!(
        "{}: {} with {} coefficients, largest residual {:.2e} px over r_d <= {:.4}",
        e.camera,
        e.distortion.model,
        e.distortion.coefficients.len(),
        e.distortion.residual_px,
        e.distortion.r_max
    ))
}
