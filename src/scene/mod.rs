//! The compact scene the renderer works on: camera, distortion, materials,
//! primitives, lights, exposure and output format, in fixed point, with no
//! heap (bounded `heapless` vectors). host-sim builds it from a scene file;
//! a firmware can build or embed it.
//!
//! Every value is validated when it is added, against ranges that keep the
//! per-pixel I32F32 arithmetic of the renderer free of overflow: positions
//! within ±[`MAX_EXTENT`] m of the origin, radii and cells within
//! [[`MIN_SIZE`], [`MAX_EXTENT`]] m, radiometric values within
//! [0, [`MAX_RADIOMETRIC`]].

pub mod data;

use crate::geom::calibrated::Calibrated;
use crate::geom::camera::Camera;
use crate::geom::distortion::Distortion;
use crate::geom::frame::WorldPoint;
use crate::num::vec3::{cross, div, dot, norm};
use crate::num::{Len, Norm};
use core::fmt;
use fixed::types::I32F32;

/// Renderer scalar: I32F32 (±2.1·10⁹, resolution 2.3·10⁻¹⁰).
pub type Q = I32F32;

/// Most materials in a scene: 16, or fewer where a device's build sets
/// `HILCAM_MAX_MATERIALS` (1 to 16) — a device holds the scenes it is built
/// for, and its RAM follows (a scene and a frame reserve each item).
pub const MAX_MATERIALS: usize = capacity(built::MATERIALS, 16);
/// Most primitives in a scene: 16, or `HILCAM_MAX_PRIMITIVES` (1 to 16).
pub const MAX_PRIMITIVES: usize = capacity(built::PRIMITIVES, 16);
/// Most lights in a scene: 8, or `HILCAM_MAX_LIGHTS` (1 to 8).
pub const MAX_LIGHTS: usize = capacity(built::LIGHTS, 8);

/// The `HILCAM_MAX_*` a device (`target_os = "none"`) is built with.
#[cfg(target_os = "none")]
mod built {
    pub(super) const MATERIALS: Option<&str> = option_env!("HILCAM_MAX_MATERIALS");
    pub(super) const PRIMITIVES: Option<&str> = option_env!("HILCAM_MAX_PRIMITIVES");
    pub(super) const LIGHTS: Option<&str> = option_env!("HILCAM_MAX_LIGHTS");
}

/// On the host, the most: a host build, the firmware's build script among
/// them, does not read `HILCAM_MAX_*`, so cargo does not build it again
/// when a firmware build sets other values (the build script checks its
/// scenes against them itself).
#[cfg(not(target_os = "none"))]
mod built {
    pub(super) const MATERIALS: Option<&str> = None;
    pub(super) const PRIMITIVES: Option<&str> = None;
    pub(super) const LIGHTS: Option<&str> = None;
}

/// A capacity set at build time (`value`, decimal), `most` if unset. A
/// value that is not a number from 1 to `most` stops the build.
const fn capacity(value: Option<&str>, most: usize) -> usize {
    let Some(v) = value else {
        return most;
    };
    let mut b = v.as_bytes();
    let mut n = 0usize;
    while let [d, rest @ ..] = b {
        assert!(d.is_ascii_digit() && n < 1000, "HILCAM_MAX_*: not a number");
        n = n * 10 + (*d - b'0') as usize;
        b = rest;
    }
    assert!(n >= 1 && n <= most, "HILCAM_MAX_*: out of range");
    n
}
/// Largest distance of any scene position (and the camera) from the origin,
/// metres, per coordinate.
pub const MAX_EXTENT: f64 = 1000.0;
/// Smallest radius, cell size or half-size, metres.
pub const MIN_SIZE: f64 = 1e-4;
/// Largest radiance, intensity, irradiance or ambient value (SI units).
pub const MAX_RADIOMETRIC: f64 = 1e6;
/// Largest specular exponent `s`.
pub const MAX_EXPONENT: u16 = 1000;

/// Output pixel format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PixelFormat {
    /// 8-bit gray, one byte a pixel.
    Gray8,
    /// Gray with `bits` (9 to 16) significant bits, two bytes a pixel,
    /// little-endian.
    Gray16 {
        /// Significant bits.
        bits: u8,
    },
    /// 5-6-5 colour, two bytes a pixel, little-endian `r << 11 | g << 5 | b`.
    Rgb565,
}

