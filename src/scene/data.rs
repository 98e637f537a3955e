//! A scene as data (`docs/wire.md`, "Scene data"): every value a scene
//! file gives, in its units (f64, SI), as one postcard-encodable value. The
//! firmware holds its scenes as these blobs (made from `scenes/` at build
//! time) and receives new ones over the link (`LoadScene`); host-sim makes
//! its scenes through the same [`load`] from the same bytes, so a camera
//! and the host build the same [`Scene`].
//!
//! Decoding needs no heap: the lists are bounded by the scene's own limits
//! ([`MAX_MATERIALS`], [`MAX_PRIMITIVES`], [`MAX_LIGHTS`]), and an encoded
//! scene is at most [`MAX_SCENE_DATA`] bytes.

#[cfg(feature = "calibrated")]
use crate::geom::calibrated::Calibrated;
use crate::geom::distortion::Distortion;
use crate::geom::lens::{Aperture, LensConfig};
use crate::scene::{
    CheckerSpec, Item, PixelFormat, Problem, Scene, SceneError, ShapeSpec, MAX_LIGHTS, MAX_MATERIALS,
    MAX_PRIMITIVES, Q,
};
use crate::{Camera, Error, Extrinsics, Field, IntrinsicsConfig, Model};
use core::fmt;
use serde::Serialize;

/// The largest encoded [`SceneData`] with at most `materials`,
/// `primitives` and `lights` (each at most 127), bytes: every value given
/// per channel, every shape a rectangle with a checker, every option
/// given, every varint at its longest (tested): 396 bytes of camera,
/// format, exposure, ambient, background, sampling, noise, lens, shadows
/// and list lengths; 62 a material (an RGB albedo and lobe), 124 a primitive (a
/// checkered rectangle), 50 a light.
pub const fn max_bytes(materials: usize, primitives: usize, lights: usize) -> usize {
    396 + 62 * materials + 124 * primitives + 50 * lights
}

/// The largest encoded [`SceneData`] this build holds ([`max_bytes`] of
/// its capacities): what a camera's upload buffer needs.
pub const MAX_SCENE_DATA: usize = max_bytes(MAX_MATERIALS, MAX_PRIMITIVES, MAX_LIGHTS);

/// A scene as data.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneData {
    /// The camera.
    pub camera: CameraData,
    /// Output format (`Gray16` bits 9 to 16).
    pub format: FormatData,
    /// Exposure `K`, DN per W/m² (0 to 10⁹).
    pub exposure: f64,
    /// Ambient `A`.
    pub ambient: Colour,
    /// Background radiance `L_bg`, W/(m²·sr).
    pub background: Colour,
    /// Materials, referred to by index.
    pub materials: heapless::Vec<MaterialData, MAX_MATERIALS>,
    /// Primitives.
    pub primitives: heapless::Vec<PrimitiveData, MAX_PRIMITIVES>,
    /// Lights.
    pub lights: heapless::Vec<LightData, MAX_LIGHTS>,
    /// Pixel-area integration (camera-model.md §7), if asked for.
    pub sampling: Option<SamplingData>,
    /// Sensor noise (camera-model.md §9), if asked for.
    pub noise: Option<NoiseData>,
    /// A calibrated lens in place of `camera.distortion`, if given.
    pub lens: Option<LensData>,
    /// Cast shadows (camera-model.md §6; `environment.shadows`).
    pub shadows: bool,
}

/// A calibrated lens (geom::calibrated): OpenCV's coefficients in its
/// order.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum LensData {
    /// Tag 0: OpenCV's standard model, `[k1, k2, p1, p2, k3, k4, k5, k6,
    /// s1, s2, s3, s4]` (a shorter calibration's missing terms 0).
    OpenCv([f64; 12]),
    /// Tag 1: OpenCV's fisheye model, `[k1, k2, k3, k4]`.
    Fisheye([f64; 4]),
}

