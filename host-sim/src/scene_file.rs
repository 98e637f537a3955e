//! Scene files (`docs/scenes.md`): TOML, parsed with serde, unknown keys
//! rejected. One parsed [`SceneDesc`] builds both the core's fixed-point
//! scene and the reference's f64 scene, so both render the same input.

use hilcam::geom::lens::Aperture;
use hilcam::scene::data::{
    CameraData, MaterialData, NoiseData, PrimitiveData, SamplingData, SceneData, SpecularData,
};
use hilcam::scene::{CheckerSpec, PixelFormat, Scene, ShapeSpec, MAX_LIGHTS, MAX_MATERIALS, MAX_PRIMITIVES};
use serde::Deserialize;
use std::path::Path;

mod camera;
pub use camera::{CameraDesc, Pair, Pose, PoseDesc};

/// A scene file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    /// A short name.
    pub name: String,
    /// Output format and exposure.
    pub output: Output,
    /// The camera.
    pub camera: CameraDesc,
    /// Ambient and background.
    #[serde(default)]
    pub environment: Environment,
    /// Materials, referred to by name.
    pub materials: Vec<MaterialDesc>,
    /// Lights.
    #[serde(default)]
    pub lights: Vec<LightEntry>,
    /// Primitives.
    pub primitives: Vec<PrimitiveDesc>,
    /// Pixel-area integration (camera-model.md §7); without it, the
    /// sensor's default ([`SamplingDesc::DEFAULT`]: edges within 1/8 px).
    /// One sample at each pixel's centre is `edge_error = 0.5`.
    #[serde(default = "SamplingDesc::default_some")]
    pub sampling: Option<SamplingDesc>,
    /// Sensor noise (camera-model.md §9); off without it.
    #[serde(default)]
    pub noise: Option<NoiseDesc>,
    /// `[[trajectory]]`: timed keyframes of the camera (`t` s, `position`
    /// m, `quaternion` `[w, x, y, z]` of the camera-to-world rotation), for
    /// runs that produce a sequence (`host-sim drive`); the pose above is
    /// the still camera's.
    #[serde(default)]
    pub trajectory: Vec<crate::trajectory::Keyframe>,
}

/// Longest scene `name`, characters.
pub const MAX_NAME: usize = 64;

/// A scene's `name` names files (`hil`'s `NAME.png`) and report lines: 1 to
/// [`MAX_NAME`] letters, digits, `-`, `_` and `.`, not starting with `.`.
fn check_name(name: &str) -> Result<(), String> {
    let ok = (1..=MAX_NAME).contains(&name.len())
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if ok {
        return Ok(());
    }
    let shown: String = name.chars().take(MAX_NAME).collect();
    Err(format!(
        "name: {shown:?}{} is not a scene name: 1 to {MAX_NAME} letters, digits, '-', '_' or '.', not starting with '.' \
         (it names output files)",
        if name.chars().count() > MAX_NAME { "…" } else { "" }
    ))
}

/// `[sampling]`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingDesc {
    /// Largest edge-placement error of the sample pattern, pixels (1/32 to
    /// 0.5): the planner picks the grid from it.
    pub edge_error: f64,
    /// The grid only where a pixel's corners and centre disagree (default
    /// true).
    #[serde(default = "yes")]
    pub adaptive: bool,
}

fn yes() -> bool {
    true
}

impl SamplingDesc {
    /// What a scene without `[sampling]` gets (camera-model.md §7): the
    /// sensor's area integration, edges placed within 1/8 px, the grid
    /// only where a pixel's corners and centre disagree.
    pub const DEFAULT: SamplingDesc = SamplingDesc {
        edge_error: 0.125,
        adaptive: true,
    };

    fn default_some() -> Option<SamplingDesc> {
        Some(Self::DEFAULT)
    }

