"""A serial cable on one machine: two ptys whose masters are bridged.

Each end's slave is a path a program opens as its serial device — a camera
(``host-sim camera --device A``) on one, a client (``hilcam.Camera(B)``) on
the other — with no other program needed (``socat`` makes the same). The
bridge can pause, as a host that stops reading for a moment."""

from __future__ import annotations

import os
import select
import threading
import time
import tty


class PtyLink:
    """Two ptys bridged master to master; ``a`` and ``b`` are the ends' paths."""

    def __init__(self) -> None:
        self._ma, sa = os.openpty()
        self._mb, sb = os.openpty()
        for fd in (self._ma, self._mb):
            tty.setraw(fd)
        self.a: str = os.ttyname(sa)
        self.b: str = os.ttyname(sb)
        # The slaves stay open here too, so that a master sees no hang-up
        # before its program opens its end.
        self._slaves = (sa, sb)
        self._stop = threading.Event()
        self._paused_until = 0.0
        self._t = threading.Thread(target=self._pump, daemon=True)
        self._t.start()

    def pause(self, seconds: float) -> None:
        """Carries no byte for ``seconds``: both ends' writes fill their buffers and wait."""
        self._paused_until = time.monotonic() + seconds

    @property
    def closed(self) -> bool:
        return self._stop.is_set()

    def _pump(self) -> None:
        peer = {self._ma: self._mb, self._mb: self._ma}
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

    def close(self) -> None:
        """Hangs up both ends."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._t.join()
        for fd in (self._ma, self._mb, *self._slaves):
            os.close(fd)

    def __enter__(self) -> "PtyLink":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
