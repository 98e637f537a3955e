"""hilcam from Python: scenes, frames with their ground truth, and a camera client.

A test bench renders frames on the host::

    import hilcam
    scene = hilcam.Scene.from_toml("scenes/standard.toml")
    scene.look_at(eye=(0.0, -2.0, 1.2), target=(0.0, 0.0, 0.2), up=(0.0, 0.0, 1.0))
    frame = scene.render()
    frame.image          # numpy array, the pixels of host-sim frame's frame.png
    frame.truth["K"]     # 3x3 camera matrix (OpenCV's pixel convention)

or drives a camera (the firmware on a board, or ``host-sim camera``) over a
serial port or pty::

    with hilcam.Camera("/dev/ttyACM0") as cam:
        cam.set_pose(R, T)
        cam.trigger(1)
        for frame in cam.frames(timeout=2.0, count=1):
            ...

Frames, poses and units follow the camera model (docs/camera-model in the
repository): ``R`` has the camera's axes in world coordinates as rows and
``T`` is the centre of projection in metres. :meth:`Scene.opencv` gives the
same camera in OpenCV's conventions.
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass, field
from typing import Any, Dict, Iterator, Optional, Sequence, Tuple, Union

import numpy as np

from . import _hilcam
from ._hilcam import LinkError, Refused

__all__ = ["Scene", "Frame", "Camera", "SceneError", "Refused", "LinkError"]

Matrix3 = Sequence[Sequence[float]]
Vector3 = Sequence[float]


class SceneError(ValueError):
    """A scene (a file, or a value set on it) that hilcam refuses.

    ``field`` names the scene file's key at fault (``camera.pose.eye``,
    ``output.exposure``, ...), or is empty when the message names none.
    """

    def __init__(self, message: str):
        super().__init__(message)
        # "[file: ][line N: ]key: why": the first part shaped as a key
        # that is not the file.
        parts = [p for p in message.split(": ")[:-1] if not p.endswith(".toml")]
        self.field = next((p for p in parts if _KEY.fullmatch(p)), "")


_KEY = re.compile(r"[a-z_]+(\[\d+\])?(\.[a-z_0-9]+(\[\d+\])?)*")


def _scene_call(f, *args):
    try:
        return f(*args)
    except ValueError as e:
        raise SceneError(str(e)) from None


def _matrix(m: Matrix3, name: str) -> list:
    a = np.asarray(m, dtype=float)
    if a.shape != (3, 3):
        raise SceneError(f"{name}: a 3x3 matrix expected, got shape {a.shape}")
    return a.tolist()


def _vector(v: Vector3, name: str) -> list:
    a = np.asarray(v, dtype=float)
    if a.shape != (3,):
        raise SceneError(f"{name}: 3 numbers expected, got shape {a.shape}")
    return a.tolist()


def _pixels(raw: bytes, fmt: str, bits: int, width: int, height: int) -> Tuple[np.ndarray, np.ndarray]:
    """The frame's image (the PNG's values) and its digital numbers."""
    if fmt == "gray8":
        dn = np.frombuffer(raw, dtype=np.uint8).reshape(height, width)
        return dn.copy(), dn.copy()
    v = np.frombuffer(raw, dtype="<u2").reshape(height, width)
    if fmt == "gray16":
        dn = v.astype(np.uint16)
        return (dn << (16 - bits)).astype(np.uint16), dn
    r, g, b = v >> 11, (v >> 5) & 63, v & 31
    dn = np.stack([r, g, b], axis=-1).astype(np.uint8)
    image = np.stack([r * 255 // 31, g * 255 // 63, b * 255 // 31], axis=-1).astype(np.uint8)
    return image, dn


def _flags(raw: bytes, width: int, height: int) -> np.ndarray:
    if len(raw) == 0:
        return np.zeros((height, width), dtype=np.uint8)
    return np.frombuffer(raw, dtype=np.uint8).reshape(height, width).copy()


@dataclass
class Frame:
    """A rendered or received frame.

    ``image``: what the frame's PNG holds — uint8 H×W (gray8), uint16 H×W
    with the ``bits`` significant bits at the top (gray16), uint8 H×W×3 RGB
    (rgb565 expanded to 8 bits a channel). ``dn``: the sensor's digital
    numbers (gray16: 0 to 2^bits − 1; rgb565: 5, 6 and 5 bits). ``flags``:
    uint8 H×W, bit 0 set where the pixel is outside the lens field (its
    value is the background's). ``truth``: the frame's ground truth.
    ``plan``: what the planner chose (rendered frames; empty for received
    ones).
    """

    image: np.ndarray
    dn: np.ndarray
    flags: np.ndarray
    format: str
    bits: int
    frame_id: int
    truth: Dict[str, Any]
    plan: Dict[str, Any] = field(default_factory=dict)

    @property
    def outside(self) -> np.ndarray:
        """Boolean H×W mask of pixels outside the lens field."""
        return (self.flags & 1).astype(bool)


class Scene:
    """A scene file (TOML, docs/scenes.md), checked as ``host-sim`` checks it.

    Setters check the whole scene again and raise :class:`SceneError`
    naming the key; on error the scene is unchanged.
    """

    def __init__(self, native: "_hilcam.NativeScene"):
        self._n = native

    @classmethod
    def from_toml(cls, source: Union[str, os.PathLike]) -> "Scene":
        """A scene from a file path or from TOML text."""
        if isinstance(source, os.PathLike) or os.path.exists(source) or ("\n" not in source and "=" not in source):
            return cls(_scene_call(_hilcam.NativeScene.load, os.fspath(source)))
        return cls(_scene_call(_hilcam.NativeScene.parse, source))

    @property
    def name(self) -> str:
        return self._n.name

    @property
    def size(self) -> Tuple[int, int]:
        """``(width, height)``, pixels."""
        return (self._n.width, self._n.height)

    @property
    def format(self) -> str:
        """``gray8``, ``gray16`` or ``rgb565``."""
        return self._n.format

    @property
    def bits(self) -> int:
        return self._n.bits

    @property
    def exposure(self) -> float:
        """The exposure ``K``, DN per W/m²."""
        return self._n.exposure

    @property
    def pose(self) -> Tuple[np.ndarray, np.ndarray]:
        """``(R, T)``: rows of ``R`` are the camera's axes in world coordinates; ``T`` the centre, m."""
        r, t = _scene_call(self._n.pose_matrix)
        return np.array(r), np.array(t)

    def set_pose(self, R: Matrix3, T: Vector3) -> None:
        """Sets the pose: ``R`` orthonormal (det +1), ``T`` the centre of projection, m."""
        _scene_call(self._n.set_pose, _matrix(R, "camera.pose.rotation"), _vector(T, "camera.pose.position"))

    def look_at(self, eye: Vector3, target: Vector3, up: Vector3 = (0.0, 0.0, 1.0)) -> None:
        """Sets the pose looking from ``eye`` at ``target`` (m), ``up`` up."""
        _scene_call(
            self._n.look_at,
            _vector(eye, "camera.pose.eye"),
            _vector(target, "camera.pose.target"),
            _vector(up, "camera.pose.up"),
        )

    def set_exposure(self, k: float) -> None:
        """Sets the exposure ``K``, DN per W/m²."""
        _scene_call(self._n.set_exposure, float(k))

    def set_format(self, format: str, bits: Optional[int] = None) -> None:
        """Sets the pixel format: ``gray8``, ``gray16`` (with ``bits``, 9 to 16) or ``rgb565``."""
        _scene_call(self._n.set_format, format, bits)

    def render(self, frame_id: int = 0, variant: str = "planned") -> Frame:
        """Renders a frame with the planner's choice (the bytes ``host-sim frame`` writes).

        ``frame_id`` keys the sensor noise: the same id, the same frame.
        ``variant`` trades accuracy for speed as ``host-sim frame
        --variant`` does (e.g. ``i32f32-s1``: one sample a pixel).
        """
        pixels, flags, truth, plan = _scene_call(self._n.render, int(frame_id), variant)
        t = json.loads(truth)
        w, h = self.size
        image, dn = _pixels(pixels, self.format, self.bits, w, h)
        t["K"] = [[t["fx"], 0.0, t["cx"]], [0.0, t["fy"], t["cy"]], [0.0, 0.0, 1.0]]
        t["R"] = t["rotation"]
        t["T"] = t["translation"]
        t["frame_id"] = int(frame_id)
        return Frame(image, dn, _flags(flags, w, h), self.format, self.bits, int(frame_id), t, json.loads(plan))

    def opencv(self) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, Tuple[int, int]]:
        """The camera in OpenCV's conventions: ``(camera_matrix, dist_coeffs, rvec, tvec, image_size)``.

        The refit ``host-sim export`` makes (plumb_bob, or rational_polynomial
        where plumb_bob's residual is too large); its residual, px, is
        ``export()["distortion"]["residual_px"]``. World to camera:
        ``x_cam = R(rvec) X + tvec``.
        """
        e = self.export()
        k = np.array(e["camera_matrix"], dtype=float).reshape(3, 3)
        d = np.array(e["distortion"]["coefficients"], dtype=float)
        rvec = _rodrigues(np.array(e["rotation"], dtype=float).reshape(3, 3))
        tvec = np.array(e["translation"], dtype=float).reshape(3, 1)
        return k, d, rvec, tvec, (int(e["width"]), int(e["height"]))

    def pixel_rays(self) -> np.ndarray:
        """The ray each pixel's centre images, as the renderer computes it:
        an (H, W, 2) array of OpenCV's normalized (x, y) — the point
        (x, y, 1) in OpenCV's camera frame, x right, y down — NaN outside
        the lens field. ``cv2.projectPoints`` of these with the camera's
        own calibration gives back each pixel's position."""
        w, h = self.size
        rays = _scene_call(self._n.pixel_rays)
        return np.asarray(rays, dtype=np.float64).reshape(h, w, 2)

    def export(self) -> Dict[str, Any]:
        """``host-sim export``'s export.json: the camera matrix, the refit
        distortion with its residual, R and t in OpenCV's convention, and
        world points with the pixels where this camera images them."""
        return json.loads(_scene_call(self._n.export))

    def scene_data(self) -> bytes:
        """The scene as the link's scene data (what ``Camera.load_scene`` sends)."""
        return _scene_call(self._n.scene_data)