    /// One sample at each pixel's centre: an edge error of half a pixel
    /// (the largest allowed; anything else goes to the core's checks).
    pub fn is_point(&self) -> bool {
        self.edge_error == 0.5
    }
}

/// `[noise]`: the EMVA 1288 linear camera model.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseDesc {
    /// Saturation capacity, electrons at full scale (1 to 10⁷).
    pub saturation: f64,
    /// Dark noise, electrons rms (0 to 10⁴).
    pub dark_noise: f64,
    /// Dark offset, DN (0 to full scale; default 0).
    #[serde(default)]
    pub dark_offset: f64,
    /// The generator's seed, 0 to 2³² − 1 (default 0).
    #[serde(default)]
    pub seed: u32,
}

/// `[output]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Output {
    /// `gray8`, `gray16` or `rgb565`.
    pub format: String,
    /// Significant bits for `gray16` (9 to 16).
    pub bits: Option<u8>,
    /// `K`: DN per W/m² of image irradiance.
    pub exposure: f64,
}

/// `[environment]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Environment {
    /// Ambient `A`.
    #[serde(default)]
    pub ambient: Colour,
    /// Background radiance `L_bg`.
    #[serde(default)]
    pub background: Colour,
    /// Cast shadows (camera-model.md §6); on unless `false`.
    #[serde(default = "yes")]
    pub shadows: bool,
}

impl Default for Environment {
    fn default() -> Environment {
        Environment {
            ambient: Colour::default(),
            background: Colour::default(),
            shadows: true,
        }
    }
}

/// A gray value or an `[r, g, b]` triple.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Colour {
    /// Gray.
    Gray(f64),
    /// Per channel.
    Rgb([f64; 3]),
}

impl Default for Colour {
    fn default() -> Self {
        Colour::Gray(0.0)
    }
}

impl Colour {
    /// Per channel.
    pub fn rgb(self) -> [f64; 3] {
        self.data().rgb()
    }

    /// As scene data carries it.
    pub fn data(self) -> hilcam::scene::data::Colour {
        match self {
            Colour::Gray(v) => hilcam::scene::data::Colour::Gray(v),
            Colour::Rgb(c) => hilcam::scene::data::Colour::Rgb(c),
        }
    }
}

/// `[[materials]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialDesc {
    /// Name primitives refer to.
    pub name: String,
    /// Lambertian albedo `ρ`.
    pub albedo: Colour,
    /// Specular albedo `ρ_s` (default 0).
    #[serde(default)]
    pub specular: Colour,
    /// Mix `n` (default 1: Lambertian).
    #[serde(default = "one")]
    pub mix: f64,
    /// Phong exponent `s` (default 0).
    #[serde(default)]
    pub exponent: u16,
}

fn one() -> f64 {
    1.0
}

/// `[[lights]]` as written: a `kind` and the keys it uses. (A plain struct
/// rather than a tagged enum, so that a bad value is reported at its own key,
/// not at the table's header.)
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightEntry {
    /// `point` or `directional`.
    pub kind: String,
    /// Point: position, metres.
    #[serde(default, deserialize_with = "exact::opt")]
    pub position: Option<[f64; 3]>,
    /// Point: intensity, W/sr.
    pub intensity: Option<Colour>,
    /// Directional: direction towards the light.
    #[serde(default, deserialize_with = "exact::opt")]
    pub direction: Option<[f64; 3]>,
    /// Directional: irradiance `E₀`, W/m².
    pub irradiance: Option<Colour>,
}

/// A light, resolved: the core's scene data (the colour as the file gave
/// it, one value or one a channel).
pub use hilcam::scene::data::LightData;