/// The camera (`[camera]` of a scene file).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CameraData {
    /// Sensor width, pixels.
    pub width: u16,
    /// Sensor height, pixels.
    pub height: u16,
    /// Focal length `f`, metres.
    pub focal_length: f64,
    /// Pixel pitch `(s_x, s_y)`, metres.
    pub pitch: [f64; 2],
    /// Principal point, pixels (`None`: the sensor centre).
    pub principal_point: Option<[f64; 2]>,
    /// `m` of an orthographic camera (`None`: perspective).
    pub orthographic_scale: Option<f64>,
    /// The aperture.
    pub aperture: Aperture,
    /// Focus distance, metres.
    pub focus_distance: f64,
    /// Tolerable blur diameter, metres.
    pub tolerable_blur: f64,
    /// `[k1, k2]` (`None`: no distortion).
    pub distortion: Option<[f64; 2]>,
    /// The pose's `R`, row by row: the camera's axes in world coordinates
    /// (a scene file's look-at or yaw-pitch-roll pose is sent as the `R`
    /// the core makes of it: [`crate::geom::extrinsics::look_at_matrix`],
    /// [`crate::geom::extrinsics::yaw_pitch_roll_matrix`]).
    pub rotation: [[f64; 3]; 3],
    /// The pose's `T`, the centre of projection, metres.
    pub position: [f64; 3],
}

/// Output pixel format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum FormatData {
    /// Tag 0: one byte a pixel.
    Gray8,
    /// Tag 1: two bytes a pixel, `bits` significant (9 to 16).
    Gray16 {
        /// Significant bits.
        bits: u8,
    },
    /// Tag 2: 5-6-5 colour.
    Rgb565,
}

/// A value per channel, as a scene file gives it: one for every channel,
/// or one each.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Colour {
    /// Tag 0: the same in every channel.
    Gray(f64),
    /// Tag 1: red, green, blue.
    Rgb([f64; 3]),
}

impl Colour {
    /// Per channel.
    pub fn rgb(self) -> [f64; 3] {
        match self {
            Colour::Gray(v) => [v; 3],
            Colour::Rgb(c) => c,
        }
    }
}

/// A material (`[[materials]]`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MaterialData {
    /// Lambertian albedo, 0 to 1.
    pub albedo: Colour,
    /// The specular lobe (`None`: Lambertian, i.e. specular albedo 0,
    /// mix 1, exponent 0).
    pub specular: Option<SpecularData>,
}

/// A material's specular lobe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SpecularData {
    /// Specular albedo, 0 to 1.
    pub albedo: Colour,
    /// Mix `n`, 0 to 1 (1: Lambertian).
    pub mix: f64,
    /// Phong exponent, 0 to 1000.
    pub exponent: u16,
}

/// A primitive (`[[primitives]]`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PrimitiveData {
    /// Geometry.
    pub shape: ShapeSpec,
    /// Material index.
    pub material: u8,
    /// Checker texture (planar shapes).
    pub checker: Option<CheckerSpec>,
}

/// A light (`[[lights]]`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum LightData {
    /// Tag 0: a point light.
    Point {
        /// Position, metres.
        position: [f64; 3],
        /// Intensity, W/sr.
        intensity: Colour,
    },
    /// Tag 1: a directional light.
    Directional {
        /// Direction towards the light.
        direction: [f64; 3],
        /// Irradiance, W/m².
        irradiance: Colour,
    },
}

/// `[sampling]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SamplingData {
    /// Largest edge-placement error, pixels (1/32 to 0.5).
    pub edge_error: f64,
    /// The grid only where a pixel's corners and centre disagree.
    pub adaptive: bool,
}

/// `[noise]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NoiseData {
    /// Saturation capacity, electrons (1 to 10⁷).
    pub saturation: f64,
    /// Dark noise, electrons rms (0 to 10⁴).
    pub dark_noise: f64,
    /// Dark offset, DN (0 to full scale).
    pub dark_offset: f64,
    /// The generator's seed.
    pub seed: u32,
}

/// Why scene data was refused; each names the value as the scene format
/// spells it (`docs/scenes.md`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataError {
    /// Not the canonical postcard encoding of a [`SceneData`] (unknown tag,
    /// a list longer than the scene holds, too short, trailing bytes, or an
    /// over-long varint).
    Malformed,
    /// A camera value: what the camera's constructor said (its key:
    /// `camera_key`).
    Camera(Error),
    /// A scene value.
    Scene(SceneError),
    /// A stage this build leaves out (`sampling`, `noise`: the core's
    /// `sensor` feature).
    NotBuilt {
        /// The key.
        key: &'static str,
    },
}