impl PixelFormat {
    /// Bytes a pixel.
    pub const fn bytes_per_pixel(self) -> usize {
        match self {
            PixelFormat::Gray8 => 1,
            PixelFormat::Gray16 { .. } | PixelFormat::Rgb565 => 2,
        }
    }

    /// Colour channels rendered: 1 for gray, 3 for RGB565.
    pub const fn channels(self) -> usize {
        match self {
            PixelFormat::Rgb565 => 3,
            _ => 1,
        }
    }

    /// Largest pixel value of channel `c`.
    pub const fn dn_max(self, c: usize) -> u32 {
        match self {
            PixelFormat::Gray8 => 255,
            PixelFormat::Gray16 { bits } => (1u32 << bits) - 1,
            PixelFormat::Rgb565 => {
                if c == 1 {
                    63
                } else {
                    31
                }
            }
        }
    }

    /// The exposure scale of channel `c` relative to channel 0: `K` is given
    /// in DN of the first channel, and a channel with more bits (RGB565's
    /// 6-bit green) scales it by `dn_max(c) / dn_max(0)`, so that equal
    /// irradiance fills equal fractions of every channel. Returned as
    /// `(numerator, denominator)`.
    pub const fn channel_scale(self, c: usize) -> (u32, u32) {
        (self.dn_max(c), self.dn_max(0))
    }

    /// Name as the scene format spells it.
    pub const fn name(self) -> &'static str {
        match self {
            PixelFormat::Gray8 => "gray8",
            PixelFormat::Gray16 { .. } => "gray16",
            PixelFormat::Rgb565 => "rgb565",
        }
    }

    /// The channel values of one pixel's bytes (as [`PixelFormat::pack`]
    /// writes them; unused channels 0, missing bytes read as 0): what a
    /// receiver, the PNG writer and the comparisons decode with.
    pub fn unpack(self, b: &[u8]) -> [u32; 3] {
        let byte = |i: usize| b.get(i).copied().unwrap_or(0);
        let le16 = u16::from_le_bytes([byte(0), byte(1)]) as u32;
        match self {
            PixelFormat::Gray8 => [byte(0) as u32, 0, 0],
            PixelFormat::Gray16 { .. } => [le16, 0, 0],
            PixelFormat::Rgb565 => [le16 >> 11, (le16 >> 5) & 63, le16 & 31],
        }
    }

    /// Packs channel values (each ≤ `dn_max`) into the pixel bytes.
    #[inline]
    pub fn pack(self, dn: [u32; 3], out: &mut [u8]) {
        match self {
            PixelFormat::Gray8 => {
                if let Some(b) = out.first_mut() {
                    *b = dn[0] as u8;
                }
            }
            PixelFormat::Gray16 { .. } => {
                let v = (dn[0] as u16).to_le_bytes();
                out.iter_mut().zip(v).for_each(|(o, v)| *o = v);
            }
            PixelFormat::Rgb565 => {
                let v = ((dn[0] << 11) | (dn[1] << 5) | dn[2]) as u16;
                out.iter_mut().zip(v.to_le_bytes()).for_each(|(o, v)| *o = v);
            }
        }
    }
}

/// A surface's reflectance (camera-model.md §6), per channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Material {
    /// Lambertian albedo `ρ` per channel, in [0, 1].
    pub albedo: [Q; 3],
    /// Specular albedo `ρ_s` per channel, in [0, 1].
    pub specular: [Q; 3],
    /// Mix `n` between Lambertian (1) and specular (0), in [0, 1].
    pub mix: Q,
    /// Phong exponent `s`, 0 to [`MAX_EXPONENT`].
    pub exponent: u16,
}

impl Material {
    /// True if the specular lobe contributes anything.
    pub fn has_specular(&self) -> bool {
        self.mix < Q::ONE && self.specular.iter().any(|s| *s > Q::ZERO)
    }
}

