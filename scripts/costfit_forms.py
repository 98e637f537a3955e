#!/usr/bin/env python3
"""Compares forms of the planner's sample-grid cost (planner::SampleCost) on
the committed calibration counts: each form's fit, and its error on the
sampled points of a calibration scene left out of the fit, one scene at a
time. Usage: python3 scripts/costfit_forms.py [docs/cost-calibration.json]
(needs numpy). The one-sample coefficients are fitted as host-sim costfit
fits them (least squares in relative error); `p` below is a sampled
point's one-sample prediction, `n` its samples, `c` 1 with the adaptive
rule (corner looks), else 0, `k` the primitives some ray can meet
(`Samples::prims`). The committed form is the last: with `g3` in the fast
arithmetic alone (`host-sim costfit` fits the wide one without it).
"""
import json
import sys

import numpy as np

FORMS = {
    "factors p (g0 (1-c) + g1 c + g2 n)  [an earlier form]": lambda p, n, c, k: [p * (1 - c), p * c, p * n],
    "g0 (1-c) + g1 c + g2 n p            [before 2026-12-05]": lambda p, n, c, k: [1 - c, c, n * p],
    "g0 (1-c) + g1 c + p (g2 n + g3 c)": lambda p, n, c, k: [1 - c, c, n * p, c * p],
    "g0 (1-c) + g1 c + p (g2 n + g3 c) + g4 n": lambda p, n, c, k: [1 - c, c, n * p, c * p, n],
    "g0 (1-c) + g1 c + n (g2 p + g3)": lambda p, n, c, k: [1 - c, c, n * p, n],
    "g0 (1-c) + g1 c + n (g2 p + g4 k)": lambda p, n, c, k: [1 - c, c, n * p, n * k],
    "g0 (1-c) + g1 c + n (g2 p + g3 + g4 k)": lambda p, n, c, k: [1 - c, c, n * p, n, n * k],
}


def one_sample(pt):
    s = pt["samples"]
    return s["grid"] == 1 and s["corners"] == 0 and s["aperture"] == 0


def fit_rel(rows, measured):
    a = rows / measured[:, None]
    coef, *_ = np.linalg.lstsq(a, np.ones(len(measured)), rcond=None)
    return coef


def overheads(points):
    """Per scene with a 2x2 and a 4x4 grid on every pixel (fast): the cost a
    sample (their difference over 12 samples) and what is left a pixel
    (the 2x2 point less 4 samples), beside its one-sample cost."""
    by = {}
    for p in points:
        if p["arithmetic"] == "fast":
            by.setdefault(p["scene"], {})[p["variant"]] = p["measured"]
    for scene, v in sorted(by.items()):
        s2, s4, one = v.get("mix32-s2"), v.get("mix32-s4"), v.get("mix32-poly")
        if s2 and s4 and one:
            per = (s4 - s2) / 12
            print(f"fast {scene}: one sample {one:.0f}, a grid sample {per:.0f}, overhead {s2 - 4 * per:.0f} a pixel")


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "docs/cost-calibration.json"
    points = json.load(open(path))["points"]
    overheads(points)
    for arithmetic in ("fast", "wide"):
        ours = [p for p in points if p["arithmetic"] == arithmetic]
        ones = [p for p in ours if one_sample(p)]
        x = np.array([p["features"] for p in ones])
        y = np.array([p["measured"] for p in ones])
        used = [k for k in range(x.shape[1]) if (x[:, k] != 0).any()]
        coef = np.zeros(x.shape[1])
        coef[used] = fit_rel(x[:, used], y)
        sampled = [p for p in ours if not one_sample(p) and p["samples"]["aperture"] == 0]
        pred = np.array([np.dot(coef, p["features"]) for p in sampled])
        meas = np.array([p["measured"] for p in sampled])
        scene = np.array([p["scene"] for p in sampled])
        for name, form in FORMS.items():
            m = np.array(
                [
                    form(pv, p["samples"]["grid"], p["samples"]["corners"], p["samples"].get("prims", 0.0))
                    for pv, p in zip(pred, sampled)
                ]
            )
            g = fit_rel(m, meas)
            e = (m @ g - meas) / meas
            left = []
            for s in sorted(set(scene)):
                keep = scene != s
                gl = fit_rel(m[keep], meas[keep])
                left += list((m[~keep] @ gl - meas[~keep]) / meas[~keep])
            left = np.array(left)
            print(
                f"{arithmetic} {name}: fit RMS {100 * np.sqrt((e ** 2).mean()):.1f} %, max {100 * abs(e).max():.1f} %;"
                f" left out RMS {100 * np.sqrt((left ** 2).mean()):.1f} %, max {100 * abs(left).max():.1f} %"
            )


if __name__ == "__main__":
    main()
