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
//! One module per stage:
//! - [`frame`]: coordinate frames as types;
//! - [`extrinsics`]: pose, world → camera;
//! - [`projection`]: perspective, weak perspective, orthographic; rays;
//! - [`intrinsics`]: image plane ↔ pixel;
//! - [`lens`]: thin lens, blur circle, depth of field;
//! - [`distortion`]: radial distortion, its table and inverse;
//! - [`scene`]: the compact scene;
//! - [`scene_data`]: a scene as data (what a camera stores and receives);
//! - [`shading`]: the mixed BRDF and lights;
//! - [`vignetting`]: cos⁴ fall-off, exposure and quantization;
//! - [`render`]: the line renderer (rays, intersection, and the stages above);
//! - [`sampling`]: pixel-area integration, the sample pattern;
//! - [`defocus`]: the thin lens in the image, the aperture pattern;
//! - [`noise`]: sensor noise (EMVA 1288) from a counter-based generator;
//! - [`scalar`]: the per-pixel number type (I32F32, 32-bit fixed point, `f32`);
//! - [`planner`]: picks the cheapest rendering that meets an error budget;
//! - [`link`]: the wire protocol and the frame encoder;
//! - [`control`]: the host → camera commands, their receiver and state;
//! - [`num`]: the fixed-point formats and wide intermediates.
//!
//! Nothing here panics on any input: constructors return [`Error`], a point
//! at or behind the lens plane is [`NotVisible`], and any result that leaves
//! its format saturates and says so through [`Sat`].

pub mod camera;
pub mod control;
pub mod defocus;
pub mod distortion;
pub mod error;
pub mod extrinsics;
pub mod frame;
pub mod intrinsics;
pub mod lens;
pub mod link;
#[cfg(feature = "mix32")]
pub mod mix32;
pub mod noise;
pub mod num;
pub mod planner;
pub mod projection;
pub mod render;
pub mod sampling;
pub mod scalar;
pub mod scene;
pub mod scene_data;
pub mod shading;
mod vec3;
pub mod vignetting;

#[cfg(feature = "defmt")]
mod fmt;

pub use camera::Camera;
pub use error::{Error, Field, NoRealImage, NotVisible};
pub use extrinsics::Extrinsics;
pub use frame::{CameraDir, CameraPoint, ImagePoint, NormPoint, PixelPoint, Ray, WorldPoint};
pub use intrinsics::{Intrinsics, IntrinsicsConfig};
pub use lens::{Aperture, DepthOfField, Distance, Lens, LensConfig};
pub use num::{Angle, Gain, Len, Norm, Pitch, Px, Rot, Sat};
pub use projection::{DepthBox, Model};
