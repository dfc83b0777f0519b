#!/usr/bin/env python3
"""Calibration of `uncertainty_deg`: does the true direction lie inside the cone for 95%
of rows and events, on every kind of array?

Scenes are drawn from the seed given (rooms 5.5-9 x 4.5-7.5 x 2.6-3.4 m at RT60 0.2-0.8 s,
SNR 0-20 dB over a fan and diffuse noise, four ARCTIC utterances in turn 1-3 m away at
elevations -10 to 30 deg), rendered by `ssl simulate` for nine arrays (3-D, planar and
linear, 4 to 8 microphones, 6.5 cm to 50 cm, 16 and 48 kHz) and analysed by `ssl analyze
--events` at its defaults, or with the options given after `--` (`-- --every-frame`: every
frame's row, no events). A row is scored against the talker speaking at its time (0.3 s
of reverberation after allowed), an event against the talkers speaking during it.

Planar and linear arrays cannot tell a direction from its mirror image: the truth is taken
onto the side the array reports (above a horizontal plane; the +y side of a line along x),
as docs/interface.md defines the cone. A linear array's cone holds the half-circle around
its axis that it cannot resolve.

The constants of src/method/uncertainty.rs were chosen on other draws of the same kind
(seeds 900-905 of a development version of this script, drawn in another order; `--seed
900 --scenes 6` here gives 98.2% of rows); docs/uncertainty.md is this script's output for
seeds 100-107, which no choice saw:

    python3 benches/uncertainty.py --ssl target/release/ssl --seed 100 --scenes 8 > docs/uncertainty.md

Needs numpy (pip install numpy). About a minute on two cores.
"""

import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import draws as D  # noqa: E402  (the scene helpers of the fresh draws)


def circle(k, r):
    return [[r * math.cos(2 * math.pi * i / k), r * math.sin(2 * math.pi * i / k), 0.0] for i in range(k)]


def tetrahedron(edge):
    a = edge / (2 * math.sqrt(2))
    return [[a, a, a], [a, -a, -a], [-a, a, -a], [-a, -a, a]]


UP = np.array([0.0, 0.0, 1.0])
# name -> (positions, sample rate, normal of a planar array, axis of a linear one)
ARRAYS = {
    "prism, 8 mics, 50 x 40 x 36 cm, 48 kHz": ([[x * 0.25, y * 0.20, z * 0.18] for x in (1, -1) for y in (1, -1) for z in (1, -1)], 48000, None, None),
    "cube, 8 mics, 10 cm, 48 kHz": ([[x * 0.05, y * 0.05, z * 0.05] for x in (1, -1) for y in (1, -1) for z in (1, -1)], 48000, None, None),
    "tetrahedron, 4 mics, 6.5 cm, 16 kHz": (tetrahedron(0.065), 16000, None, None),
    "circle, 6 mics, r 4.63 cm, 16 kHz": (circle(6, 0.0463), 16000, UP, None),
    "square, 4 mics, 4.57 cm, 16 kHz": (circle(4, 0.0457 / math.sqrt(2)), 16000, UP, None),
    "circle, 8 mics, r 15 cm, 48 kHz": (circle(8, 0.15), 48000, UP, None),
    "circle, 8 mics, r 15 cm, 16 kHz": (circle(8, 0.15), 16000, UP, None),
    "line, 4 mics, 4.57 cm apart, 16 kHz": ([[0.0457 * (i - 1.5), 0, 0] for i in range(4)], 16000, None, np.array([1.0, 0, 0])),
    "line, 8 mics, 3 cm apart, 16 kHz": ([[0.03 * (i - 3.5), 0, 0] for i in range(8)], 16000, None, np.array([1.0, 0, 0])),
}


def write_geometry(work, k, name):
    path = os.path.join(work, f"array{k}.toml")
    with open(path, "w") as f:
        f.write(f"name = \"{name}\"\n")
        for q in ARRAYS[name][0]:
            f.write(f"[[mic]]\nposition = [{q[0]:.6f}, {q[1]:.6f}, {q[2]:.6f}]\n")
    return path


def scene(ssl, work, k, name, seed):
    rng = random.Random(seed * 31 + k)
    rate = ARRAYS[name][1]
    dims, pos = D.room_block(rng)
    rt60, snr = rng.uniform(0.2, 0.8), rng.uniform(0, 20)
    sources, duration = D.speech_turns(rng, dims, pos, 4, 30, (0.3, 1.0), (1.0, 3.0), D.clips())
    fans = D.fan_positions(rng, dims, pos, near=False)
    geometry = os.path.join(work, f"array{k}.toml")
    text = D.scene_toml(dims, pos, rt60, rate, duration, seed, geometry, sources, snr, fans, -6.0)
    d = os.path.join(work, f"{k}-{seed}")
    os.makedirs(d, exist_ok=True)
    toml, wav = os.path.join(d, "scene.toml"), os.path.join(d, "rec.wav")
    with open(toml, "w") as f:
        f.write(text)
    subprocess.run([ssl, "simulate", toml, "-o", wav], check=True, capture_output=True)
    return wav, geometry, sources