def _rodrigues(r: np.ndarray) -> np.ndarray:
    """A rotation matrix as a rotation vector (OpenCV's ``rvec``), 3×1."""
    c = max(-1.0, min(1.0, (np.trace(r) - 1.0) / 2.0))
    angle = math.acos(c)
    if angle < 1e-12:
        return np.zeros((3, 1))
    if math.pi - angle < 1e-6:
        # Near π: the axis from the symmetric part.
        m = (r + np.eye(3)) / 2.0
        k = int(np.argmax(np.diag(m)))
        axis = m[:, k] / math.sqrt(m[k, k])
        return (axis * angle).reshape(3, 1)
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / (2.0 * math.sin(angle))
    return (axis * angle).reshape(3, 1)


class Camera:
    """A camera on a serial device or pty: the firmware, or ``host-sim camera``.

    Each command waits for the camera's answer (resent after ``timeout`` s
    of silence, three times at most); a refusal raises :class:`Refused`
    (``.args``: message, command, reason, field), a failed link
    :class:`LinkError`. Use it as a context manager to close the port.
    """

    def __init__(self, port: str, baud: int = 921_600, timeout: float = 10.0):
        self._n = _hilcam.NativeCamera(port, int(baud), float(timeout))

    @classmethod
    def when_ready(cls, port: str, baud: int = 921_600, timeout: float = 0.5, within: float = 30.0) -> "Camera":
        """Opens the camera on ``port`` once it answers: for a camera that is
        still starting (a process just launched, a board booting). Raises
        :class:`LinkError` if it has not answered within ``within`` s."""
        import time

        deadline = time.monotonic() + within
        while True:
            try:
                return cls(port, baud, timeout)
            except LinkError:
                if time.monotonic() > deadline:
                    raise

    def __enter__(self) -> "Camera":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        """Closes the port; the camera keeps running."""
        self._n.close()

    def describe(self) -> Dict[str, Any]:
        """What the camera is and does now: size, format, scenes, mode, ..."""
        return json.loads(self._n.describe())

    def set_pose(self, R: Matrix3, T: Vector3) -> int:
        """The pose of the next frames; returns the command's sequence number."""
        return self._n.set_pose(_matrix(R, "rotation"), _vector(T, "translation"))

    def look_at(self, eye: Vector3, target: Vector3, up: Vector3 = (0.0, 0.0, 1.0)) -> int:
        return self._n.look_at(_vector(eye, "eye"), _vector(target, "target"), _vector(up, "up"))

    def set_exposure(self, k: float) -> int:
        """The exposure ``K``, DN per W/m² (0 to 1e9)."""
        return self._n.set_exposure(float(k))

    def set_mode(self, mode: str = "triggered", period_us: int = 0) -> int:
        """``"triggered"`` or ``"free_run"`` (a frame every ``period_us`` µs; 0: back to back)."""
        if mode == "triggered":
            return self._n.set_mode(None)
        if mode == "free_run":
            return self._n.set_mode(int(period_us))
        raise ValueError(f"mode: {mode!r} is neither 'triggered' nor 'free_run'")

    def load_scene(self, scene: Scene) -> int:
        """Sends ``scene`` as data; returns the id the camera shows it under."""
        return self._n.load_scene(scene._n)

    def select_scene(self, id: int) -> int:
        return self._n.select_scene(int(id))

    def trigger(self, n: int = 1) -> int:
        """Asks for ``n`` more frames (triggered mode)."""
        return self._n.trigger(int(n))

    def frames(self, timeout: float = 5.0, count: Optional[int] = None) -> Iterator[Frame]:
        """Frames as they arrive, each with its truth; stops after ``count``
        frames, or when none arrives within ``timeout`` s."""
        got = 0
        while count is None or got < count:
            r = self._n.next_frame(float(timeout))
            if r is None:
                return
            pixels, flags, header = r
            h = json.loads(header)
            w, ht = h["width"], h["height"]
            image, dn = _pixels(pixels, h["format"], h["bits"], w, ht)
            truth = dict(h["truth"])
            truth.update({k: h[k] for k in ("scene_id", "exposure", "outside_field")})
            truth["R"], truth["T"] = truth["rotation"], truth["translation"]
            got += 1
            yield Frame(image, dn, _flags(flags, w, ht), h["format"], h["bits"], h["frame_id"], truth)
