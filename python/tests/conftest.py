"""Shared by the package's tests: the repository, host-sim, and a camera on a pty link."""

import os
import subprocess
from pathlib import Path

import pytest

from hilcam.pty import PtyLink

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def host_sim() -> str:
    """The host-sim binary: $HILCAM_HOST_SIM, else the workspace's build."""
    env = os.environ.get("HILCAM_HOST_SIM")
    for p in [env] if env else [ROOT / "target/debug/host-sim", ROOT / "target/release/host-sim"]:
        if p and Path(p).is_file():
            return str(p)
    pytest.fail("host-sim is not built: cargo build -p host-sim, or set HILCAM_HOST_SIM")


@pytest.fixture(scope="session")
def scenes() -> Path:
    return ROOT / "scenes"


class CameraSession:
    """``host-sim camera`` on one end of a pty link (``link.a``); ``path``
    is the other end, for the client."""

    def __init__(self, host_sim, scene):
        self.link = PtyLink()
        self.path = self.link.b
        self.proc = subprocess.Popen(
            [host_sim, "camera", "--device", self.link.a, "--scene", str(scene)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )

    def hang_up(self, timeout: float = 20.0):
        """Closes the link; returns the camera's exit code, stdout and stderr."""
        self.link.close()
        out, err = self.proc.communicate(timeout=timeout)
        return self.proc.returncode, out.decode(), err.decode()

    def close(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self.link.close()


@pytest.fixture
def camera_session(host_sim, scenes):
    """A camera holding the standard scene, on a pty link."""
    s = CameraSession(host_sim, scenes / "standard.toml")
    try:
        yield s
    finally:
        s.close()


@pytest.fixture
def camera_link(camera_session):
    """The client's end of a camera session's link."""
    return camera_session.path
