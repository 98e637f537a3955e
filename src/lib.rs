#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
//! # hilcam core
//!
//! A camera, in fixed point, that forms the frames a real one would: give
//! it a scene (surfaces, materials, lights) and a camera (pose, lens,
//! sensor) and it renders the frame line by line into your buffer, or
//! straight onto a link, on a Cortex-M0 as on the host, the same bytes on
//! each. `#![no_std]`, no heap, no floating point in the per-pixel path.
//! The model it implements is the contract in `camera-model.md`; the f64
//! reference that checks it lives in `host-sim`.
//!
//! ## Render a frame
//!
//! Build a validated [`Scene`] (every value is checked where it is added,
//! and a refusal names the field), let the planner choose the cheapest
//! rendering within an error budget ([`Frame::plan`]), and render the
//! frame into a buffer ([`render::Image`]) or through any
//! [`render::FrameSink`] — a link encoder ([`link::Stream`]), a file, a
//! test's collector:
//!
//! ```
//! use hilcam::render::{Image, LineBuffers};
//! use hilcam::{Aperture, Budget, Camera, Distortion, Extrinsics, Frame};
//! use hilcam::{IntrinsicsConfig, LensConfig, Model, PixelFormat, Scene, ShapeSpec};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let sensor = IntrinsicsConfig { focal_length: 2.4e-3, pitch: (12e-6, 12e-6), size: (160, 120), principal_point: None };
//! let lens = LensConfig { aperture: Aperture::FNumber(4.0), focus_distance: 2.0, tolerable_blur: 12e-6 };
//! let pose = Extrinsics::look_at([0.0, 0.5, -2.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0])?;
//! let camera = Camera::new(&sensor, &lens, pose, Model::Perspective)?;
//! let mut scene = Scene::new(camera, Distortion::NONE, PixelFormat::Gray8, 2e4, [0.05; 3], [0.0; 3])?;
//! let grey = scene.add_material([0.8; 3], [0.0; 3], 1.0, 0)?;
//! scene.add_primitive(ShapeSpec::Sphere { centre: [0.0, 0.0, 0.0], radius: 0.4 }, grey, None)?;
//! scene.add_point_light([1.0, 2.0, -1.0], [4.0; 3])?;
//!
//! let frame = Frame::plan(&scene, &Budget::default())?;
//! let mut image = vec![0u8; 160 * 120];
//! let mut flags = [0u8; 160];
//! frame.render(LineBuffers::new(&mut [], &mut flags), &mut Image::new(&mut image))?;
//! assert!(image.iter().any(|&p| p > 0));
//! # Ok(())
//! # }
//! ```
//!
//! [`Frame::render_line`] renders one line alone (lines in any order, or
//! in parallel); [`Frame::new`] renders with options of your own
//! instead of the planner's ([`planner::plan`] lists its candidates, with
//! their predicted errors and costs). A camera in the loop keeps a scene
//! and a frame and changes what the host asks for: [`Scene::set_pose`],
//! [`Scene::set_exposure`], or a whole scene as data ([`scene::data`],
//! [`link::control`]).
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
mod target;

#[cfg(feature = "defmt")]
mod fmt;

pub use geom::camera::Camera;
pub use geom::distortion::Distortion;
pub use geom::error::{Error, Field, NoRealImage, NotVisible};
pub use geom::extrinsics::Extrinsics;
pub use geom::frame::{CameraDir, CameraPoint, ImagePoint, NormPoint, PixelPoint, Ray, WorldPoint};
pub use geom::intrinsics::{Intrinsics, IntrinsicsConfig};
pub use geom::lens::{Aperture, DepthOfField, Distance, Lens, LensConfig};
pub use geom::projection::{DepthBox, Model};
pub use num::{Angle, Gain, Len, Norm, Pitch, Px, Rot, Sat};
pub use planner::Budget;
pub use render::Frame;
pub use scene::{CheckerSpec, PixelFormat, Scene, SceneError, ShapeSpec};