/// `[[primitives]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PrimitiveDesc {
    /// `plane`, `sphere`, `disc` or `rectangle`.
    pub kind: String,
    /// Material name.
    pub material: String,
    /// Plane: a point on it.
    #[serde(default, deserialize_with = "exact::opt")]
    pub point: Option<[f64; 3]>,
    /// Plane, disc, rectangle: normal.
    #[serde(default, deserialize_with = "exact::opt")]
    pub normal: Option<[f64; 3]>,
    /// Sphere, disc, rectangle: centre.
    #[serde(default, deserialize_with = "exact::opt")]
    pub centre: Option<[f64; 3]>,
    /// Sphere, disc: radius.
    pub radius: Option<f64>,
    /// Rectangle: direction of the `u` edges.
    #[serde(default, deserialize_with = "exact::opt")]
    pub u_axis: Option<[f64; 3]>,
    /// Rectangle: `[width, height]` along `u`, `v`.
    #[serde(default, deserialize_with = "exact::opt")]
    pub size: Option<[f64; 2]>,
    /// Planar shapes: checker texture.
    pub checker: Option<CheckerDesc>,
}

/// A checker texture.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckerDesc {
    /// Cell size, metres.
    pub cell: f64,
    /// Material of the odd cells.
    pub material: String,
    /// Direction of the texture's `u` axis (projected into the plane).
    #[serde(deserialize_with = "exact::arr")]
    pub u_axis: [f64; 3],
}

/// A shape with every field resolved (f64), shared by core and reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResolvedPrimitive {
    /// Geometry.
    pub shape: ShapeSpec,
    /// Material index.
    pub material: usize,
    /// Checker (cell, u direction, odd material index).
    pub checker: Option<(f64, [f64; 3], usize)>,
}

/// A scene with names resolved and every field checked for presence.
#[derive(Clone, Debug)]
pub struct Resolved {
    /// The file as parsed.
    pub desc: SceneDesc,
    /// Output format.
    pub format: PixelFormat,
    /// Pose.
    pub pose: Pose,
    /// Primitives.
    pub primitives: Vec<ResolvedPrimitive>,
    /// Lights.
    pub lights: Vec<LightData>,
    /// The camera's trajectory, if the file gives one.
    pub trajectory: Option<crate::trajectory::Trajectory>,
}

/// The largest scene file read, bytes (docs/scenes.md; the fullest scene is under 8 KiB).
pub const MAX_SCENE_BYTES: u64 = 1 << 20;

/// Reads and checks a scene file of at most [`MAX_SCENE_BYTES`]. Errors
/// name the file and the field.
pub fn load(path: &Path) -> Result<Resolved, String> {
    use std::io::Read;
    let at = |e: String| format!("{}: {e}", path.display());
    let file = std::fs::File::open(path).map_err(|e| at(e.to_string()))?;
    let mut bytes = Vec::new();
    file.take(MAX_SCENE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| at(e.to_string()))?;
    if bytes.len() as u64 > MAX_SCENE_BYTES {
        return Err(at(format!(
            "larger than {MAX_SCENE_BYTES} bytes: not a scene file (docs/scenes.md)"
        )));
    }
    let text = String::from_utf8(bytes).map_err(|e| at(format!("not UTF-8 text: {e}")))?;
    parse_in(&text, path.parent()).map_err(at)
}

/// Parses and checks scene text (`camera.calibration` from `.`).
pub fn parse(text: &str) -> Result<Resolved, String> {
    parse_in(text, None)
}

/// [`parse`], a relative `camera.calibration` path starting in `dir`.
pub fn parse_in(text: &str, dir: Option<&Path>) -> Result<Resolved, String> {
    let mut table: toml::Table = toml::from_str(text).map_err(|e| toml_error(text, &e))?;
    let camera = table.get_mut("camera").and_then(|c| c.as_table_mut());
    let desc: SceneDesc = match camera {
        Some(c) if c.contains_key("calibration") => {
            crate::calibration::merge(c, dir)?;
            table
                .try_into()
                .map_err(|e: toml::de::Error| e.to_string().trim_end().to_string())?
        }
        _ => toml::from_str(text).map_err(|e| toml_error(text, &e))?,
    };
    resolve(desc)
}

