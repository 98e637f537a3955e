"""Shared by the package's tests: the repository, host-sim, and a pty link."""

import os
import select
import subprocess
import threading
import time
import tty
from pathlib import Path

import pytest

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


class Link:
    """Two ptys bridged master to master, as a serial cable: each end's
    slave is a path a program opens as its serial device."""

    def __init__(self):
        self.ma, sa = os.openpty()
        self.mb, sb = os.openpty()
        for fd in (self.ma, self.mb):
            tty.setraw(fd)
        self.a, self.b = os.ttyname(sa), os.ttyname(sb)
        # The slaves stay open here too, so that a master does not see a
        # hang-up before its program opens its end.
        self._slaves = (sa, sb)
        self._stop = threading.Event()
        self._paused_until = 0.0
        self._t = threading.Thread(target=self._pump, daemon=True)
        self._t.start()

    def pause(self, seconds: float):
        """Stops carrying bytes for ``seconds``: a host that stops reading
        (and writing) for a moment; the writers' buffers fill."""
        self._paused_until = time.monotonic() + seconds

    def _pump(self):
        peer = {self.ma: self.mb, self.mb: self.ma}
        while not self._stop.is_set():
            if time.monotonic() < self._paused_until:
                time.sleep(0.01)
                continue
            ready, _, _ = select.select(list(peer), [], [], 0.05)
            for fd in ready:
                try:
                    data = os.read(fd, 1 << 16)
                except OSError:
                    continue
                view = memoryview(data)
                while view:
                    try:
                        view = view[os.write(peer[fd], view):]
                    except BlockingIOError:
                        select.select([], [peer[fd]], [], 0.05)

    def close(self):
        self._stop.set()
        self._t.join()
        for fd in (self.ma, self.mb, *self._slaves):
            os.close(fd)


class CameraSession:
    """``host-sim camera`` on one end of a pty link (``link.a``); ``path``
    is the other end, for the client."""

    def __init__(self, host_sim, scene):
        self.link = Link()
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
        if not self.link._stop.is_set():
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
