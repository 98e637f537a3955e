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
    /// Per checkered rectangle, its inner corners in view (imaged within
    /// the frame), row by row; at most [`MAX_CORNERS`] in all.
    pub checker_corners: Vec<Vec<Corner>>,
    /// Corners in view left out past [`MAX_CORNERS`] (0: the list is whole).
    pub corners_left_out: u64,
    /// The stages the frame was rendered with.
    pub stages: Vec<String>,
}

/// A checker corner.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Corner {
    /// Texture coordinates `(u, v)`, metres from the texture's origin (the
    /// rectangle's centre): the board's own coordinates.
    pub board: [f64; 2],
    /// Pixel position (pixel centres at integers; within the frame).
    pub pixel: Option<[f64; 2]>,
}

/// The most checker corners a frame's truth lists (a 1 m board of 1 mm
/// cells has a million; past the cap they are counted, not listed).
pub const MAX_CORNERS: usize = 250_000;

/// The truth of `r` rendered with `stages`.
pub fn truth(r: &Resolved, stages: Vec<String>) -> Result<Truth, String> {
    let rs = RefScene::new(r);
    let s = rs.sensor;
    let (rotation, translation) = r.pose.matrix()?;
    // Corners in view only: imaged within the frame's edges.
    let (w, h) = (f64::from(s.width), f64::from(s.height));
    let mut checker_corners = vec![Vec::new(); rs.checkered_rectangles()];
    let (mut listed, mut corners_left_out) = (0usize, 0u64);
    rs.for_each_checker_corner(|k, board, p| {
        let Some((x, y)) = rs.project(p) else { return };
        if !(-0.5..w - 0.5).contains(&x) || !(-0.5..h - 0.5).contains(&y) {
            return;
        }
        if listed == MAX_CORNERS {
            corners_left_out += 1;
            return;
        }
        listed += 1;
        checker_corners[k].push(Corner {
            board,
            pixel: Some([x, y]),
        });
    });
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
        checker_corners,
        corners_left_out,
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

/// Renders `r` as [`render`] does, a line at a time straight into
/// `frame.png` (memory is a line, whatever the height), and writes
/// `truth.json` into `dir`: both or neither (a refusal or a failure leaves
/// nothing, [`crate::output::Outputs`]).
pub fn frame_to(
    dir: &std::path::Path,
    r: &Resolved,
    variant: &crate::variant::Variant,
    frame_id: u32,
) -> Result<Truth, String> {
    /// The frame's rows into its PNG.
    struct Rows<W: std::io::Write + 'static> {
        png: png::StreamWriter<'static, W>,
        format: hilcam::scene::PixelFormat,
        row: Vec<u8>,
        path: std::path::PathBuf,
    }
    impl<W: std::io::Write + 'static> hilcam::render::FrameSink for Rows<W> {
        type Error = String;
        fn line(&mut self, _y: u16, pixels: &[u8], _flags: &[u8]) -> Result<(), String> {
            use std::io::Write;
            let dn = crate::harness::decode_all(self.format, pixels);
            crate::frame_png::png_row(self.format, &dn, &mut self.row);
            self.png
                .write_all(&self.row)
                .map_err(|e| format!("{}: {e}", self.path.display()))
        }
    }
    if variant.scalar == crate::variant::ScalarKind::F32 {
        return Err("--variant: f32 variants are for the sweep (tradeoff), not for frames".into());
    }
    let mut out = crate::output::Outputs::prepare(dir)?;
    let (w, h) = (usize::from(r.desc.camera.width), usize::from(r.desc.camera.height));
    let path = out.dir().join("frame.png");
    let png = crate::frame_png::png_stream(out.create("frame.png")?, w, h, Some(r.format))?;
    let mut rows = Rows {
        png,
        format: r.format,
        row: Vec::new(),
        path: path.clone(),
    };
    let (_, stages) = variant.render_frame_to(r, &hilcam::planner::Budget::default(), frame_id, &mut rows)?;
    rows.png.finish().map_err(|e| format!("{}: {e}", path.display()))?;
    let t = truth(r, stages)?;
    let json = serde_json::to_vec_pretty(&t).map_err(|e| format!("truth: {e}"))?;
    out.write("truth.json", &json)?;
    out.commit()?;
    Ok(t)
}

/// The ray each pixel's centre images in the frame the planner picks for
/// `r`, as the core computes it (`Frame::undistorted`, the pixel loop's own
/// code): OpenCV's normalized `(x, y)` (the point `(x, y, 1)` in its camera
/// frame, x right and y down), row by row; NaN outside the lens field.
pub fn pixel_rays(r: &Resolved) -> Result<Vec<[f64; 2]>, String> {
    let scene = r.core_scene()?;
    let plan = hilcam::planner::plan(&scene, &hilcam::planner::Budget::default());
    let frame = hilcam::render::Frame::new(&scene, &plan.options).map_err(|e| format!("camera: {e:?}"))?;
    let (w, h) = frame.size();
    let mut out = Vec::with_capacity(usize::from(w) * usize::from(h));
    for j in 0..h {
        for i in 0..w {
            out.push(match frame.undistorted(i, j) {
                Some((x, y)) => [-x.to_num::<f64>(), -y.to_num::<f64>()],
                None => [f64::NAN; 2],
            });
        }
    }
    Ok(out)
}