/// A TOML error as `line N: KEY: message`, the key being the one whose
/// value the error points at (serde's messages do not name it), followed by
/// the TOML crate's own excerpt.
fn toml_error(text: &str, e: &toml::de::Error) -> String {
    let full = e.to_string().trim_end().to_string();
    let Some(span) = e.span() else {
        return full;
    };
    let start = span.start.min(text.len());
    let line_no = text[..start].matches('\n').count() + 1;
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    // The nearest `key =` before the span on its line (inline tables too).
    let before = &text[line_start..start];
    let key = before.rfind('=').and_then(|eq| {
        let k = before[..eq].trim_end();
        let k = k
            .rsplit(|c: char| c == '{' || c == ',' || c.is_whitespace())
            .next()?;
        (!k.is_empty()).then(|| k.trim_matches('"').to_string())
    });
    match key {
        Some(k) => format!("line {line_no}: {k}: {}\n{full}", e.message().trim_end()),
        None => full,
    }
}

impl<'de> Deserialize<'de> for Colour {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(match exact::one_or::<D, 3>(d, "a number or [r, g, b]")? {
            Ok(v) => Colour::Gray(v),
            Err(a) => Colour::Rgb(a),
        })
    }
}

/// Fixed-size arrays that must have exactly their length: serde's array
/// impl, under the TOML deserializer, drops extra elements (OpenCV's
/// five-coefficient `distortion` would silently lose three).
mod exact {
    use serde::de::{Deserialize, Deserializer, Error};

    struct Len(usize, &'static str);
    impl serde::de::Expected for Len {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "exactly {} {}", self.0, self.1)
        }
    }

    fn fixed<'de, D: Deserializer<'de>, T, const N: usize>(
        v: Vec<T>,
        what: &'static str,
    ) -> Result<[T; N], D::Error> {
        let n = v.len();
        v.try_into()
            .map_err(|_| D::Error::invalid_length(n, &Len(N, what)))
    }

    /// `[f64; N]`, exactly N numbers.
    pub fn arr<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error> {
        fixed::<D, f64, N>(Vec::deserialize(d)?, "numbers")
    }

    /// An optional `[f64; N]`, exactly N numbers.
    pub fn opt<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<Option<[f64; N]>, D::Error> {
        arr(d).map(Some)
    }

    /// A number (`Ok`) or exactly N numbers (`Err`).
    pub fn one_or<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
        what: &'static str,
    ) -> Result<Result<f64, [f64; N]>, D::Error> {
        struct V<const N: usize>(&'static str);
        impl<'de, const N: usize> serde::de::Visitor<'de> for V<N> {
            type Value = Result<f64, [f64; N]>;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.0)
            }
            fn visit_f64<E: Error>(self, v: f64) -> Result<Self::Value, E> {
                Ok(Ok(v))
            }
            fn visit_i64<E: Error>(self, v: i64) -> Result<Self::Value, E> {
                Ok(Ok(v as f64))
            }
            fn visit_u64<E: Error>(self, v: u64) -> Result<Self::Value, E> {
                Ok(Ok(v as f64))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element::<f64>()? {
                    v.push(x);
                }
                let n = v.len();
                v.try_into()
                    .map(Err)
                    .map_err(|_| A::Error::invalid_length(n, &Len(N, "numbers")))
            }
        }
        d.deserialize_any(V::<N>(what))
    }

    /// An optional 3×3 matrix, exactly 3 rows of exactly 3 numbers.
    pub fn opt_matrix<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[[f64; 3]; 3]>, D::Error> {
        let rows: Vec<Vec<f64>> = Vec::deserialize(d)?;
        let rows = rows
            .into_iter()
            .map(|r| fixed::<D, f64, 3>(r, "numbers in a row"))
            .collect::<Result<Vec<_>, _>>()?;
        fixed::<D, [f64; 3], 3>(rows, "rows").map(Some)
    }
}