/// A checkerboard on a planar primitive: albedo from the primitive's
/// material or from `material` by the parity of `floor(u/c) + floor(v/c)`
/// (odd cells take `material`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Checker {
    /// Cell size `c`, metres.
    pub cell: Len,
    /// Unit texture axis `u` in the plane (world frame).
    pub u_axis: [Norm; 3],
    /// Unit texture axis `v = n × u` (world frame).
    pub v_axis: [Norm; 3],
    /// Material of the odd cells.
    pub material: u8,
}

/// A primitive's geometry (world frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// Infinite plane through `point` with unit `normal` (two-sided).
    Plane {
        /// A point on the plane.
        point: WorldPoint,
        /// Unit normal.
        normal: [Norm; 3],
    },
    /// Sphere.
    Sphere {
        /// Centre.
        centre: WorldPoint,
        /// Radius, metres.
        radius: Len,
    },
    /// Disc (two-sided).
    Disc {
        /// Centre.
        centre: WorldPoint,
        /// Unit normal.
        normal: [Norm; 3],
        /// Radius, metres.
        radius: Len,
    },
    /// Rectangle (two-sided) with unit edge directions `u`, `v`.
    Rectangle {
        /// Centre.
        centre: WorldPoint,
        /// Unit edge direction `u`.
        u_axis: [Norm; 3],
        /// Unit edge direction `v` (orthogonal to `u`).
        v_axis: [Norm; 3],
        /// Half-extents along `u` and `v`, metres.
        half: [Len; 2],
    },
}

/// A shape with its material and optional checker texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Primitive {
    /// Geometry.
    pub shape: Shape,
    /// Index into the scene's materials.
    pub material: u8,
    /// Checker texture (planar shapes only).
    pub checker: Option<Checker>,
}

/// A light source.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Light {
    /// Point light with intensity `I` (W/sr) per channel; irradiance
    /// `I / r² · max(0, n̂·l̂)`.
    Point {
        /// Position.
        position: WorldPoint,
        /// Intensity per channel, W/sr.
        intensity: [Q; 3],
    },
    /// Directional light: irradiance `E₀ · max(0, n̂·l̂)`.
    Directional {
        /// Unit direction towards the light (world frame).
        towards: [Norm; 3],
        /// Irradiance `E₀` per channel, W/m², on a surface facing the light.
        irradiance: [Q; 3],
    },
}

/// What a scene value is, for error messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Item {
    /// A scene-wide value.
    Scene,
    /// Material `i`.
    Material(u8),
    /// Primitive `i`.
    Primitive(u8),
    /// Light `i`.
    Light(u8),
}

/// A scene value that was rejected: where, which field, and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SceneError {
    /// The item.
    pub item: Item,
    /// The field's name as the scene format spells it.
    pub field: &'static str,
    /// What is wrong.
    pub problem: Problem,
}

/// What is wrong with a scene value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Problem {
    /// NaN or infinite.
    NotFinite,
    /// Outside its documented range.
    OutOfRange,
    /// A zero vector, or axes that are parallel.
    Degenerate,
    /// Refers to a material that does not exist.
    UnknownMaterial,
    /// More items than the scene holds.
    TooMany,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.item {
            Item::Scene => write!(f, "{}", self.field)?,
            Item::Material(i) => write!(f, "materials[{i}].{}", self.field)?,
            Item::Primitive(i) => write!(f, "primitives[{i}].{}", self.field)?,
            Item::Light(i) => write!(f, "lights[{i}].{}", self.field)?,
        }
        let why = match self.problem {
            Problem::NotFinite => "not a finite number",
            Problem::OutOfRange => "outside the supported range",
            Problem::Degenerate => "degenerate (zero length or parallel axes)",
            Problem::UnknownMaterial => "no such material",
            Problem::TooMany => "too many items for the scene",
        };
        write!(f, ": {why}")
    }
}

impl core::error::Error for SceneError {}