impl DataError {
    /// The item and the key of the value at fault (`Item::Scene` and
    /// `"scene"` for malformed data).
    pub fn field(&self) -> (Item, &'static str) {
        match self {
            DataError::Malformed => (Item::Scene, "scene"),
            DataError::Camera(e) => (Item::Scene, camera_key(e.field())),
            DataError::NotBuilt { key } => (Item::Scene, key),
            DataError::Scene(e) => (e.item, e.field),
        }
    }
}

impl fmt::Display for DataError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DataError::Malformed => write!(f, "scene: not the canonical encoding of scene data"),
            DataError::Camera(e) => {
                write!(f, "{}: ", camera_key(e.field()))?;
                e.why(f)
            }
            DataError::Scene(e) => e.fmt(f),
            DataError::NotBuilt { key } => write!(
                f,
                "{key}: not in this build (a feature of the core it leaves out)"
            ),
        }
    }
}

impl core::error::Error for DataError {}

impl From<SceneError> for DataError {
    fn from(e: SceneError) -> Self {
        DataError::Scene(e)
    }
}

impl From<FormatData> for PixelFormat {
    fn from(f: FormatData) -> Self {
        match f {
            FormatData::Gray8 => PixelFormat::Gray8,
            FormatData::Gray16 { bits } => PixelFormat::Gray16 { bits },
            FormatData::Rgb565 => PixelFormat::Rgb565,
        }
    }
}

impl From<PixelFormat> for FormatData {
    fn from(f: PixelFormat) -> Self {
        match f {
            PixelFormat::Gray8 => FormatData::Gray8,
            PixelFormat::Gray16 { bits } => FormatData::Gray16 { bits },
            PixelFormat::Rgb565 => FormatData::Rgb565,
        }
    }
}

impl SceneData {
    /// Encodes the scene into `buf` (postcard; at most [`MAX_SCENE_DATA`]
    /// bytes); `None` if it does not fit.
    pub fn encode<'b>(&self, buf: &'b mut [u8]) -> Option<&'b mut [u8]> {
        postcard::to_slice(self, buf).ok()
    }
}

/// Builds the scene encoded in `bytes` (a [`SceneData`]: exactly one
/// canonical encoding, nothing after it), checking every value against the
/// ranges of `docs/scenes.md` as it is read; the first value refused is
/// named. Read and built in one pass, with no [`SceneData`] in memory: the
/// one way a scene is made from data, on the host and on a camera.
#[inline(always)]
pub fn load(bytes: &[u8]) -> Result<Scene, DataError> {
    load_as(bytes, |e| e)
}

/// [`load`] with its error mapped by `refused`: built in the value
/// returned whatever the error type (one scene on the stack, not a scene
/// and a copy of it).
#[inline(never)]
pub(crate) fn load_as<E>(bytes: &[u8], refused: impl Fn(DataError) -> E) -> Result<Scene, E> {
    let mut r = Reader(bytes);
    let (camera, distortion, format, head) = head(&mut r).map_err(&refused)?;
    let mut scene = Ok(Scene::of(camera, distortion, format, head));
    if let Ok(s) = &mut scene {
        fill(&mut r, s).map_err(&refused)?;
    }
    scene
}