fn need<T: Copy>(v: Option<T>, what: &str) -> Result<T, String> {
    v.ok_or_else(|| format!("{what}: missing"))
}

/// Checks a parsed scene file and resolves it (what [`load`] and [`parse`]
/// do after parsing): errors name the key.
pub fn resolve(desc: SceneDesc) -> Result<Resolved, String> {
    let format = match (desc.output.format.as_str(), desc.output.bits) {
        ("gray8", None) => PixelFormat::Gray8,
        ("gray16", Some(bits)) => PixelFormat::Gray16 { bits },
        ("gray16", None) => return Err("output.bits: missing (gray16 needs 9 to 16)".into()),
        ("rgb565", None) => PixelFormat::Rgb565,
        ("gray8" | "rgb565", Some(_)) => return Err("output.bits: only for gray16".into()),
        (other, _) => {
            return Err(format!(
                "output.format: unknown format {other:?} (gray8, gray16, rgb565)"
            ))
        }
    };
    let p = &desc.camera.pose;
    let pose = match (p.eye, p.target, p.up, p.position, p.yaw_pitch_roll, p.rotation) {
        (Some(eye), Some(target), Some(up), None, None, None) => Pose::LookAt { eye, target, up },
        (None, None, None, Some(position), Some(angles), None) => Pose::Ypr { position, angles },
        (None, None, None, Some(position), None, Some(rotation)) => Pose::Matrix { position, rotation },
        _ => {
            return Err(
                "camera.pose: give either eye, target and up; or position and yaw_pitch_roll; \
                        or position and rotation"
                    .into(),
            )
        }
    };
    check_name(&desc.name)?;
    let names: Vec<&str> = desc.materials.iter().map(|m| m.name.as_str()).collect();
    for (i, n) in names.iter().enumerate() {
        if let Some(j) = names[..i].iter().position(|m| m == n) {
            return Err(format!(
                "materials[{i}].name: {n:?} is also the name of materials[{j}] (names must be unique)"
            ));
        }
    }
    let material = |name: &str, field: String| -> Result<usize, String> {
        names
            .iter()
            .position(|n| *n == name)
            .ok_or_else(|| format!("{field}: no material named {name:?}"))
    };
    if format.channels() == 1 {
        let gray = |c: &Colour, field: String| match c {
            Colour::Rgb(_) => Err(format!("{field}: a colour triple needs the rgb565 format")),
            Colour::Gray(_) => Ok(()),
        };
        for (i, m) in desc.materials.iter().enumerate() {
            gray(&m.albedo, format!("materials[{i}].albedo"))?;
            gray(&m.specular, format!("materials[{i}].specular"))?;
        }
        for (i, l) in desc.lights.iter().enumerate() {
            if let Some(c) = &l.intensity {
                gray(c, format!("lights[{i}].intensity"))?;
            }
            if let Some(c) = &l.irradiance {
                gray(c, format!("lights[{i}].irradiance"))?;
            }
        }
        gray(&desc.environment.ambient, "environment.ambient".into())?;
        gray(&desc.environment.background, "environment.background".into())?;
    }
    let primitives = resolve_primitives(&desc, &material)?;
    let lights = resolve_lights(&desc)?;
    let trajectory = if desc.trajectory.is_empty() {
        None
    } else {
        let t = crate::trajectory::Trajectory::new(desc.trajectory.clone())?;
        if let Some(i) = desc
            .trajectory
            .iter()
            .position(|k| k.position.iter().any(|v| v.abs() > hilcam::scene::MAX_EXTENT))
        {
            return Err(format!(
                "trajectory keyframe {i}: position: beyond ±{} m",
                hilcam::scene::MAX_EXTENT
            ));
        }
        Some(t)
    };
    let r = Resolved {
        desc,
        format,
        pose,
        primitives,
        lights,
        trajectory,
    };
    // Build the core scene and prepare its default frame once, so that
    // every range check runs now, naming the field, rather than at render.
    let scene = r.core_scene()?;
    r.check_renderable(&scene)?;
    Ok(r)
}