/// A renderable scene.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Scene {
    /// The camera (its model is the true model; the planner may render an
    /// approximation of it).
    pub(crate) camera: Camera,
    /// Radial distortion.
    pub(crate) distortion: Distortion,
    /// A calibrated lens (OpenCV's models), in place of the radial
    /// distortion ([`Scene::set_calibrated`]).
    #[cfg(feature = "calibrated")]
    pub(crate) calibrated: Option<Calibrated>,
    /// Output format.
    pub(crate) format: PixelFormat,
    /// Exposure `K`, DN per W/m² of image irradiance.
    pub(crate) exposure: Q,
    /// Ambient term `A` per channel (radiance `ρ·A` is added).
    pub(crate) ambient: [Q; 3],
    /// Background radiance `L_bg` per channel, W/(m²·sr).
    pub(crate) background: [Q; 3],
    /// Materials.
    pub(crate) materials: heapless::Vec<Material, MAX_MATERIALS>,
    /// Primitives.
    pub(crate) primitives: heapless::Vec<Primitive, MAX_PRIMITIVES>,
    /// Lights.
    pub(crate) lights: heapless::Vec<Light, MAX_LIGHTS>,
    /// Pixel-area integration (camera-model.md §7), if the scene asks for
    /// it; without it a pixel is one sample at its centre.
    pub(crate) sampling: Option<Sampling>,
    /// Sensor noise (camera-model.md §9), if the scene asks for it.
    pub(crate) noise: Option<Noise>,
    /// Cast shadows (camera-model.md §6): on unless the scene turns them
    /// off ([`Scene::set_shadows`]) or the build leaves them out.
    pub(crate) shadows: bool,
}

/// Smallest edge-placement error a scene may ask of pixel-area sampling,
/// pixels (16×16 samples a pixel).
pub const MIN_EDGE_ERROR: f64 = 1.0 / 32.0;

/// Pixel-area integration as a scene asks for it (camera-model.md §7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampling {
    /// Largest error the sampling pattern may leave in an edge's placement,
    /// pixels ([`MIN_EDGE_ERROR`] to 0.5): the planner picks the grid from
    /// it (an `n×n` grid places a straight edge within `1/(2n)` px).
    pub edge_error_px: Q,
    /// Spend the grid only on pixels whose corners and centre do not all
    /// see the same primitive and texture cell (docs/sensor.md); `false`:
    /// the grid on every pixel.
    pub adaptive: bool,
}

/// Sensor noise in the EMVA 1288 linear model (camera-model.md §9).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Noise {
    /// Saturation capacity `μ_e,sat`, electrons at `DN_max` (1 to 10⁷).
    pub saturation_e: Q,
    /// Dark noise `σ_d`, electrons rms (0 to 10⁴).
    pub dark_noise_e: Q,
    /// Dark offset `μ_y,dark`, DN (0 to `DN_max`).
    pub dark_offset_dn: Q,
    /// The generator's seed.
    pub seed: u64,
}

/// Checks and converts scene values (f64 in SI units → fixed point).
struct Check {
    item: Item,
}

impl Check {
    fn err(&self, field: &'static str, problem: Problem) -> SceneError {
        SceneError {
            item: self.item,
            field,
            problem,
        }
    }

    fn range(&self, field: &'static str, v: f64, lo: f64, hi: f64) -> Result<f64, SceneError> {
        if !v.is_finite() {
            Err(self.err(field, Problem::NotFinite))
        } else if v < lo || v > hi {
            Err(self.err(field, Problem::OutOfRange))
        } else {
            Ok(v)
        }
    }

    fn q(&self, field: &'static str, v: f64, lo: f64, hi: f64) -> Result<Q, SceneError> {
        self.fixed(field, self.range(field, v, lo, hi)?)
    }

    fn len(&self, field: &'static str, v: f64, lo: f64, hi: f64) -> Result<Len, SceneError> {
        self.fixed(field, self.range(field, v, lo, hi)?)
    }

    /// A unit vector (from [`Check::unit_f64`]) in the stored format.
    fn norm3(&self, field: &'static str, v: [f64; 3]) -> Result<[Norm; 3], SceneError> {
        Ok([
            self.fixed(field, v[0])?,
            self.fixed(field, v[1])?,
            self.fixed(field, v[2])?,
        ])
    }

