//! `hilcam._hilcam`: the native half of the `hilcam` Python package.
//!
//! It hands Python what host-sim's library does — a scene file checked and
//! resolved, a frame rendered by the core with its plan and its ground
//! truth, the OpenCV export, and the one client of a camera on a serial
//! device ([`host_sim::client::Client`]) — as bytes, numbers and JSON text.
//! The package's Python half (`hilcam/__init__.py`) makes numpy arrays and
//! typed objects of them.

use host_sim::client::{ClientError, SerialClient};
use host_sim::scene_file::{PoseDesc, Resolved};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::time::Duration;

create_exception!(
    _hilcam,
    Refused,
    PyException,
    "The camera refused a command; args: (message, command, reason, field)."
);
create_exception!(
    _hilcam,
    LinkError,
    PyException,
    "The link to the camera failed: closed, silent, or answering out of turn."
);

/// A scene error (Python's `ValueError`, its message starting with the
/// key at fault).
fn scene_err(e: String) -> PyErr {
    PyValueError::new_err(e)
}

/// A client error as the package's exceptions.
fn client_err(e: ClientError) -> PyErr {
    match &e {
        ClientError::Refused {
            command,
            reason,
            field,
            ..
        } => Refused::new_err((e.to_string(), *command, format!("{reason:?}"), field.clone())),
        ClientError::Link(_) => LinkError::new_err(e.to_string()),
    }
}

/// A scene file, resolved and checked as `host-sim` checks it.
#[pyclass(module = "hilcam._hilcam")]
#[derive(Clone)]
struct NativeScene {
    r: Resolved,
}

impl NativeScene {
    /// The scene with its description changed by `edit`, checked again
    /// whole; on error the scene is unchanged.
    fn edit(&mut self, edit: impl FnOnce(&mut host_sim::scene_file::SceneDesc)) -> PyResult<()> {
        let mut desc = self.r.desc.clone();
        edit(&mut desc);
        self.r = host_sim::scene_file::resolve(desc).map_err(scene_err)?;
        Ok(())
    }

    /// A pose of the scene file's `[camera.pose]`.
    fn pose(&mut self, p: PoseDesc) -> PyResult<()> {
        self.edit(|d| {
            d.camera.pose = p;
            // A pose set from the bench replaces the file's trajectory.
            d.trajectory.clear();
        })
    }
}

#[pymethods]
impl NativeScene {
    /// Parses and checks TOML text.
    #[staticmethod]
    fn parse(text: &str) -> PyResult<NativeScene> {
        Ok(NativeScene {
            r: host_sim::scene_file::parse(text).map_err(scene_err)?,
        })
    }

    /// Reads, parses and checks a scene file.
    #[staticmethod]
    fn load(path: &str) -> PyResult<NativeScene> {
        Ok(NativeScene {
            r: host_sim::scene_file::load(std::path::Path::new(path)).map_err(scene_err)?,
        })
    }

    #[getter]
    fn name(&self) -> String {
        self.r.desc.name.clone()
    }

    #[getter]
    fn width(&self) -> u16 {
        self.r.desc.camera.width
    }

    #[getter]
    fn height(&self) -> u16 {
        self.r.desc.camera.height
    }

    /// `gray8`, `gray16` or `rgb565`.
    #[getter]
    fn format(&self) -> String {
        self.r.desc.output.format.clone()
    }

    /// Significant bits of a `gray16` frame (8 for gray8, 5/6/5 rgb565: 16).
    #[getter]
    fn bits(&self) -> u8 {
        match self.r.format {
            hilcam::scene::PixelFormat::Gray8 => 8,
            hilcam::scene::PixelFormat::Gray16 { bits } => bits,
            hilcam::scene::PixelFormat::Rgb565 => 16,
        }
    }

    #[getter]
    fn exposure(&self) -> f64 {
        self.r.desc.output.exposure
    }

    /// `R` (rows: the camera's axes in world coordinates) and `T` (the
    /// centre of projection, m), camera-model.md §1.
    fn pose_matrix(&self) -> PyResult<([[f64; 3]; 3], [f64; 3])> {
        self.r.pose.matrix().map_err(scene_err)
    }

