//! The line renderer (camera-model.md §3, §5, §6, §7, §9).
//!
//! One ray per pixel centre — or, where the scene asks for pixel-area
//! integration, the mean of an `n×n` grid over the pixel's square
//! ([`crate::render::sensor::sampling`]) — then, where it asks for sensor noise, the EMVA
//! 1288 stage ([`crate::render::sensor::noise`]); fixed point end to end, one scanline at a time
//! into the place a [`FrameSink`] holds for it (a link encoder's chunk) or
//! else a caller-provided line buffer handed to the sink: RAM is O(width),
//! whatever the height.
//!
//! A [`Frame`] is prepared once per frame: the scene is moved into the camera
//! frame, the distortion table built, constants folded, each bounded
//! primitive's slope-space bounds computed. The per-pixel arithmetic is the
//! planner's choice ([`Options::arithmetic`]): the fast one
//! (`crate::render::fast`, 32-bit with a format per quantity, lines in chunks of
//! 32 rays), or the wide one here, generic over a [`crate::num::scalar::Scalar`] — I32F32
//! ([`crate::scene::Q`]) for the planner's fallback, `f32` for comparison
//! ([`Frame::build`]). The wide one runs one of two pixel loops
//! (perspective or parallel rays), and the stages the scene may not need
//! (distortion, specular, vignetting) are per-frame flags: a branch that
//! goes the same way for the whole frame. Arithmetic saturates: nothing
//! wraps, and a value that saturates ends as a saturated pixel. Scene
//! ranges ([`crate::scene`]) keep valid scenes clear of saturation in
//! I32F32 except where the physics says so (over-exposure); what the fast
//! formats cannot hold the planner does not send them.

#[cfg(feature = "mix32")]
pub(crate) mod fast;
mod frame;
mod options;
pub(crate) mod prepare;
pub mod sensor;
pub mod shading;
pub mod shadows;
mod sink;
pub mod vignetting;
mod wide;

#[cfg(feature = "mix32")]
pub use fast::ApertureClasses;
pub use frame::Frame;
pub use options::{
    AllLines, Arithmetic, ClosedMean, DistortionEval, FrameError, LineLoop, Lines, Options, Override,
    PlannedLines, RenderError, RenderModel, Stages, Unfit, FLAG_OUTSIDE_FIELD, MAX_SLOPE,
};
pub use sink::{FrameInfo, FrameSink, Image, ImageTooSmall, LineBuffers, Timed};
