//! Geometry: coordinate frames as types, the pose, the projection models,
//! the pixel grid, the thin lens and radial distortion (camera-model.md §1–§5).

pub mod calibrated;
pub mod camera;
pub mod distortion;
pub mod error;
pub mod extrinsics;
pub mod frame;
pub mod intrinsics;
pub mod lens;
pub mod projection;
