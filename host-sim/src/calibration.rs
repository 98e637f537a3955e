//! A real camera's calibration as a scene's camera (`camera.calibration`,
//! docs/scenes.md "Your own lens"): OpenCV's FileStorage (YAML or XML, as
//! `cv2.FileStorage` writes it) or a ROS `CameraInfo` YAML.
//!
//! What a file gives — image size, `fx, fy, cx, cy`, the distortion model
//! and its coefficients — becomes the scene's `width`, `height`, `pitch`
//! (`focal_length / fx`, `/ fy`), `principal_point` and
//! `opencv_distortion` or `fisheye_distortion`; the scene file gives the
//! rest (focal length, aperture, focus, pose). Errors name the file and the
//! key.

use std::path::Path;

/// The distortion model a calibration names.
#[derive(Clone, Debug, PartialEq)]
pub enum Model {
    /// OpenCV's standard model (ROS `plumb_bob`, `rational_polynomial`):
    /// its coefficients in OpenCV's order.
    OpenCv(Vec<f64>),
    /// OpenCV's fisheye model (ROS `equidistant`): `k1 … k4`.
    Fisheye([f64; 4]),
}

/// A camera as its calibration file states it.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraFile {
    /// Image size, pixels.
    pub width: u16,
    /// Image size, pixels.
    pub height: u16,
    /// Focal lengths, pixels.
    pub fx: f64,
    /// Focal lengths, pixels.
    pub fy: f64,
    /// Principal point, pixels.
    pub cx: f64,
    /// Principal point, pixels.
    pub cy: f64,
    /// The distortion.
    pub model: Model,
}

/// A key's value as the reader found it: a number, text, a list, or a map.
#[derive(Clone, Debug)]
enum Value {
    Num(f64),
    Text(String),
    List(Vec<f64>),
    Map(Vec<(String, Value)>),
}

impl Value {
    fn get(&self, key: &str) -> Option<&Value> {
        match self {
            Value::Map(m) => m.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }
}

/// Reads a calibration file (at most 1 MiB): XML if it starts with `<`,
/// else YAML — OpenCV's FileStorage if it has `camera_matrix` with
/// `rows`/`cols`/`data` under OpenCV's tag, ROS `CameraInfo` if it has
/// `distortion_model`.
pub fn read(path: &Path) -> Result<CameraFile, String> {
    use std::io::Read;
    let at = |e: String| format!("{}: {e}", path.display());
    let file = std::fs::File::open(path).map_err(|e| at(e.to_string()))?;
    let mut bytes = Vec::new();
    file.take((1 << 20) + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| at(e.to_string()))?;
    if bytes.len() > 1 << 20 {
        return Err(at("larger than 1 MiB: not a calibration file".into()));
    }
    let text = String::from_utf8(bytes).map_err(|e| at(format!("not UTF-8 text: {e}")))?;
    parse(&text).map_err(at)
}

/// [`read`] of a file's text.
pub fn parse(text: &str) -> Result<CameraFile, String> {
    let root = if text.trim_start().starts_with('<') {
        xml(text)?
    } else {
        yaml(text)?
    };
    camera(&root)
}

/// OpenCV's FileStorage XML: `<opencv_storage>` with one element a key; a
/// matrix is `<rows>`, `<cols>`, `<dt>`, `<data>` (numbers separated by
/// white space).
fn xml(text: &str) -> Result<Value, String> {
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("not XML: {e}"))?;
    let root = doc.root_element();
    if root.tag_name().name() != "opencv_storage" {
        return Err(format!(
            "{}: not OpenCV's FileStorage XML (its root is opencv_storage)",
            root.tag_name().name()
        ));
    }
    fn node(n: roxmltree::Node) -> Value {
        let children: Vec<_> = n.children().filter(|c| c.is_element()).collect();
        if children.is_empty() {
            let t = n.text().unwrap_or("").trim();
            let nums: Option<Vec<f64>> = t.split_whitespace().map(|w| w.parse().ok()).collect();
            return match nums {
                Some(v) if v.len() == 1 && !t.contains(char::is_whitespace) => Value::Num(v[0]),
                Some(v) if !v.is_empty() => Value::List(v),
                _ => Value::Text(t.trim_matches('"').to_string()),
            };
        }
        Value::Map(
            children
                .into_iter()
                .map(|c| (c.tag_name().name().to_string(), node(c)))
                .collect(),
        )
    }
    Ok(node(root))
}

