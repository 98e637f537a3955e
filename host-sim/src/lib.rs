//! host-sim: the f64 reference models of the hilcam camera and the host-side
//! harness.
//!
//! [`reference`](mod@reference) implements `camera-model.md` in `f64`, written from the
//! contract and not from the fixed-point core, so that comparing the two
//! checks something. Its modules mirror the core's (`extrinsics`,
//! `projection`, `intrinsics`, `lens`).
//!
//! Without the default `cli` feature only [`scene_file`], [`trajectory`]
//! and the link's decoder are built (what the fuzz targets need).

#[cfg(feature = "cli")]
pub mod camera_cmd;
#[cfg(feature = "cli")]
pub mod costfit;
#[cfg(feature = "cli")]
pub mod demo;
#[cfg(feature = "cli")]
pub mod drive_cmd;
#[cfg(feature = "cli")]
pub mod export;
#[cfg(feature = "cli")]
pub mod frame_png;
#[cfg(feature = "cli")]
pub mod harness;
#[cfg(feature = "cli")]
pub mod hil_cmd;
pub mod link;
#[cfg(feature = "cli")]
pub mod output;
#[cfg(feature = "cli")]
pub mod reference;
#[cfg(feature = "cli")]
pub mod render_cmd;
pub mod scene_file;
#[cfg(feature = "cli")]
pub mod stream_cmd;
#[cfg(feature = "cli")]
pub mod tradeoff;
pub mod trajectory;
#[cfg(feature = "cli")]
pub mod truth;
#[cfg(feature = "cli")]
pub mod variant;
