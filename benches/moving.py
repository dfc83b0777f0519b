#!/usr/bin/env python3
"""Walkers: one talker turning around the array, with pauses, on every kind of array.

Each scene (drawn from the seed given): a room of 5.5-9 x 4.5-7.5 x 2.6-3.4 m at RT60
0.25-0.7 s, a fan and diffuse noise 12 dB under the talker; one talker 1.5-2.2 m away (nearer where the room is smaller) at
an elevation of -5 to 20 deg, turning about the array at 10, 20 or 30 deg/s (either way)
for about 6 s, saying an ARCTIC sentence in three stretches with pauses of 0.3-0.5 s
between them. Rendered by `ssl simulate` for the arrays of `benches/uncertainty.py`
(lines left out: they cannot follow a turn through their axis) and analysed by `ssl
analyze --events` at its defaults, or with the options given after `--`.

Scores per array and rate of turn:

- windows: the share of 0.1 s windows of speech (the sentence's own pauses left out) with a row within 10 deg of the talker's
  direction at the row's time (planar arrays: in azimuth, as `ssl evaluate` scores them);
- error: the mean error of those rows;
- inside: the share of the rows (talking or within 0.3 s after) whose cone holds the
  talker's direction at their time (planar arrays: the truth on the side they report);
- tracks: the mean number of source ids a walker's rows carry (the share of its rows
  under one id at least 5%); 1 is one track through the pauses;
- events: events per walker, and the share of them that report a path (first and last
  directions 10 deg or more apart) whose end lies within 15 deg of the talker at the
  event's end.

    python3 benches/moving.py --ssl target/release/ssl --seed 700 --scenes 2 [-- FLAGS]

Needs numpy (pip install numpy). About two minutes on two cores.
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

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import draws as D  # noqa: E402
import uncertainty as U  # noqa: E402

RATES = (10.0, 20.0, 30.0)
FOUND_DEG = 10.0
TAIL_S = 0.3


def scene(ssl, work, k, name, seed, turn):
    rng = random.Random(seed * 7907 + k * 131 + int(turn))
    rate = U.ARRAYS[name][1]
    dims, pos = D.room_block(rng)
    rt60 = rng.uniform(0.25, 0.7)
    clips = D.clips()
    clip = clips[rng.randrange(len(clips))]
    az, el = rng.uniform(-180, 180), rng.uniform(-5, 20)
    # The whole circle it walks stays 0.3 m inside the walls.
    room = min(pos[0], dims[0] - pos[0], pos[1], dims[1] - pos[1]) - 0.3
    dist = min(rng.uniform(1.5, 2.2), room / math.cos(math.radians(el)))
    sign = rng.choice([-1.0, 1.0])
    t, active = 0.4, []
    for i in range(3):
        length = rng.uniform(1.2, 2.0)
        active.append([round(t, 3), round(t + length, 3)])
        t += length + rng.uniform(0.3, 0.5)
    source = {"azimuth_deg": round(az, 2), "elevation_deg": round(el, 2), "distance": round(dist, 3),
              "signal": "file", "file": clip, "level_db": -26.0, "active": active,
              "turn_deg_per_s": sign * turn}
    fans = D.fan_positions(rng, dims, pos, near=False)
    geometry = os.path.join(work, f"array{k}.toml")
    text = D.scene_toml(dims, pos, rt60, rate, t + 0.3, seed, geometry, [source], 12.0, fans, -6.0)
    d = os.path.join(work, f"{k}-{seed}-{int(turn)}")
    os.makedirs(d, exist_ok=True)
    toml, wav, truth = (os.path.join(d, f) for f in ("scene.toml", "rec.wav", "truth.json"))
    with open(toml, "w") as f:
        f.write(text)
    if not os.path.exists(truth):
        subprocess.run([ssl, "simulate", toml, "-o", wav, "--truth", truth], check=True, capture_output=True)
    with open(truth) as f:
        s = json.load(f)["sources"][0]
    s["speaking"] = speaking(clip, rate, active, s["distance_m"])
    return wav, geometry, s


def speaking(clip, rate, active, distance):
    """The 0.1 s windows in which the talker sounds: each active interval plays the clip
    from its start, heard `distance / c` later; a window counts when at least half its
    10 ms frames are within 30 dB of the clip's loudest."""
    x, r = D.read_wav(clip)
    x = x[:, 0]
    hop = r // 100
    power = np.array([np.mean(x[i:i + hop] ** 2) for i in range(0, len(x) - hop, hop)])
    loud = power > power.max() * 1e-3
    out = []
    for a, b in active:
        w = a
        while w + 0.1 <= b:
            frames = [loud[k] for k in range(int((w - a) * 100), int((w - a) * 100) + 10) if k < len(loud)]
            if frames and sum(frames) >= 5:
                out.append(round(w + distance / 343.0, 4))
            w += 0.1
    return out