/// YAML: OpenCV's (`%YAML:1.0` and `!!opencv-matrix` are OpenCV's own
/// spellings, taken out before parsing) or ROS's.
fn yaml(text: &str) -> Result<Value, String> {
    use yaml_rust2::{Yaml, YamlLoader};
    let cleaned: String = text
        .lines()
        .filter(|l| !l.starts_with("%YAML"))
        .map(|l| l.replace("!!opencv-matrix", "").replace("!!opencv-nd-matrix", ""))
        .collect::<Vec<_>>()
        .join("\n");
    let docs = YamlLoader::load_from_str(&cleaned).map_err(|e| format!("not YAML: {e}"))?;
    let doc = docs.into_iter().next().ok_or("empty YAML")?;
    fn conv(y: &Yaml) -> Value {
        match y {
            Yaml::Real(_) | Yaml::Integer(_) => Value::Num(
                y.as_f64()
                    .or_else(|| y.as_i64().map(|i| i as f64))
                    .unwrap_or(f64::NAN),
            ),
            Yaml::String(s) => Value::Text(s.clone()),
            Yaml::Array(a) => Value::List(
                a.iter()
                    .map(|v| {
                        v.as_f64()
                            .or_else(|| v.as_i64().map(|i| i as f64))
                            .unwrap_or(f64::NAN)
                    })
                    .collect(),
            ),
            Yaml::Hash(h) => Value::Map(
                h.iter()
                    .map(|(k, v)| (k.as_str().unwrap_or("").to_string(), conv(v)))
                    .collect(),
            ),
            _ => Value::Text(String::new()),
        }
    }
    Ok(conv(&doc))
}

/// A matrix's numbers (`rows × cols` of them, or a plain list).
fn matrix(root: &Value, key: &str) -> Result<Option<Vec<f64>>, String> {
    let Some(v) = root.get(key) else {
        return Ok(None);
    };
    let data = match v {
        Value::List(d) => d.clone(),
        Value::Map(_) => {
            let data = match v.get("data") {
                Some(Value::List(d)) => d.clone(),
                Some(Value::Num(n)) => vec![*n],
                _ => return Err(format!("{key}.data: missing or not numbers")),
            };
            let dim = |k: &str| match v.get(k) {
                Some(Value::Num(n)) => Ok(Some(*n as usize)),
                None => Ok(None),
                _ => Err(format!("{key}.{k}: not a number")),
            };
            if let (Some(r), Some(c)) = (dim("rows")?, dim("cols")?) {
                if r * c != data.len() {
                    return Err(format!("{key}.data: {} numbers for {r} × {c}", data.len()));
                }
            }
            data
        }
        _ => return Err(format!("{key}: not a matrix")),
    };
    if let Some(i) = data.iter().position(|x| !x.is_finite()) {
        return Err(format!("{key}.data[{i}]: not a finite number"));
    }
    Ok(Some(data))
}

fn number(root: &Value, key: &str) -> Result<Option<f64>, String> {
    match root.get(key) {
        None => Ok(None),
        Some(Value::Num(n)) => Ok(Some(*n)),
        Some(_) => Err(format!("{key}: not a number")),
    }
}

fn text<'a>(root: &'a Value, key: &str) -> Result<Option<&'a str>, String> {
    match root.get(key) {
        None => Ok(None),
        Some(Value::Text(t)) => Ok(Some(t.as_str())),
        Some(_) => Err(format!("{key}: not text")),
    }
}

/// The camera of a parsed file.
fn camera(root: &Value) -> Result<CameraFile, String> {
    let k = matrix(root, "camera_matrix")?.ok_or("camera_matrix: missing")?;
    if k.len() != 9 {
        return Err(format!("camera_matrix: {} numbers, not 3 × 3", k.len()));
    }
    if k[1] != 0.0 {
        return Err("camera_matrix: a skew (row 0, column 1) is not modelled".into());
    }
    if k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
        return Err("camera_matrix: not [fx 0 cx; 0 fy cy; 0 0 1]".into());
    }
    let d = matrix(root, "distortion_coefficients")?.unwrap_or_default();
    let size = |w: &str, h: &str| -> Result<Option<(f64, f64)>, String> {
        Ok(number(root, w)?.zip(number(root, h)?))
    };
    let (w, h) = match (size("image_width", "image_height")?, matrix(root, "image_size")?) {
        (Some(wh), _) => wh,
        (None, Some(v)) if v.len() == 2 => (v[0], v[1]),
        _ => return Err("image_width, image_height: missing (or image_size: [width, height])".into()),
    };
    let side = |v: f64, key: &str| {
        (v.fract() == 0.0 && (1.0..=16384.0).contains(&v))
            .then_some(v as u16)
            .ok_or_else(|| format!("{key}: {v}: not a size from 1 to 16384"))
    };
    let (width, height) = (side(w, "image_width")?, side(h, "image_height")?);
    let model = match text(root, "distortion_model")?.unwrap_or("plumb_bob") {
        "plumb_bob" | "rational_polynomial" | "opencv" => Model::OpenCv(d),
        "equidistant" | "fisheye" => {
            let k: [f64; 4] = d.as_slice().try_into().map_err(|_| {
                format!(
                    "distortion_coefficients: {} numbers; the fisheye model has 4",
                    d.len()
                )
            })?;
            Model::Fisheye(k)
        }
        other => {
            return Err(format!(
                "distortion_model: {other:?} is not modelled (plumb_bob, rational_polynomial, equidistant)"
            ))
        }
    };
    Ok(CameraFile {
        width,
        height,
        fx: k[0],
        fy: k[4],
        cx: k[2],
        cy: k[5],
        model,
    })
}