/// The scene's camera, distortion, format and its head's values
/// (exposure, ambient, background), read and checked.
#[allow(clippy::type_complexity)]
#[inline(always)]
fn head(r: &mut Reader) -> Result<(Camera, Distortion, PixelFormat, (Q, [Q; 3], [Q; 3])), DataError> {
    const M: DataError = DataError::Malformed;
    let c = r.camera().ok_or(M)?;
    let cam = DataError::Camera;
    let intr = IntrinsicsConfig {
        focal_length: c.focal_length,
        pitch: (c.pitch[0], c.pitch[1]),
        size: (c.width, c.height),
        principal_point: c.principal_point.map(|[x, y]| (x, y)),
    };
    let pose = Extrinsics::from_matrix(c.rotation, c.position).map_err(cam)?;
    let model = match c.orthographic_scale {
        None => Model::Perspective,
        Some(m) => Model::orthographic(m).map_err(cam)?,
    };
    let lens = LensConfig {
        aperture: c.aperture,
        focus_distance: c.focus_distance,
        tolerable_blur: c.tolerable_blur,
    };
    let camera = Camera::new(&intr, &lens, pose, model).map_err(cam)?;
    let distortion = match c.distortion {
        Some([k1, k2]) => Distortion::new(k1, k2).map_err(cam)?,
        None => Distortion::NONE,
    };
    let format = r.format().ok_or(M)?;
    let (exposure, ambient, background) = (r.f64().ok_or(M)?, r.colour().ok_or(M)?, r.colour().ok_or(M)?);
    let format: PixelFormat = format.into();
    let gray = format.channels() == 1;
    one_channel(gray, &ambient, Item::Scene, "environment.ambient")?;
    one_channel(gray, &background, Item::Scene, "environment.background")?;
    let head = Scene::check(&camera, format, exposure, ambient.rgb(), background.rgb())?;
    Ok((camera, distortion, format, head))
}

/// A colour triple where the format has one channel is refused, as a scene
/// file's is: a gray frame would show its red channel alone.
fn one_channel(gray: bool, c: &Colour, item: Item, field: &'static str) -> Result<(), DataError> {
    match c {
        Colour::Rgb(_) if gray => Err(DataError::Scene(SceneError {
            item,
            field,
            problem: Problem::OutOfRange,
        })),
        _ => Ok(()),
    }
}

/// Reads a scene's materials, primitives, lights, sampling and noise into
/// `s`, checking each as it is added.
fn fill(r: &mut Reader, s: &mut Scene) -> Result<(), DataError> {
    const M: DataError = DataError::Malformed;
    let gray = s.format.channels() == 1;
    for i in 0..r.len().ok_or(M)? {
        let m = r.material().ok_or(M)?;
        let item = Item::Material(i as u8);
        one_channel(gray, &m.albedo, item, "albedo")?;
        if let Some(sp) = &m.specular {
            one_channel(gray, &sp.albedo, item, "specular")?;
        }
        let (specular, mix, exponent) = m
            .specular
            .map_or(([0.0; 3], 1.0, 0), |s| (s.albedo.rgb(), s.mix, s.exponent));
        s.add_material(m.albedo.rgb(), specular, mix, exponent)?;
    }
    for _ in 0..r.len().ok_or(M)? {
        let p = r.primitive().ok_or(M)?;
        s.add_primitive(p.shape, p.material, p.checker)?;
    }
    for i in 0..r.len().ok_or(M)? {
        let item = Item::Light(i as u8);
        match r.light().ok_or(M)? {
            LightData::Point { position, intensity } => {
                one_channel(gray, &intensity, item, "intensity")?;
                s.add_point_light(position, intensity.rgb())?
            }
            LightData::Directional {
                direction,
                irradiance,
            } => {
                one_channel(gray, &irradiance, item, "irradiance")?;
                s.add_directional_light(direction, irradiance.rgb())?
            }
        };
    }
    // Without the `sensor` feature nothing renders them: refused here,
    // and the build carries no code for them.
    if let Some(sm) = r.option(Reader::sampling).ok_or(M)? {
        #[cfg(feature = "sensor")]
        s.set_sampling(sm.edge_error, sm.adaptive)?;
        #[cfg(not(feature = "sensor"))]
        {
            let _ = sm;
            return Err(DataError::NotBuilt { key: "sampling" });
        }
    }
    if let Some(n) = r.option(Reader::noise).ok_or(M)? {
        #[cfg(feature = "sensor")]
        s.set_noise(n.saturation, n.dark_noise, n.dark_offset, u64::from(n.seed))?;
        #[cfg(not(feature = "sensor"))]
        {
            let _ = n;
            return Err(DataError::NotBuilt { key: "noise" });
        }
    }
    #[cfg(feature = "calibrated")]
    if let Some(l) = r.option(Reader::lens).ok_or(M)? {
        let lens = match l {
            LensData::OpenCv(c) => Calibrated::opencv(c),
            LensData::Fisheye(c) => Calibrated::fisheye(c),
        };
        let lens = lens.map_err(DataError::Camera)?;
        s.set_calibrated(Some(lens)).map_err(DataError::Camera)?;
    }
    // Without the feature, a lens is refused unread.
    #[cfg(not(feature = "calibrated"))]
    if r.bool().ok_or(M)? {
        return Err(DataError::NotBuilt {
            key: "camera.calibration",
        });
    }
    let shadows = r.bool().ok_or(M)?;
    if shadows && cfg!(not(feature = "shadows")) {
        return Err(DataError::NotBuilt {
            key: "environment.shadows",
        });
    }
    s.set_shadows(shadows);
    if !r.0.is_empty() {
        return Err(M);
    }
    Ok(())
}

