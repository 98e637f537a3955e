#!/usr/bin/env python3
"""The ground-truth export, checked by OpenCV itself, through the hilcam
Python package: for every shipped scene, `Scene.opencv()` gives the camera
in OpenCV's conventions; cv2.projectPoints with those values alone images
the export's world points, compared with the pixels where the emulator
images them (the contract's model, f64). Each camera must agree within the
residual its export states (plus 1e-6 px of arithmetic), at most 0.05 px.
`host-sim export`'s opencv.yaml, read with cv2.FileStorage, must hold the
same camera. Exits 1 if a camera misses; writes export-check.json into
--out.

Run it with the virtual environment's Python (target/venv: scripts/lib.sh
ensure_venv installs hilcam, numpy and opencv-python-headless there)."""
import argparse
import json
import pathlib
import subprocess
import sys

import cv2
import numpy as np

import hilcam

ROOT = pathlib.Path(__file__).resolve().parent.parent


def yaml_camera(host_sim, scene, d):
    """host-sim export's opencv.yaml, as OpenCV reads it."""
    subprocess.run([str(host_sim), "export", "--scene", str(scene), "--out", str(d)],
                   check=True, capture_output=True, text=True)
    fs = cv2.FileStorage(str(d / "opencv.yaml"), cv2.FILE_STORAGE_READ)
    v = {n: fs.getNode(n).mat() for n in ("camera_matrix", "distortion_coefficients",
                                          "rotation_matrix", "translation_vector")}
    v["max_residual_px"] = fs.getNode("max_residual_px").real()
    fs.release()
    return v


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "out" / "export"))
    ap.add_argument("--host-sim", default=str(ROOT / "target" / "release" / "host-sim"),
                    help="the host-sim binary whose export files are read")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    rows, ok = [], True
    for path in sorted((ROOT / "scenes").glob("*.toml")):
        name = path.stem
        scene = hilcam.Scene.from_toml(path)
        try:
            k, dist, rvec, tvec, size = scene.opencv()
        except hilcam.SceneError as e:
            print(f"{name}: not exported: {e}")
            rows.append({"camera": name, "exported": False, "why": str(e)})
            continue
        e = scene.export()
        stated = float(e["distortion"]["residual_px"])
        model = e["distortion"]["model"]
        world = np.array(e["world_points"], dtype=np.float64)
        want = np.array(e["pixels"], dtype=np.float64)
        got, _ = cv2.projectPoints(world, rvec, tvec, k, dist)
        worst = float(np.linalg.norm(got.reshape(-1, 2) - want, axis=1).max())
        y = yaml_camera(args.host_sim, path, out / name)
        same_yaml = (np.allclose(y["camera_matrix"], k, rtol=1e-15, atol=0)
                     and np.allclose(y["distortion_coefficients"].ravel(), dist, rtol=1e-15, atol=0)
                     and np.allclose(y["rotation_matrix"], cv2.Rodrigues(rvec)[0], rtol=0, atol=1e-12)
                     and np.allclose(y["translation_vector"].ravel(), tvec.ravel(), rtol=1e-15, atol=1e-15)
                     and y["max_residual_px"] == stated)
        good = worst <= stated + 1e-6 and stated <= 0.05 and same_yaml
        ok &= good
        rows.append({"camera": name, "exported": True, "model": model, "size": list(size),
                     "coefficients": int(dist.size), "stated_residual_px": stated,
                     "max_projectPoints_error_px": worst, "points": int(len(world)),
                     "opencv_yaml_same": bool(same_yaml), "ok": good})
        print(f"{name:<20} {model:<20} stated {stated:.2e} px, cv2.projectPoints max "
              f"{worst:.2e} px over {len(world)} points{'' if same_yaml else ', opencv.yaml DIFFERS'} "
              f"{'ok' if good else 'FAIL'}")
    out.mkdir(parents=True, exist_ok=True)
    (out / "export-check.json").write_text(json.dumps(rows, indent=2))
    if not ok:
        print("a camera's export disagrees with OpenCV beyond its stated residual, states more than 0.05 px, "
              "or its opencv.yaml differs from the package's")
        sys.exit(1)


main()