/// The scene file's primitives: each shape with the fields its kind uses
/// (another field is refused, naming it), its material by name.
fn resolve_primitives(
    desc: &SceneDesc,
    material: &dyn Fn(&str, String) -> Result<usize, String>,
) -> Result<Vec<ResolvedPrimitive>, String> {
    let mut primitives = Vec::new();
    for (i, pd) in desc.primitives.iter().enumerate() {
        let f = |name: &str| format!("primitives[{i}].{name}");
        let shape = match pd.kind.as_str() {
            "plane" => ShapeSpec::Plane {
                point: need(pd.point, &f("point"))?,
                normal: need(pd.normal, &f("normal"))?,
            },
            "sphere" => ShapeSpec::Sphere {
                centre: need(pd.centre, &f("centre"))?,
                radius: need(pd.radius, &f("radius"))?,
            },
            "disc" => ShapeSpec::Disc {
                centre: need(pd.centre, &f("centre"))?,
                normal: need(pd.normal, &f("normal"))?,
                radius: need(pd.radius, &f("radius"))?,
            },
            "rectangle" => ShapeSpec::Rectangle {
                centre: need(pd.centre, &f("centre"))?,
                normal: need(pd.normal, &f("normal"))?,
                u_axis: need(pd.u_axis, &f("u_axis"))?,
                size: need(pd.size, &f("size"))?,
            },
            other => {
                return Err(format!(
                    "{}: unknown kind {other:?} (plane, sphere, disc, rectangle)",
                    f("kind")
                ))
            }
        };
        let used: &[(&str, bool)] = &[
            ("point", pd.point.is_some()),
            ("normal", pd.normal.is_some()),
            ("centre", pd.centre.is_some()),
            ("radius", pd.radius.is_some()),
            ("u_axis", pd.u_axis.is_some()),
            ("size", pd.size.is_some()),
        ];
        let allowed: &[&str] = match pd.kind.as_str() {
            "plane" => &["point", "normal"],
            "sphere" => &["centre", "radius"],
            "disc" => &["centre", "normal", "radius"],
            _ => &["centre", "normal", "u_axis", "size"],
        };
        for (name, present) in used {
            if *present && !allowed.contains(name) {
                return Err(format!("{}: not used by a {}", f(name), pd.kind));
            }
        }
        let checker = match &pd.checker {
            None => None,
            Some(c) => Some((c.cell, c.u_axis, material(&c.material, f("checker.material"))?)),
        };
        primitives.push(ResolvedPrimitive {
            shape,
            material: material(&pd.material, f("material"))?,
            checker,
        });
    }
    Ok(primitives)
}

/// The scene file's lights: point or directional, each with the fields its
/// kind uses.
fn resolve_lights(desc: &SceneDesc) -> Result<Vec<LightData>, String> {
    let mut lights = Vec::new();
    for (i, l) in desc.lights.iter().enumerate() {
        let f = |name: &str| format!("lights[{i}].{name}");
        let (light, unused): (LightData, [(&str, bool); 2]) = match l.kind.as_str() {
            "point" => (
                LightData::Point {
                    position: need(l.position, &f("position"))?,
                    intensity: need(l.intensity, &f("intensity"))?.data(),
                },
                [
                    ("direction", l.direction.is_some()),
                    ("irradiance", l.irradiance.is_some()),
                ],
            ),
            "directional" => (
                LightData::Directional {
                    direction: need(l.direction, &f("direction"))?,
                    irradiance: need(l.irradiance, &f("irradiance"))?.data(),
                },
                [
                    ("position", l.position.is_some()),
                    ("intensity", l.intensity.is_some()),
                ],
            ),
            other => {
                return Err(format!(
                    "{}: unknown kind {other:?} (point, directional)",
                    f("kind")
                ))
            }
        };
        for (name, present) in unused {
            if present {
                return Err(format!("{}: not used by a {} light", f(name), l.kind));
            }
        }
        lights.push(light);
    }
    Ok(lights)
}