    /// A checked value in its storage format. The conversion cannot fail
    /// after the checks; checked, it keeps a panic path out of the core all
    /// the same.
    fn fixed<T>(&self, field: &'static str, v: f64) -> Result<T, SceneError>
    where
        T: fixed::traits::Fixed,
        T::Bits: TryFrom<i64>,
    {
        crate::num::from_f64(v).ok_or(self.err(field, Problem::OutOfRange))
    }

    fn point(&self, field: &'static str, p: [f64; 3]) -> Result<WorldPoint, SceneError> {
        Ok(WorldPoint {
            x: self.len(field, p[0], -MAX_EXTENT, MAX_EXTENT)?,
            y: self.len(field, p[1], -MAX_EXTENT, MAX_EXTENT)?,
            z: self.len(field, p[2], -MAX_EXTENT, MAX_EXTENT)?,
        })
    }

    fn unit_f64(&self, field: &'static str, v: [f64; 3]) -> Result<[f64; 3], SceneError> {
        for c in v {
            self.range(field, c, -1e6, 1e6)?;
        }
        let n = norm(v);
        if n < 1e-9 {
            return Err(self.err(field, Problem::Degenerate));
        }
        Ok(div(v, n))
    }

    fn colour(&self, field: &'static str, c: [f64; 3], hi: f64) -> Result<[Q; 3], SceneError> {
        Ok([
            self.q(field, c[0], 0.0, hi)?,
            self.q(field, c[1], 0.0, hi)?,
            self.q(field, c[2], 0.0, hi)?,
        ])
    }
}

/// A checker texture as given: cell size and the `u` direction (projected
/// into the plane), and the odd cells' material.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CheckerSpec {
    /// Cell size, metres.
    pub cell: f64,
    /// Direction of the texture's `u` axis (need not be unit or in-plane).
    pub u_axis: [f64; 3],
    /// Material of the odd cells.
    pub material: u8,
}

/// A primitive's geometry as given (f64, SI units).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub enum ShapeSpec {
    /// Infinite plane.
    Plane {
        /// A point on it.
        point: [f64; 3],
        /// Normal (any length).
        normal: [f64; 3],
    },
    /// Sphere.
    Sphere {
        /// Centre.
        centre: [f64; 3],
        /// Radius.
        radius: f64,
    },
    /// Disc.
    Disc {
        /// Centre.
        centre: [f64; 3],
        /// Normal (any length).
        normal: [f64; 3],
        /// Radius.
        radius: f64,
    },
    /// Rectangle.
    Rectangle {
        /// Centre.
        centre: [f64; 3],
        /// Normal (any length).
        normal: [f64; 3],
        /// Direction of the `u` edges (projected into the plane).
        u_axis: [f64; 3],
        /// Full size along `u` and `v`, metres.
        size: [f64; 2],
    },
}

impl Scene {
    /// The camera (its model is the true model; the planner may render an
    /// approximation of it).
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Radial distortion.
    pub fn distortion(&self) -> &Distortion {
        &self.distortion
    }

    /// The calibrated lens, if the scene gives one.
    #[inline(always)]
    pub fn calibrated(&self) -> Option<&Calibrated> {
        // (A constant `None` where the feature is off: no code follows it.)
        #[cfg(feature = "calibrated")]
        return self.calibrated.as_ref();
        #[cfg(not(feature = "calibrated"))]
        None
    }

    /// Images through a calibrated lens (OpenCV's models) instead of the
    /// radial distortion, which must then be none
    /// ([`crate::geom::error::Error::OutOfRange`]`(Field::Distortion)` otherwise: a lens has one
    /// model).
    #[cfg(feature = "calibrated")]
    pub fn set_calibrated(&mut self, lens: Option<Calibrated>) -> Result<(), crate::geom::error::Error> {
        if lens.is_some() && !self.distortion.is_none() {
            return Err(crate::geom::error::Error::OutOfRange(
                crate::geom::error::Field::Distortion,
            ));
        }
        self.calibrated = lens;
        Ok(())
    }

    /// Output format.
    pub fn format(&self) -> PixelFormat {
        self.format
    }

    /// Exposure `K`, DN per W/m² of image irradiance.
    pub fn exposure(&self) -> Q {
        self.exposure
    }

