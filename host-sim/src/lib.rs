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

pub mod boards;
pub mod calibration;
pub mod link;
pub mod scene_file;
pub mod shipped;
pub mod trajectory;

/// Modules built only with the `cli` feature.
macro_rules! cli_modules {
    ($($m:ident),* $(,)?) => {
        $(
            #[cfg(feature = "cli")]
            pub mod $m;
        )*
    };
}

cli_modules!(
    camera_cmd, client, costfit, demo, drive_cmd, export, frame_png, hil_cmd, output, profile, qemu,
    render_cmd, stream_cmd, tradeoff, truth,
);

#[cfg(feature = "model")]
pub mod harness;
#[cfg(feature = "model")]
pub mod reference;
#[cfg(feature = "model")]
pub mod variant;
