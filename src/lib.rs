#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
//! # hilcam core
//!
//! The camera model of the hardware-in-the-loop camera emulator, in fixed
//! point, without heap or floating point in its per-point and per-pixel paths
//! (floats appear only where parameters are converted once, at
//! construction). The contract it implements is `camera-model.md`; the f64
//! reference that checks it lives in `host-sim`.
//!
//! Modules by layer:
//! - [`num`]: the fixed-point formats, wide intermediates, the per-pixel
//!   scalar;
//! - [`geom`]: coordinate frames as types, extrinsics, projection,
//!   intrinsics, the thin lens, distortion, the camera;
//! - [`scene`]: the compact scene, and a scene as data ([`scene::data`]);
//! - [`render`]: the line renderer: options, preparation, the wide and the
//!   fast arithmetic, shading, vignetting and the sensor stages;
//! - [`planner`]: picks the cheapest rendering that meets an error budget;
//! - [`link`]: the wire protocol, the frame encoder and the camera's
//!   control.
//!
//! Nothing here panics on any input: constructors return [`Error`], a point
//! at or behind the lens plane is [`NotVisible`], and any result that leaves
//! its format saturates and says so through [`Sat`].

pub mod geom;
pub mod link;
pub mod num;
pub mod planner;
pub mod render;
pub mod scene;

#[cfg(feature = "defmt")]
mod fmt;

pub use geom::camera::Camera;
pub use geom::error::{Error, Field, NoRealImage, NotVisible};
pub use geom::extrinsics::Extrinsics;
pub use geom::frame::{CameraDir, CameraPoint, ImagePoint, NormPoint, PixelPoint, Ray, WorldPoint};
pub use geom::intrinsics::{Intrinsics, IntrinsicsConfig};
pub use geom::lens::{Aperture, DepthOfField, Distance, Lens, LensConfig};
pub use geom::projection::{DepthBox, Model};
pub use num::{Angle, Gain, Len, Norm, Pitch, Px, Rot, Sat};