    /// Ambient term `A` per channel (radiance `ρ·A` is added).
    pub fn ambient(&self) -> [Q; 3] {
        self.ambient
    }

    /// Background radiance `L_bg` per channel, W/(m²·sr).
    pub fn background(&self) -> [Q; 3] {
        self.background
    }

    /// Materials, in the order they were added (a primitive's `material`
    /// is an index here).
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// Primitives, in the order they were added.
    pub fn primitives(&self) -> &[Primitive] {
        &self.primitives
    }

    /// Lights, in the order they were added.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// Pixel-area integration (camera-model.md §7), if the scene asks for
    /// it; without it a pixel is one sample at its centre.
    pub fn sampling(&self) -> Option<Sampling> {
        self.sampling
    }

    /// Sensor noise (camera-model.md §9), if the scene asks for it.
    pub fn noise(&self) -> Option<Noise> {
        self.noise
    }

    /// Whether lights cast shadows (camera-model.md §6; on by default).
    pub fn shadows(&self) -> bool {
        self.shadows
    }

    /// Turns cast shadows on or off (the scene file's
    /// `environment.shadows`). Off, every light reaches every point that
    /// faces it, as in a scene without occluders. A build without the
    /// `shadows` feature keeps them off (its data reader refuses a scene
    /// that asks for them).
    pub fn set_shadows(&mut self, on: bool) {
        self.shadows = on && cfg!(feature = "shadows");
    }

    /// An empty scene (no materials, primitives or lights) for `camera`.
    ///
    /// `exposure` is `K` in DN per W/m² (0 to 10⁹); `ambient` and
    /// `background` per channel in [0, [`MAX_RADIOMETRIC`]].
    pub fn new(
        camera: Camera,
        distortion: Distortion,
        format: PixelFormat,
        exposure: f64,
        ambient: [f64; 3],
        background: [f64; 3],
    ) -> Result<Scene, SceneError> {
        let (exposure, ambient, background) = Scene::check(&camera, format, exposure, ambient, background)?;
        Ok(Scene::of(
            camera,
            distortion,
            format,
            (exposure, ambient, background),
        ))
    }

    /// The scene [`Scene::new`] makes of checked values (`exposure, ambient,
    /// background` from [`Scene::check`]), with nothing in it. Inlined, so
    /// that it is built where it is stored (a scene is 4.7 KB).
    #[inline(always)]
    pub(crate) fn of(
        camera: Camera,
        distortion: Distortion,
        format: PixelFormat,
        head: (Q, [Q; 3], [Q; 3]),
    ) -> Scene {
        Scene {
            camera,
            distortion,
            #[cfg(feature = "calibrated")]
            calibrated: None,
            format,
            exposure: head.0,
            ambient: head.1,
            background: head.2,
            materials: heapless::Vec::new(),
            primitives: heapless::Vec::new(),
            lights: heapless::Vec::new(),
            sampling: None,
            noise: None,
            shadows: cfg!(feature = "shadows"),
        }
    }

    /// [`Scene::new`]'s checks: the values it takes, converted.
    pub(crate) fn check(
        camera: &Camera,
        format: PixelFormat,
        exposure: f64,
        ambient: [f64; 3],
        background: [f64; 3],
    ) -> Result<(Q, [Q; 3], [Q; 3]), SceneError> {
        let c = Check { item: Item::Scene };
        if let PixelFormat::Gray16 { bits } = format {
            if !(9..=16).contains(&bits) {
                return Err(c.err("output.bits", Problem::OutOfRange));
            }
        }
        let t = camera.extrinsics.translation().to_f64();
        for v in t {
            if v.abs() > MAX_EXTENT {
                return Err(c.err("camera.pose", Problem::OutOfRange));
            }
        }
        Ok((
            c.q("output.exposure", exposure, 0.0, 1e9)?,
            c.colour("environment.ambient", ambient, MAX_RADIOMETRIC)?,
            c.colour("environment.background", background, MAX_RADIOMETRIC)?,
        ))
    }