    fn set_pose(&mut self, rotation: [[f64; 3]; 3], translation: [f64; 3]) -> PyResult<()> {
        self.pose(PoseDesc {
            eye: None,
            target: None,
            up: None,
            position: Some(translation),
            yaw_pitch_roll: None,
            rotation: Some(rotation),
        })
    }

    fn look_at(&mut self, eye: [f64; 3], target: [f64; 3], up: [f64; 3]) -> PyResult<()> {
        self.pose(PoseDesc {
            eye: Some(eye),
            target: Some(target),
            up: Some(up),
            position: None,
            yaw_pitch_roll: None,
            rotation: None,
        })
    }

    fn set_exposure(&mut self, k: f64) -> PyResult<()> {
        self.edit(|d| d.output.exposure = k)
    }

    #[pyo3(signature = (format, bits=None))]
    fn set_format(&mut self, format: String, bits: Option<u8>) -> PyResult<()> {
        self.edit(|d| {
            d.output.format = format;
            d.output.bits = bits;
        })
    }

    /// Renders frame `frame_id` with the planner's choice (or `variant`,
    /// as `host-sim frame --variant` names them): `(pixels, flags, truth
    /// JSON, plan JSON)`, the pixels the core's (and the wire's) bytes.
    #[pyo3(signature = (frame_id, variant="planned"))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        frame_id: u32,
        variant: &str,
    ) -> PyResult<(Bound<'py, PyBytes>, Bound<'py, PyBytes>, String, String)> {
        let variant =
            host_sim::variant::Variant::parse(variant).map_err(|e| scene_err(format!("variant: {e}")))?;
        let f = py
            .detach(|| host_sim::truth::render(&self.r, &variant, frame_id))
            .map_err(scene_err)?;
        let truth = serde_json::to_string(&f.truth).map_err(|e| scene_err(e.to_string()))?;
        let plan = serde_json::to_string(&f.plan).map_err(|e| scene_err(e.to_string()))?;
        Ok((
            PyBytes::new(py, &f.pixels),
            PyBytes::new(py, &f.flags),
            truth,
            plan,
        ))
    }

    /// The ray each pixel's centre images, as the renderer computes it:
    /// OpenCV's normalized `(x, y)`, row by row, NaN outside the lens field.
    fn pixel_rays(&self, py: Python<'_>) -> PyResult<Vec<[f64; 2]>> {
        py.detach(|| host_sim::truth::pixel_rays(&self.r))
            .map_err(scene_err)
    }

    /// The OpenCV export (`host-sim export`) as JSON.
    fn export(&self) -> PyResult<String> {
        let e = host_sim::export::export(&self.r).map_err(scene_err)?;
        serde_json::to_string(&e).map_err(|e| scene_err(e.to_string()))
    }

    /// The scene as the link's scene data (what `LoadScene` carries).
    fn scene_data<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        Ok(PyBytes::new(py, &self.r.scene_bytes().map_err(scene_err)?))
    }
}

/// A camera on a serial device or pty, through host-sim's client.
#[pyclass(module = "hilcam._hilcam", unsendable)]
struct NativeCamera {
    c: Option<SerialClient>,
}

impl NativeCamera {
    fn client(&mut self) -> PyResult<&mut SerialClient> {
        self.c
            .as_mut()
            .ok_or_else(|| LinkError::new_err("the camera's port is closed"))
    }
}

#[pymethods]
impl NativeCamera {
    #[new]
    fn new(py: Python<'_>, port: String, baud: u32, timeout: f64) -> PyResult<NativeCamera> {
        let mut c = py
            .detach(|| SerialClient::open(&port, baud))
            .map_err(client_err)?;
        c.timeout = Duration::try_from_secs_f64(timeout)
            .map_err(|_| PyValueError::new_err(format!("timeout: {timeout} s is not a duration")))?;
        Ok(NativeCamera { c: Some(c) })
    }

    /// The camera's description as JSON (docs/wire.md, `Description`).
    fn describe(&mut self, py: Python<'_>) -> PyResult<String> {
        let c = self.client()?;
        let d = py.detach(|| c.describe()).map_err(client_err)?;
        serde_json::to_string(&d).map_err(|e| LinkError::new_err(e.to_string()))
    }

