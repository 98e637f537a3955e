#!/usr/bin/env python3
"""A system under test's loop in Python against `host-sim camera` over a pty
link (hilcam.pty.PtyLink): frames a second and trigger-to-frame latency at
160x120 and 640x480, through the hilcam package (frames as numpy arrays
with their truth) and through its native calls alone (the Rust client's
work: no numpy, no JSON), alternating on one session — the difference is
what the Python layer adds.
Then the camera's robustness: a reader paused for --pause s while frames
are due, after which every frame must arrive intact, and --sessions
sessions each hung up after its frames, each of which must end with exit 0.
Writes python-loop.json into --out; exits 1 if a robustness check fails.

Run it with the virtual environment's Python (target/venv)."""
import argparse
import json
import pathlib
import platform
import statistics
import subprocess
import sys
import time

import hilcam
from hilcam.pty import PtyLink

ROOT = pathlib.Path(__file__).resolve().parent.parent


def camera(host_sim, scene, link):
    return subprocess.Popen([host_sim, "camera", "--device", link.a, "--scene", str(scene)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def connect(path):
    return hilcam.Camera.when_ready(path)


def loop(host_sim, scene, frames):
    """Trigger-to-frame times (s) of `frames` triggers through the package
    and as many through its native calls alone, alternating on one camera
    session (so that both see the same camera, link and machine load)."""
    times = {"python": [], "native": []}
    with PtyLink() as link:
        proc = camera(host_sim, scene, link)
        try:
            with connect(link.b) as cam:
                cam.trigger(1)
                list(cam.frames(timeout=20, count=1))
                for k in range(2 * frames):
                    native = k % 2 == 1
                    t = time.perf_counter()
                    if native:
                        cam._n.trigger(1)
                        got = cam._n.next_frame(20.0)
                    else:
                        cam.trigger(1)
                        got = next(cam.frames(timeout=20, count=1), None)
                    if got is None:
                        raise SystemExit(f"{scene.name}: a frame did not arrive")
                    times["native" if native else "python"].append(time.perf_counter() - t)
        finally:
            proc.kill()
            proc.wait()
    return times


def paused(host_sim, scene, n, pause):
    """Triggers `n` frames, stops reading for `pause` s; frames that arrive after."""
    with PtyLink() as link:
        proc = camera(host_sim, scene, link)
        try:
            with connect(link.b) as cam:
                cam.trigger(n)
                link.pause(pause)
                got = list(cam.frames(timeout=pause + 20, count=n))
                alive = proc.poll() is None
        finally:
            proc.kill()
            proc.wait()
    return len({f.frame_id for f in got}), alive


def sessions(host_sim, scene, n):
    """Exit codes of `n` sessions, each hung up after its 2 frames."""
    codes = []
    for _ in range(n):
        link = PtyLink()
        proc = camera(host_sim, scene, link)
        try:
            with connect(link.b) as cam:
                cam.trigger(2)
                list(cam.frames(timeout=20, count=2))
            link.close()
            proc.communicate(timeout=20)
            codes.append(proc.returncode)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            link.close()
    return codes


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--host-sim", default=str(ROOT / "target" / "release" / "host-sim"))
    ap.add_argument("--out", default=str(ROOT / "out" / "python-loop"))
    ap.add_argument("--frames", type=int, default=300, help="triggers a client at 160x120 (a fifth at 640x480)")
    ap.add_argument("--pause", type=float, default=10.0, help="seconds the reader pauses")
    ap.add_argument("--sessions", type=int, default=100, help="hang-up sessions")
    a = ap.parse_args()
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    standard = ROOT / "scenes" / "standard.toml"
    wide = out / "standard-640.toml"
    text = standard.read_text()
    for old, new in [("width = 160", "width = 640"), ("height = 120", "height = 480"),
                     ("pitch = 12e-6", "pitch = 3e-6"), ("tolerable_blur = 12e-6", "tolerable_blur = 3e-6")]:
        text = text.replace(old, new)
    wide.write_text(text)
    res = {"command": "target/venv/bin/python " + " ".join(["scripts/python-loop.py"] + sys.argv[1:]),
           "machine": f"{platform.machine()}, {platform.processor() or platform.system()}",
           "date": time.strftime("%Y-%m-%d"), "sizes": {}}
    for name, scene, frames in [("160x120", standard, a.frames), ("640x480", wide, max(10, a.frames // 5))]:
        row = {}
        for client, lat in loop(a.host_sim, scene, frames).items():
            row[client] = {"frames": frames, "fps": len(lat) / sum(lat),
                           "latency_ms_median": 1e3 * statistics.median(lat), "latency_ms_max": 1e3 * max(lat)}
        row["python_overhead"] = row["native"]["fps"] / row["python"]["fps"] - 1.0
        res["sizes"][name] = row
        print(f"{name}: Python client {row['python']['fps']:.1f} frames/s (trigger to frame median "
              f"{row['python']['latency_ms_median']:.2f} ms), native calls alone {row['native']['fps']:.1f} "
              f"frames/s ({row['native']['latency_ms_median']:.2f} ms): the Python layer adds "
              f"{100 * row['python_overhead']:.1f} %")
    n = 20
    got, alive = paused(a.host_sim, standard, n, a.pause)
    res["paused_reader"] = {"pause_s": a.pause, "frames_triggered": n, "frames_received": got, "camera_alive": alive}
    print(f"reader paused {a.pause:g} s with {n} frames due: {got} of {n} received, camera "
          f"{'running' if alive else 'ENDED'}")
    codes = sessions(a.host_sim, standard, a.sessions)
    zero = sum(c == 0 for c in codes)
    res["hang_up_sessions"] = {"sessions": len(codes), "exit_0": zero,
                               "other_exits": sorted({c for c in codes if c != 0})}
    print(f"hang-up after every frame: {zero} of {len(codes)} sessions exit 0")
    (out / "python-loop.json").write_text(json.dumps(res, indent=2))
    ok = got == n and alive and zero == len(codes)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