/// Puts a calibration file's camera into a scene file's `[camera]` table
/// (TOML), in place of its `calibration` key: `width`, `height`, `pitch`
/// (from the table's `focal_length`), `principal_point`, and
/// `opencv_distortion` or `fisheye_distortion`. The table must not give
/// any of them itself. `dir`: where a relative path starts.
pub fn merge(camera: &mut toml::Table, dir: Option<&Path>) -> Result<(), String> {
    let Some(v) = camera.remove("calibration") else {
        return Ok(());
    };
    let name = v.as_str().ok_or("camera.calibration: not a file name")?;
    let path = match dir {
        Some(d) if Path::new(name).is_relative() => d.join(name),
        _ => Path::new(name).to_path_buf(),
    };
    let file = read(&path).map_err(|e| format!("camera.calibration: {e}"))?;
    let f = match camera.get("focal_length") {
        Some(toml::Value::Float(f)) => *f,
        Some(toml::Value::Integer(i)) => *i as f64,
        _ => {
            return Err(
                "camera.focal_length: missing (with camera.calibration it sets the pixel pitch, f / fx)"
                    .into(),
            )
        }
    };
    if !(file.fx > 0.0 && file.fy > 0.0) {
        return Err(format!(
            "camera.calibration: {}: camera_matrix: fx, fy must be greater than zero",
            path.display()
        ));
    }
    let (key, coefficients) = match &file.model {
        Model::OpenCv(c) => ("opencv_distortion", c.clone()),
        Model::Fisheye(k) => ("fisheye_distortion", k.to_vec()),
    };
    let floats = |v: &[f64]| toml::Value::Array(v.iter().map(|x| toml::Value::Float(*x)).collect());
    let given = [
        ("width", toml::Value::Integer(file.width.into())),
        ("height", toml::Value::Integer(file.height.into())),
        ("pitch", floats(&[f / file.fx, f / file.fy])),
        ("principal_point", floats(&[file.cx, file.cy])),
        (key, floats(&coefficients)),
    ];
    for (k, v) in given {
        if camera.contains_key(k) {
            return Err(format!(
                "camera.{k}: given by camera.calibration ({}); leave it out",
                path.display()
            ));
        }
        camera.insert(k.into(), v);
    }
    for k in ["distortion", "opencv_distortion", "fisheye_distortion"] {
        if k != key && camera.contains_key(k) {
            return Err(format!(
                "camera.{k}: the lens is camera.calibration's ({})",
                path.display()
            ));
        }
    }
    Ok(())
}

/// The calibrated lens of a scene's `[camera]` keys, as the core takes it:
/// `opencv_distortion` (4, 5, 8, 12 or 14 coefficients; τx = τy = 0) or
/// `fisheye_distortion`, at most one lens model in all (`radial`: whether
/// `distortion` is given).
pub fn lens(
    radial: bool,
    opencv: &Option<Vec<f64>>,
    fisheye: &Option<[f64; 4]>,
) -> Result<Option<hilcam::scene::data::LensData>, String> {
    use hilcam::scene::data::LensData;
    match (radial, opencv, fisheye) {
        (_, None, None) => Ok(None),
        (false, Some(c), None) => {
            if !matches!(c.len(), 4 | 5 | 8 | 12 | 14) {
                return Err(format!(
                    "camera.opencv_distortion: {} coefficients; OpenCV's model has 4, 5, 8, 12 or 14",
                    c.len()
                ));
            }
            if c.len() == 14 && (c[12] != 0.0 || c[13] != 0.0) {
                return Err("camera.opencv_distortion: a tilted sensor (tauX, tauY not 0) is not modelled".into());
            }
            let mut k = [0.0; 12];
            for (d, v) in k.iter_mut().zip(c) {
                *d = *v;
            }
            Ok(Some(LensData::OpenCv(k)))
        }
        (false, None, Some(k)) => Ok(Some(LensData::Fisheye(*k))),
        _ => Err(
            "camera.distortion, camera.opencv_distortion, camera.fisheye_distortion: give at most one lens model"
                .into(),
        ),
    }
}