    /// Moves the camera (`T` within ±[`MAX_EXTENT`] m per coordinate, as
    /// [`Scene::new`] checks). Refused, the scene is unchanged.
    pub fn set_pose(&mut self, pose: crate::Extrinsics) -> Result<(), SceneError> {
        let c = Check { item: Item::Scene };
        if pose.translation().to_f64().iter().any(|v| v.abs() > MAX_EXTENT) {
            return Err(c.err("camera.pose", Problem::OutOfRange));
        }
        self.camera.extrinsics = pose;
        Ok(())
    }

    /// Sets the exposure `K`, DN per W/m² (0 to 10⁹). Refused, the scene is
    /// unchanged.
    pub fn set_exposure(&mut self, k: f64) -> Result<(), SceneError> {
        let c = Check { item: Item::Scene };
        self.exposure = c.q("output.exposure", k, 0.0, 1e9)?;
        Ok(())
    }

    /// Asks for pixel-area integration with edges placed within
    /// `edge_error_px` ([`MIN_EDGE_ERROR`] to 0.5 px); `adaptive` as
    /// [`Sampling::adaptive`].
    pub fn set_sampling(&mut self, edge_error_px: f64, adaptive: bool) -> Result<(), SceneError> {
        let c = Check { item: Item::Scene };
        self.sampling = Some(Sampling {
            edge_error_px: c.q("sampling.edge_error", edge_error_px, MIN_EDGE_ERROR, 0.5)?,
            adaptive,
        });
        Ok(())
    }

    /// Asks for sensor noise: saturation capacity (e⁻), dark noise (e⁻ rms),
    /// dark offset (DN of the format's first channel) and seed.
    pub fn set_noise(
        &mut self,
        saturation_e: f64,
        dark_noise_e: f64,
        dark_offset_dn: f64,
        seed: u64,
    ) -> Result<(), SceneError> {
        let c = Check { item: Item::Scene };
        self.noise = Some(Noise {
            saturation_e: c.q("noise.saturation", saturation_e, 1.0, 1e7)?,
            dark_noise_e: c.q("noise.dark_noise", dark_noise_e, 0.0, 1e4)?,
            dark_offset_dn: c.q(
                "noise.dark_offset",
                dark_offset_dn,
                0.0,
                self.format.dn_max(0) as f64,
            )?,
            seed,
        });
        Ok(())
    }

    /// Adds a material; returns its index.
    pub fn add_material(
        &mut self,
        albedo: [f64; 3],
        specular: [f64; 3],
        mix: f64,
        exponent: u16,
    ) -> Result<u8, SceneError> {
        let i = self.materials.len() as u8;
        let c = Check {
            item: Item::Material(i),
        };
        if exponent > MAX_EXPONENT {
            return Err(c.err("exponent", Problem::OutOfRange));
        }
        let m = Material {
            albedo: c.colour("albedo", albedo, 1.0)?,
            specular: c.colour("specular", specular, 1.0)?,
            mix: c.q("mix", mix, 0.0, 1.0)?,
            exponent,
        };
        self.materials
            .push(m)
            .map_err(|_| Check { item: Item::Scene }.err("materials", Problem::TooMany))?;
        Ok(i)
    }