impl Resolved {
    /// Aperture diameter, metres.
    pub fn aperture_diameter(&self) -> f64 {
        let c = &self.desc.camera;
        c.aperture
            .unwrap_or_else(|| c.focal_length / c.f_number.unwrap_or(1.0))
    }

    /// Prepares the frame the planner picks by default, so that a camera
    /// the renderer cannot image is refused at load, naming the fields
    /// that set it, instead of failing at render.
    fn check_renderable(&self, scene: &Scene) -> Result<(), String> {
        use hilcam::render::{Frame, RenderError, MAX_SLOPE};
        let plan = hilcam::planner::plan(scene, &hilcam::planner::Budget::default());
        let Err(e) = Frame::new(scene, &plan.options) else {
            return Ok(());
        };
        let c = &self.desc.camera;
        // The widest sensor corner in normalized coordinates (f64).
        let (sx, sy) = c.pitch.get();
        let (ox, oy) = c.principal_point.map_or(
            ((c.width as f64 - 1.0) / 2.0, (c.height as f64 - 1.0) / 2.0),
            |[x, y]| (x, y),
        );
        let (last_i, last_j) = (c.width as f64 - 1.0, c.height as f64 - 1.0);
        let corner = [(0.0, 0.0), (last_i, 0.0), (0.0, last_j), (last_i, last_j)]
            .into_iter()
            .map(|(i, j)| (((ox - i) * sx / c.focal_length), ((oy - j) * sy / c.focal_length)))
            .fold((0.0f64, 0.0f64), |(a, b), (x, y)| {
                (a.max(x.abs()), b.max(y.abs()))
            });
        Err(match e {
            RenderError::FieldTooWide => format!(
                "camera.width, camera.height, camera.pitch, camera.focal_length, camera.principal_point, \
                 camera.distortion: field too wide: a sensor corner's undistorted slope (tan of its angle \
                 off the axis) exceeds {MAX_SLOPE} (the corners lie at |x̂_d| {:.3}, |ŷ_d| {:.3} before \
                 distortion); docs/scenes.md, \"Field of view\"",
                corner.0, corner.1
            ),
            RenderError::DistortionOutOfRange => format!(
                "camera.distortion: the factor 1 + k1 u + k2 u² exceeds ±32768 over the sensor (corners at \
                 |x̂_d| {:.3}, |ŷ_d| {:.3}); docs/scenes.md, \"Field of view\"",
                corner.0, corner.1
            ),
            other => format!("camera: the renderer cannot prepare this camera: {other:?}"),
        })
    }