/// The scene-file key of a camera constructor's field (the core names its
/// own parameters: `pitch_x` is the file's `camera.pitch`), the pose given
/// as `R` and `T`.
pub(crate) fn camera_key(field: Field) -> &'static str {
    match field {
        Field::FocalLength => "camera.focal_length",
        Field::PitchX | Field::PitchY => "camera.pitch",
        Field::Width => "camera.width",
        Field::Height => "camera.height",
        Field::PrincipalX | Field::PrincipalY => "camera.principal_point",
        Field::Rotation => "camera.pose.rotation",
        Field::Translation => "camera.pose.position",
        Field::Angle => "camera.pose.yaw_pitch_roll",
        Field::Target => "camera.pose.target",
        Field::Up => "camera.pose.up",
        Field::Aperture => "camera.aperture",
        Field::FNumber => "camera.f_number",
        Field::FocusDistance => "camera.focus_distance",
        Field::TolerableBlur => "camera.tolerable_blur",
        Field::OrthographicScale => "camera.orthographic_scale",
        Field::Distortion => "camera.distortion",
        Field::Calibrated => "camera.calibration",
        Field::MeanDepth | Field::Point => "camera",
    }
}

/// Reads postcard's encoding of a [`SceneData`] (what `serde` derives for
/// the types above, `docs/wire.md` "Scene data"): structs and arrays as
/// their fields in order, enums as a varint tag and the variant's fields,
/// options as a byte 0 or 1 and the value, lists as a varint length and the
/// items, f64 as 8 bytes little-endian, u8 as a byte, u16 and u32 as
/// canonical (shortest) varints, bool as a byte 0 or 1. Written out rather
/// than derived: serde's derived decoder and the canonical check took
/// 5.9 KB of flash, this 3.4 KB with building included, and the 64 KiB
/// size build had 0.6 KB spare (`tests/scene_data.rs` checks it against
/// postcard's encoder on arbitrary scenes). `None` on anything else.
struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn byte(&mut self) -> Option<u8> {
        let (&b, rest) = self.0.split_first()?;
        self.0 = rest;
        Some(b)
    }

    /// Out of line: in line at each of the scene's numbers it cost 0.5 KB
    /// of flash (M3).
    #[inline(never)]
    fn f64(&mut self) -> Option<f64> {
        let (b, rest) = self.0.split_first_chunk::<8>()?;
        self.0 = rest;
        Some(f64::from_le_bytes(*b))
    }

    fn f64s<const N: usize>(&mut self) -> Option<[f64; N]> {
        let mut v = [0.0; N];
        for x in &mut v {
            *x = self.f64()?;
        }
        Some(v)
    }

    /// A canonical varint of at most `max`.
    fn varint(&mut self, max: u32) -> Option<u32> {
        let mut v: u32 = 0;
        for i in 0..5 {
            let b = self.byte()?;
            if i == 4 && b > 0x0f {
                return None;
            }
            v |= u32::from(b & 0x7f) << (7 * i);
            if b & 0x80 == 0 {
                // Shortest form: no final zero group after the first.
                return (v <= max && (i == 0 || b != 0)).then_some(v);
            }
        }
        None
    }

    fn bool(&mut self) -> Option<bool> {
        match self.byte()? {
            0 => Some(false),
            1 => Some(true),
            _ => None,
        }
    }

    fn option<T>(&mut self, f: impl FnOnce(&mut Self) -> Option<T>) -> Option<Option<T>> {
        match self.bool()? {
            false => Some(None),
            true => f(self).map(Some),
        }
    }

    /// A list's length (the scene's builders refuse more items than it
    /// holds).
    fn len(&mut self) -> Option<u32> {
        self.varint(u32::MAX)
    }

    fn format(&mut self) -> Option<FormatData> {
        Some(match self.varint(2)? {
            0 => FormatData::Gray8,
            1 => FormatData::Gray16 { bits: self.byte()? },
            _ => FormatData::Rgb565,
        })
    }

    #[inline(never)]
    fn colour(&mut self) -> Option<Colour> {
        Some(match self.varint(1)? {
            0 => Colour::Gray(self.f64()?),
            _ => Colour::Rgb(self.f64s()?),
        })
    }

    fn material(&mut self) -> Option<MaterialData> {
        Some(MaterialData {
            albedo: self.colour()?,
            specular: self.option(|r| {
                Some(SpecularData {
                    albedo: r.colour()?,
                    mix: r.f64()?,
                    exponent: r.varint(u16::MAX.into())? as u16,
                })
            })?,
        })
    }

    fn light(&mut self) -> Option<LightData> {
        let point = self.varint(1)? == 0;
        let (a, b) = (self.f64s()?, self.colour()?);
        Some(match point {
            true => LightData::Point {
                position: a,
                intensity: b,
            },
            false => LightData::Directional {
                direction: a,
                irradiance: b,
            },
        })
    }

    fn sampling(&mut self) -> Option<SamplingData> {
        Some(SamplingData {
            edge_error: self.f64()?,
            adaptive: self.bool()?,
        })
    }

    fn noise(&mut self) -> Option<NoiseData> {
        Some(NoiseData {
            saturation: self.f64()?,
            dark_noise: self.f64()?,
            dark_offset: self.f64()?,
            seed: self.varint(u32::MAX)?,
        })
    }

    #[cfg(feature = "calibrated")]
    fn lens(&mut self) -> Option<LensData> {
        Some(match self.varint(1)? {
            0 => LensData::OpenCv(self.f64s()?),
            _ => LensData::Fisheye(self.f64s()?),
        })
    }

    fn camera(&mut self) -> Option<CameraData> {
        let side = u16::MAX.into();
        Some(CameraData {
            width: self.varint(side)? as u16,
            height: self.varint(side)? as u16,
            focal_length: self.f64()?,
            pitch: self.f64s()?,
            principal_point: self.option(Self::f64s)?,
            orthographic_scale: self.option(Self::f64)?,
            aperture: match self.varint(1)? {
                0 => Aperture::Diameter(self.f64()?),
                _ => Aperture::FNumber(self.f64()?),
            },
            focus_distance: self.f64()?,
            tolerable_blur: self.f64()?,
            distortion: self.option(Self::f64s)?,
            rotation: [self.f64s()?, self.f64s()?, self.f64s()?],
            position: self.f64s()?,
        })
    }

    fn primitive(&mut self) -> Option<PrimitiveData> {
        let shape = match self.varint(3)? {
            0 => ShapeSpec::Plane {
                point: self.f64s()?,
                normal: self.f64s()?,
            },
            1 => ShapeSpec::Sphere {
                centre: self.f64s()?,
                radius: self.f64()?,
            },
            2 => ShapeSpec::Disc {
                centre: self.f64s()?,
                normal: self.f64s()?,
                radius: self.f64()?,
            },
            _ => ShapeSpec::Rectangle {
                centre: self.f64s()?,
                normal: self.f64s()?,
                u_axis: self.f64s()?,
                size: self.f64s()?,
            },
        };
        Some(PrimitiveData {
            shape,
            material: self.byte()?,
            checker: self.option(|r| {
                Some(CheckerSpec {
                    cell: r.f64()?,
                    u_axis: r.f64s()?,
                    material: r.byte()?,
                })
            })?,
        })
    }
}
