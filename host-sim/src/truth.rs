//! Ground truth of a rendered frame (`host-sim frame`): the camera in
//! OpenCV's pixel conventions, the pose, and where each checker texture's
//! inner corners are imaged — computed by the f64 reference from the scene,
//! not read off the frame.

use crate::reference::render::RefScene;
use crate::scene_file::Resolved;
use serde::Serialize;

/// `truth.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Truth {
    /// Scene name.
    pub scene: String,
    /// Frame size, px.
    pub width: u32,
    /// Frame size, px.
    pub height: u32,
    /// Focal length in pixels along x (`f / s_x`): OpenCV's `fx`.
    pub fx: f64,
    /// Focal length in pixels along y: OpenCV's `fy`.
    pub fy: f64,
    /// Principal point, px: OpenCV's `cx`, `cy` (pixel centres at integers,
    /// as OpenCV's).
    pub cx: f64,
    /// See `cx`.
    pub cy: f64,
    /// The contract's radial distortion `[k1, k2]` (distorted →
    /// undistorted, camera-model.md §3; not OpenCV's direction), if any.
    pub distortion: Option<[f64; 2]>,
    /// `R`, row by row: the camera's axes in world coordinates
    /// (camera-model.md §1).
    pub rotation: [[f64; 3]; 3],
    /// `T`: the centre of projection in world coordinates, m.
    pub translation: [f64; 3],
    /// Per checkered rectangle, its inner corners, row by row.
    pub checker_corners: Vec<Vec<Corner>>,
    /// The stages the frame was rendered with.
    pub stages: Vec<String>,
}

/// A checker corner.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Corner {
    /// Texture coordinates `(u, v)`, metres from the texture's origin (the
    /// rectangle's centre): the board's own coordinates.
    pub board: [f64; 2],
    /// Pixel position (`null` where the corner is behind the camera or
    /// beyond the lens field's fold).
    pub pixel: Option<[f64; 2]>,
}

/// The truth of `r` rendered with `stages`.
pub fn truth(r: &Resolved, stages: Vec<String>) -> Result<Truth, String> {
    let rs = RefScene::new(r);
    let s = rs.sensor;
    let (rotation, translation) = r.pose.matrix()?;
    Ok(Truth {
        scene: r.desc.name.clone(),
        width: s.width,
        height: s.height,
        fx: s.f / s.sx,
        fy: s.f / s.sy,
        cx: s.ox,
        cy: s.oy,
        distortion: r.desc.camera.distortion,
        rotation,
        translation,
        checker_corners: rs
            .checker_corners()
            .into_iter()
            .map(|pts| {
                pts.into_iter()
                    .map(|(board, p)| Corner {
                        board,
                        pixel: rs.project(p).map(|(x, y)| [x, y]),
                    })
                    .collect()
            })
            .collect(),
        stages,
    })
}

/// A frame the core rendered (the planner's choice, or a variant), with
/// what it is: its plan and its ground truth.
pub struct Rendered {
    /// Pixel format.
    pub format: hilcam::scene::PixelFormat,
    /// Size, px.
    pub width: usize,
    /// Size, px.
    pub height: usize,
    /// The core's bytes, line by line (the wire's and the firmware's).
    pub pixels: Vec<u8>,
    /// A byte of `FLAG_*` bits a pixel (`hilcam::render::FLAG_OUTSIDE_FIELD`).
    pub flags: Vec<u8>,
    /// What the planner chose, its prediction and every candidate.
    pub plan: crate::harness::PlanReport,
    /// The frame's ground truth.
    pub truth: Truth,
}

/// Renders `r` with the core only (the planner's choice within the default
/// budget, or `variant`) as frame `frame_id` (the noise's key).
pub fn render(r: &Resolved, variant: &crate::variant::Variant, frame_id: u32) -> Result<Rendered, String> {
    /// Collects the frame, its stages and its plan.
    struct Keep;
    impl crate::variant::FrameUser for Keep {
        type Out = (crate::harness::Collect, Vec<String>, crate::harness::PlanReport);
        fn use_frame<S: hilcam::num::scalar::Scalar>(
            self,
            plan: &hilcam::planner::Plan,
            frame: &hilcam::render::Frame<S>,
            core: crate::harness::Collect,
        ) -> Self::Out {
            let stages = frame.stages().names().iter().map(|s| s.to_string()).collect();
            let report = crate::harness::plan_report(plan, &hilcam::planner::Budget::default(), frame);
            (core, stages, report)
        }
    }
    if variant.scalar == crate::variant::ScalarKind::F32 {
        return Err("--variant: f32 variants are for the sweep (tradeoff), not for frames".into());
    }
    let (core, stages, plan) = variant.render_frame(r, &hilcam::planner::Budget::default(), frame_id, Keep)?;
    Ok(Rendered {
        format: r.format,
        width: usize::from(r.desc.camera.width),
        height: usize::from(r.desc.camera.height),
        pixels: core.pixels,
        flags: core.flags,
        plan,
        truth: truth(r, stages)?,
    })
}

/// Renders `r` ([`render`]) and writes `frame.png` and `truth.json` into
/// `dir`, both or neither.
pub fn frame_to(
    dir: &std::path::Path,
    r: &Resolved,
    variant: &crate::variant::Variant,
    frame_id: u32,
) -> Result<Truth, String> {
    let f = render(r, variant, frame_id)?;
    let png = crate::frame_png::encode_png(f.format, f.width, f.height, &f.pixels)?;
    let json = serde_json::to_vec_pretty(&f.truth).map_err(|e| format!("truth: {e}"))?;
    let mut out = crate::output::Outputs::prepare(dir)?;
    out.write("frame.png", &png)?;
    out.write("truth.json", &json)?;
    out.commit()?;
    Ok(f.truth)
}
