//! host-sim: the f64 reference models of the hilcam camera and the host-side
//! harness.
//!
//! [`reference`](mod@reference) implements `camera-model.md` in `f64`, written from the
//! contract and not from the fixed-point core, so that comparing the two
//! checks something. Its modules mirror the core's (`extrinsics`,
//! `projection`, `intrinsics`, `lens`).

pub mod camera_cmd;
pub mod costfit;
pub mod demo;
pub mod drive_cmd;
pub mod export;
pub mod frame_png;
pub mod harness;
pub mod hil_cmd;
pub mod link;
pub mod output;
pub mod reference;
pub mod render_cmd;
pub mod scene_file;
pub mod stream_cmd;
pub mod tradeoff;
pub mod trajectory;
pub mod truth;
pub mod variant;