    /// Returns the command's sequence number.
    fn set_pose(&mut self, py: Python<'_>, rotation: [[f64; 3]; 3], translation: [f64; 3]) -> PyResult<u32> {
        let c = self.client()?;
        Ok(py
            .detach(|| c.set_pose(rotation, translation))
            .map_err(client_err)?
            .seq)
    }

    fn look_at(&mut self, py: Python<'_>, eye: [f64; 3], target: [f64; 3], up: [f64; 3]) -> PyResult<u32> {
        let c = self.client()?;
        Ok(py.detach(|| c.look_at(eye, target, up)).map_err(client_err)?.seq)
    }

    fn set_exposure(&mut self, py: Python<'_>, k: f64) -> PyResult<u32> {
        let c = self.client()?;
        Ok(py.detach(|| c.set_exposure(k)).map_err(client_err)?.seq)
    }

    /// Triggered (`period_us` None) or free-running every `period_us` µs.
    #[pyo3(signature = (period_us=None))]
    fn set_mode(&mut self, py: Python<'_>, period_us: Option<u32>) -> PyResult<u32> {
        let mode = match period_us {
            None => hilcam::link::Mode::Triggered,
            Some(period_us) => hilcam::link::Mode::FreeRun { period_us },
        };
        let c = self.client()?;
        Ok(py.detach(|| c.set_mode(mode)).map_err(client_err)?.seq)
    }

    fn select_scene(&mut self, py: Python<'_>, id: u32) -> PyResult<u32> {
        let c = self.client()?;
        Ok(py.detach(|| c.select_scene(id)).map_err(client_err)?.seq)
    }

    fn trigger(&mut self, py: Python<'_>, frames: u16) -> PyResult<u32> {
        let c = self.client()?;
        Ok(py.detach(|| c.trigger(frames)).map_err(client_err)?.seq)
    }

    /// Sends `scene` as data; returns the id it is shown under.
    fn load_scene(&mut self, py: Python<'_>, scene: &NativeScene) -> PyResult<u32> {
        let c = self.client()?;
        Ok(py
            .detach(|| c.load_scene_file(&scene.r))
            .map_err(client_err)?
            .scene_id)
    }

    /// The next frame within `timeout` s: `(pixels, flags, header JSON)`,
    /// or None.
    #[allow(clippy::type_complexity)]
    fn next_frame<'py>(
        &mut self,
        py: Python<'py>,
        timeout: f64,
    ) -> PyResult<Option<(Bound<'py, PyBytes>, Bound<'py, PyBytes>, String)>> {
        let wait = Duration::try_from_secs_f64(timeout)
            .map_err(|_| PyValueError::new_err(format!("timeout: {timeout} s is not a duration")))?;
        let c = self.client()?;
        let Some(a) = py.detach(|| c.next_frame(wait)).map_err(LinkError::new_err)? else {
            return Ok(None);
        };
        let f = a.frame;
        let (format, bits) = match f.start.format {
            hilcam::link::WireFormat::Gray8 => ("gray8", 8),
            hilcam::link::WireFormat::Gray16 { bits } => ("gray16", bits),
            hilcam::link::WireFormat::Rgb565 => ("rgb565", 16),
        };
        let header = serde_json::json!({
            "frame_id": f.start.frame_id,
            "scene_id": f.start.scene_id,
            "width": f.start.width,
            "height": f.start.height,
            "format": format,
            "bits": bits,
            "exposure": f.start.exposure as f64 / 4_294_967_296.0,
            "outside_field": f.end.outside,
            "truth": host_sim::drive_cmd::TruthView::from(&f.start.truth),
        });
        Ok(Some((
            PyBytes::new(py, &f.pixels),
            PyBytes::new(py, &f.flags),
            header.to_string(),
        )))
    }

    /// Closes the port (the camera keeps running).
    fn close(&mut self) {
        self.c = None;
    }
}

/// The native module.
#[pymodule]
fn _hilcam(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeScene>()?;
    m.add_class::<NativeCamera>()?;
    m.add("Refused", m.py().get_type::<Refused>())?;
    m.add("LinkError", m.py().get_type::<LinkError>())?;
    Ok(())
}