    /// The scene as data (what a camera stores and receives). Errors name
    /// the field.
    pub fn scene_data(&self) -> Result<SceneData, String> {
        let c = &self.desc.camera;
        let aperture = match (c.f_number, c.aperture) {
            (Some(n), None) => Aperture::FNumber(n),
            (None, Some(d)) => Aperture::Diameter(d),
            _ => return Err("camera: give exactly one of f_number and aperture".into()),
        };
        let orthographic_scale = match (c.model.as_str(), c.orthographic_scale) {
            ("perspective", None) => None,
            ("orthographic", Some(m)) => Some(m),
            ("orthographic", None) => return Err("camera.orthographic_scale: missing".into()),
            ("perspective", Some(_)) => return Err("camera.orthographic_scale: only for orthographic".into()),
            (other, _) => {
                return Err(format!(
                    "camera.model: unknown model {other:?} (perspective, orthographic)"
                ))
            }
        };
        let (sx, sy) = c.pitch.get();
        let (rotation, position) = self.pose.matrix()?;
        let index = |i: usize, what: &str| u8::try_from(i).map_err(|_| format!("{what}: more than 255"));
        let too_many = |what: &str, max: usize| format!("{what}: more than {max} (the core's limit)");
        let env = &self.desc.environment;
        let mut d = SceneData {
            camera: CameraData {
                width: c.width,
                height: c.height,
                focal_length: c.focal_length,
                pitch: [sx, sy],
                principal_point: c.principal_point,
                orthographic_scale,
                aperture,
                focus_distance: c.focus_distance,
                tolerable_blur: c.tolerable_blur,
                distortion: c.distortion,
                rotation,
                position,
            },
            format: self.format.into(),
            exposure: self.desc.output.exposure,
            ambient: env.ambient.data(),
            background: env.background.data(),
            materials: heapless::Vec::new(),
            primitives: heapless::Vec::new(),
            lights: heapless::Vec::new(),
            // (One sample a pixel asks for no sampling stage: a build
            // without it takes the scene.)
            sampling: self
                .desc
                .sampling
                .filter(|s| !s.is_point())
                .map(|s| SamplingData {
                    edge_error: s.edge_error,
                    adaptive: s.adaptive,
                }),
            noise: self.desc.noise.map(|n| NoiseData {
                saturation: n.saturation,
                dark_noise: n.dark_noise,
                dark_offset: n.dark_offset,
                seed: n.seed,
            }),
            lens: c.lens()?,
            shadows: env.shadows,
        };
        for m in &self.desc.materials {
            // Lambertian (the defaults) without a lobe: the same values.
            let lambertian = m.specular.rgb() == [0.0; 3] && m.mix == 1.0 && m.exponent == 0;
            let m = MaterialData {
                albedo: m.albedo.data(),
                specular: (!lambertian).then(|| SpecularData {
                    albedo: m.specular.data(),
                    mix: m.mix,
                    exponent: m.exponent,
                }),
            };
            d.materials
                .push(m)
                .map_err(|_| too_many("materials", MAX_MATERIALS))?;
        }
        for (i, p) in self.primitives.iter().enumerate() {
            let checker = match p.checker {
                Some((cell, u_axis, m)) => Some(CheckerSpec {
                    cell,
                    u_axis,
                    material: index(m, &format!("primitives[{i}].checker.material"))?,
                }),
                None => None,
            };
            let p = PrimitiveData {
                shape: p.shape,
                material: index(p.material, &format!("primitives[{i}].material"))?,
                checker,
            };
            d.primitives
                .push(p)
                .map_err(|_| too_many("primitives", MAX_PRIMITIVES))?;
        }
        for l in &self.lights {
            d.lights.push(*l).map_err(|_| too_many("lights", MAX_LIGHTS))?;
        }
        Ok(d)
    }

    /// The scene data postcard-encoded, as a camera stores and receives it.
    pub fn scene_bytes(&self) -> Result<Vec<u8>, String> {
        postcard::to_stdvec(&self.scene_data()?).map_err(|e| format!("encoding the scene: {e}"))
    }

    /// The core's scene, built from [`Resolved::scene_bytes`] as a camera
    /// builds it ([`hilcam::scene::data::load`]). Errors name the field.
    pub fn core_scene(&self) -> Result<Scene, String> {
        hilcam::scene::data::load(&self.scene_bytes()?).map_err(|e| {
            // The data carries the pose as R and T: name the file's keys.
            let key = match (e.field().1, self.pose) {
                ("camera.pose.rotation", Pose::Ypr { .. }) => Some("camera.pose.yaw_pitch_roll"),
                ("camera.pose.position", Pose::LookAt { .. }) => Some("camera.pose.eye"),
                _ => None,
            };
            let text = e.to_string();
            match (key, text.split_once(": ")) {
                (Some(k), Some((_, why))) => format!("{k}: {why}"),
                _ => text,
            }
        })
    }
}