    /// Adds a primitive; returns its index.
    pub fn add_primitive(
        &mut self,
        shape: ShapeSpec,
        material: u8,
        checker: Option<CheckerSpec>,
    ) -> Result<u8, SceneError> {
        let i = self.primitives.len() as u8;
        let c = Check {
            item: Item::Primitive(i),
        };
        let known = |m: u8| (m as usize) < self.materials.len();
        if !known(material) {
            return Err(c.err("material", Problem::UnknownMaterial));
        }
        let (shape, plane_normal) = match shape {
            ShapeSpec::Plane { point, normal } => {
                let n = c.unit_f64("normal", normal)?;
                (
                    Shape::Plane {
                        point: c.point("point", point)?,
                        normal: c.norm3("normal", n)?,
                    },
                    Some(n),
                )
            }
            ShapeSpec::Sphere { centre, radius } => (
                Shape::Sphere {
                    centre: c.point("centre", centre)?,
                    radius: c.len("radius", radius, MIN_SIZE, MAX_EXTENT)?,
                },
                None,
            ),
            ShapeSpec::Disc {
                centre,
                normal,
                radius,
            } => {
                let n = c.unit_f64("normal", normal)?;
                (
                    Shape::Disc {
                        centre: c.point("centre", centre)?,
                        normal: c.norm3("normal", n)?,
                        radius: c.len("radius", radius, MIN_SIZE, MAX_EXTENT)?,
                    },
                    Some(n),
                )
            }
            ShapeSpec::Rectangle {
                centre,
                normal,
                u_axis,
                size,
            } => {
                let n = c.unit_f64("normal", normal)?;
                let (u, v) = in_plane_axes(&c, "u_axis", n, u_axis)?;
                (
                    Shape::Rectangle {
                        centre: c.point("centre", centre)?,
                        u_axis: c.norm3("u_axis", u)?,
                        v_axis: c.norm3("u_axis", v)?,
                        half: [
                            c.len("size", size[0] / 2.0, MIN_SIZE, MAX_EXTENT)?,
                            c.len("size", size[1] / 2.0, MIN_SIZE, MAX_EXTENT)?,
                        ],
                    },
                    Some(n),
                )
            }
        };
        let checker = match (checker, plane_normal) {
            (None, _) => None,
            (Some(_), None) => return Err(c.err("checker", Problem::Degenerate)),
            (Some(k), Some(n)) => {
                if !known(k.material) {
                    return Err(c.err("checker.material", Problem::UnknownMaterial));
                }
                let (u, v) = in_plane_axes(&c, "checker.u_axis", n, k.u_axis)?;
                Some(Checker {
                    cell: c.len("checker.cell", k.cell, MIN_SIZE, MAX_EXTENT)?,
                    u_axis: c.norm3("checker.u_axis", u)?,
                    v_axis: c.norm3("checker.u_axis", v)?,
                    material: k.material,
                })
            }
        };
        self.primitives
            .push(Primitive {
                shape,
                material,
                checker,
            })
            .map_err(|_| Check { item: Item::Scene }.err("primitives", Problem::TooMany))?;
        Ok(i)
    }

    /// Adds a point light at `position` with intensity per channel (W/sr).
    pub fn add_point_light(&mut self, position: [f64; 3], intensity: [f64; 3]) -> Result<u8, SceneError> {
        let i = self.lights.len() as u8;
        let c = Check { item: Item::Light(i) };
        let l = Light::Point {
            position: c.point("position", position)?,
            intensity: c.colour("intensity", intensity, MAX_RADIOMETRIC)?,
        };
        self.lights
            .push(l)
            .map_err(|_| Check { item: Item::Scene }.err("lights", Problem::TooMany))?;
        Ok(i)
    }

    /// Adds a directional light: `towards` points to the light; irradiance
    /// per channel (W/m²).
    pub fn add_directional_light(
        &mut self,
        towards: [f64; 3],
        irradiance: [f64; 3],
    ) -> Result<u8, SceneError> {
        let i = self.lights.len() as u8;
        let c = Check { item: Item::Light(i) };
        let l = Light::Directional {
            towards: c.norm3("direction", c.unit_f64("direction", towards)?)?,
            irradiance: c.colour("irradiance", irradiance, MAX_RADIOMETRIC)?,
        };
        self.lights
            .push(l)
            .map_err(|_| Check { item: Item::Scene }.err("lights", Problem::TooMany))?;
        Ok(i)
    }

    /// True if any material has a specular lobe.
    pub fn has_specular(&self) -> bool {
        self.materials.iter().any(Material::has_specular)
    }
}

/// Unit `u` (the given direction projected into the plane of unit normal
/// `n`) and `v = n × u`.
fn in_plane_axes(
    c: &Check,
    field: &'static str,
    n: [f64; 3],
    u: [f64; 3],
) -> Result<([f64; 3], [f64; 3]), SceneError> {
    let u = c.unit_f64(field, u)?;
    let d = dot(u, n);
    let p = [u[0] - d * n[0], u[1] - d * n[1], u[2] - d * n[2]];
    let pn = norm(p);
    if pn < 1e-6 {
        return Err(c.err(field, Problem::Degenerate));
    }
    let u = div(p, pn);
    Ok((u, cross(n, u)))
}