def truth_at(s, t):
    az = s["azimuth_deg"] + s["turn_deg_per_s"] * (t - s["turn_from_s"])
    return D.unit(az, s["elevation_deg"])


def error(name, u, v):
    """Degrees between truth `u` and a row `v`: in azimuth on a planar array (as `ssl
    evaluate` scores it), else the angle."""
    if U.ARRAYS[name][2] is not None:
        a = math.degrees(math.atan2(u[1], u[0]) - math.atan2(v[1], v[0]))
        return abs((a + 180) % 360 - 180)
    return D.angle(u, v)


def score(ssl, name, wav, geometry, s, extra):
    out = subprocess.run([ssl, "analyze", wav, "-g", geometry, "--events", "-f", "json", "-q", *extra],
                         capture_output=True, text=True, check=True)
    doc = json.loads(out.stdout)
    active = s["active"]
    rows = [r for r in doc.get("detections", [])
            if any(a <= r["time_s"] <= b + TAIL_S for a, b in active)]
    res = {"windows": 0, "found": 0, "err": 0.0, "ok": 0, "rows": len(rows), "inside": 0,
           "tracks": 0, "events": 0, "paths": 0}
    errs = []
    for r in rows:
        u, v = U.fold(name, truth_at(s, r["time_s"])), np.array([r["x"], r["y"], r["z"]])
        errs.append(error(name, u, v))
        res["inside"] += int(D.angle(u, v) <= r["uncertainty_deg"])
    for w in s["speaking"]:
        res["windows"] += 1
        res["found"] += int(any(w <= r["time_s"] < w + 0.1 and e <= FOUND_DEG for r, e in zip(rows, errs)))
    for e in errs:
        if e <= FOUND_DEG:
            res["ok"] += 1
            res["err"] += e
    ids = {}
    for r, e in zip(rows, errs):
        if e <= FOUND_DEG:
            ids[r.get("source")] = ids.get(r.get("source"), 0) + 1
    total = sum(ids.values())
    res["tracks"] = sum(1 for v in ids.values() if v >= 0.05 * total)
    for ev in doc.get("events", []):
        if not any(ev["start_s"] <= b + TAIL_S and a <= ev["end_s"] for a, b in active):
            continue
        res["events"] += 1
        first = D.unit(ev["start_azimuth_deg"], ev["start_elevation_deg"])
        last = D.unit(ev["end_azimuth_deg"], ev["end_elevation_deg"])
        end_truth = U.fold(name, truth_at(s, ev["end_s"]))
        if D.angle(first, last) >= 10.0 and error(name, end_truth, last) <= 15.0:
            res["paths"] += 1
    return res


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ssl", default=os.path.join(os.path.dirname(HERE), "target", "release", "ssl"))
    ap.add_argument("--seed", type=int, default=700)
    ap.add_argument("--scenes", type=int, default=2, help="scenes per array and rate")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--work", default=None)
    ap.add_argument("extra", nargs="*")
    args = ap.parse_args()
    work = args.work or tempfile.mkdtemp(prefix="ssl-moving-")
    os.makedirs(work, exist_ok=True)
    names = [n for n in U.ARRAYS if U.ARRAYS[n][3] is None]
    for k, name in enumerate(names):
        U.write_geometry(work, k, name)
    jobs = [(k, n, args.seed + i, turn) for k, n in enumerate(names)
            for turn in RATES for i in range(args.scenes)]

    def one(job):
        k, name, seed, turn = job
        wav, geometry, s = scene(args.ssl, work, k, name, seed, turn)
        return name, turn, score(args.ssl, name, wav, geometry, s, args.extra)

    with ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(one, jobs))
    print("| array | deg/s | windows within 10 deg | mean error (deg) | rows inside their cone "
          "| tracks per walker | events per walker | events with their path |")
    print("|---|---|---|---|---|---|---|---|")
    for name in names:
        for turn in RATES:
            rs = [r for n, t, r in results if n == name and t == turn]
            tot = {key: sum(r[key] for r in rs) for key in rs[0]}
            print(f"| {name} | {turn:.0f} | {tot['found']}/{tot['windows']} "
                  f"({100 * tot['found'] / max(tot['windows'], 1):.0f}%) | {tot['err'] / max(tot['ok'], 1):.2f} | "
                  f"{100 * tot['inside'] / max(tot['rows'], 1):.1f}% of {tot['rows']} | "
                  f"{tot['tracks'] / len(rs):.2f} | {tot['events'] / len(rs):.1f} | "
                  f"{tot['paths']}/{tot['events']} |")
    print(f"\nwork: {work}")


if __name__ == "__main__":
    main()