def fold(name, t):
    _, _, normal, axis = ARRAYS[name]
    if normal is not None and np.dot(t, normal) < 0:
        t = t - 2 * np.dot(t, normal) * normal
    if axis is not None and t[1] < 0:
        t = np.array([t[0], -t[1], t[2]])
    return t


def score(ssl, name, wav, geometry, sources, extra):
    events = [] if "--every-frame" in extra else ["--events"]
    out = subprocess.run([ssl, "analyze", wav, "-g", geometry, *events, "-f", "json", "-q", *extra],
                         capture_output=True, text=True, check=True)
    doc = json.loads(out.stdout)
    truth = D.truth_units(sources)
    rows, events = [], []
    for r in doc.get("detections", []):
        t = r["time_s"]
        active = [u for u, iv in truth if any(a <= t <= b + D.TAIL_S for a, b in iv)]
        if active:
            v = np.array([r["x"], r["y"], r["z"]])
            rows.append((min(D.angle(fold(name, u), v) for u in active), r["uncertainty_deg"]))
    for e in doc.get("events", []):
        active = [u for u, iv in truth if any(a <= e["end_s"] and e["start_s"] <= b + D.TAIL_S for a, b in iv)]
        if active:
            v = np.array([e["x"], e["y"], e["z"]])
            events.append((min(D.angle(fold(name, u), v) for u in active), e["uncertainty_deg"]))
    return rows, events


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ssl", required=True)
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--scenes", type=int, default=8)
    ap.add_argument("--work", help="keep the scenes here (default: a temporary directory)")
    ap.add_argument("extra", nargs="*", help="options for ssl analyze (after --), e.g. --every-frame")
    args = ap.parse_args()
    work = args.work or tempfile.mkdtemp(prefix="ssl-uncertainty-")
    os.makedirs(work, exist_ok=True)
    names = list(ARRAYS)
    for k, name in enumerate(names):
        write_geometry(work, k, name)
    jobs = [(k, name, args.seed + s) for k, name in enumerate(names) for s in range(args.scenes)]

    def one(job):
        k, name, seed = job
        wav, geometry, sources = scene(args.ssl, work, k, name, seed)
        return name, score(args.ssl, name, wav, geometry, sources, args.extra)

    with ThreadPoolExecutor(os.cpu_count() or 2) as pool:
        results = list(pool.map(one, jobs))
    version = subprocess.run([args.ssl, "--version"], capture_output=True, text=True).stdout.strip()
    print("# Uncertainty: calibration on simulated rooms\n")
    options = f" -- {' '.join(args.extra)}" if args.extra else ""
    print(f"Generated by `python3 benches/uncertainty.py --ssl target/release/ssl --seed {args.seed} --scenes {args.scenes}{options}`"
          f" with {version}; do not edit by hand. The constants were chosen on other draws (seeds 900-905 of a development"
          " version of this script); the method is in docs/method.md, \"Uncertainty\".\n")
    print(f"{args.scenes} rooms per array (RT60 0.2-0.8 s, SNR 0-20 dB, four utterances 1-3 m away at elevations -10 to 30 deg)."
          " Inside: the share of rows (events) whose true direction lies within their `uncertainty_deg`;"
          " planar and linear arrays' truth taken onto the side they report. Target: about 95%.\n")
    print("| array | rows | inside | median cone | median error | 95th percentile error | events | inside | median cone |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in names:
        rows = [r for n, (rs, _) in results if n == name for r in rs]
        events = [e for n, (_, es) in results if n == name for e in es]
        if not rows:
            print(f"| {name} | 0 | - | - | - | - | {len(events)} | - | - |")
            continue
        err, cone = np.array([r[0] for r in rows]), np.array([r[1] for r in rows])
        line = (f"| {name} | {len(rows)} | {100 * np.mean(err <= cone):.1f}% | {np.median(cone):.1f} deg"
                f" | {np.median(err):.1f} deg | {np.quantile(err, 0.95):.1f} deg")
        if events:
            ee, ec = np.array([e[0] for e in events]), np.array([e[1] for e in events])
            line += f" | {len(events)} | {100 * np.mean(ee <= ec):.0f}% | {np.median(ec):.1f} deg |"
        else:
            line += " | 0 | - | - |"
        print(line)
    all_rows = [r for _, (rs, _) in results for r in rs]
    all_events = [e for _, (_, es) in results for e in es]
    line = f"\nAll arrays: {100 * np.mean([e <= c for e, c in all_rows]):.1f}% of {len(all_rows)} rows"
    if all_events:
        line += f" and {100 * np.mean([e <= c for e, c in all_events]):.1f}% of {len(all_events)} events"
    print(line + " inside their cone.")


if __name__ == "__main__":
    main()
