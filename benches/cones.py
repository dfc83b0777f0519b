#!/usr/bin/env python3
"""Do the cones hold on rooms we did not render? `uncertainty_deg` per kind of scene,
rendered by pyroomacoustics (not by `ssl simulate`, on which the cones were calibrated).

Each scene, drawn from the seed given: two or three talkers 1-3.5 m away at elevations
-10 to 30 deg, at least 30 deg apart in azimuth, taking turns (one ARCTIC sentence each,
0.3-0.8 s apart), with a fan near the ceiling and one low on a wall and a little
diffuse noise, together 10 dB under the talkers. Kinds:

- `paper`: the paper's conditions: the prism (8 mics, 50 x 40 x 36 cm) at 16 kHz in a
  room of RT60 0.35-0.4 s;
- `reverberant`: a 5.7 cm tetrahedron, a 6-mic circle of radius 4.63 cm and a 4-mic
  square of side 4.57 cm at 16 kHz in rooms of RT60 0.3-0.8 s;
- `cardioids`: directional microphones, simulated with their directivity
  (pyroomacoustics' first-order cardioid, facing outward): 16 on an open sphere of
  radius 5 cm and 8 on the corners of a 10 cm cube, at 48 kHz, RT60 0.3-0.8 s. The
  capsules' phase is ideal (a real cardioid's acoustic centre moves with the angle of
  arrival, which this does not model).

Scores per array: the share of rows whose true direction (the talker speaking at the
row's time, 0.3 s of reverberation after allowed) lies inside their `uncertainty_deg`,
the median cone and error; the events, those more than 10 deg from every talker speaking
during them (in azimuth on a planar array: false events, a reflection or a stray, which
no cone around the direction measured is meant to hold), and of the others the share
whose cone holds the nearest talker. A planar array's truth is taken onto the side it
reports (above its plane), as docs/interface.md defines the cone.

    python3 benches/cones.py --ssl target/release/ssl --seed 100 --scenes 6 [--work DIR] [-- FLAGS]

Needs numpy, scipy and pyroomacoustics (pip install numpy scipy pyroomacoustics).
"""

import math
import os
import random
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rooms as R  # noqa: E402  (rooms, talkers, fans, scene files)

TAIL_S = 0.3


def sphere(k, r):
    """`k` points spread evenly over a sphere of radius `r` (a Fibonacci lattice)."""
    golden = math.pi * (3 - math.sqrt(5))
    out = []
    for i in range(k):
        z = 1 - 2 * (i + 0.5) / k
        s = math.sqrt(1 - z * z)
        out.append([r * s * math.cos(golden * i), r * s * math.sin(golden * i), r * z])
    return out


# name -> (kind, positions, rate, planar, cardioids)
ARRAYS = {
    "prism, 8 mics, 50 x 40 x 36 cm, 16 kHz": ("paper", [[x * 0.25, y * 0.20, z * 0.18] for x in (1, -1) for y in (1, -1) for z in (1, -1)], 16000, False, False),
    "tetrahedron, 4 mics, 5.7 cm, 16 kHz": ("reverberant", R.tetrahedron(0.057), 16000, False, False),
    "circle, 6 mics, r 4.63 cm, 16 kHz": ("reverberant", R.circle(6, 0.0463), 16000, True, False),
    "square, 4 mics, 4.57 cm, 16 kHz": ("reverberant", R.circle(4, 0.0457 / math.sqrt(2)), 16000, True, False),
    "open sphere, 16 cardioids, r 5 cm, 48 kHz": ("cardioids", sphere(16, 0.05), 48000, False, True),
    "cube, 8 cardioids, 10 cm, 48 kHz": ("cardioids", [[x * 0.05, y * 0.05, z * 0.05] for x in (1, -1) for y in (1, -1) for z in (1, -1)], 48000, False, True),
}


def az_diff(a, b):
    return abs((a - b + 180) % 360 - 180)


def render(kind, seed, mics_local, rate, cardioids, clips):
    """The scene's audio (samples x mics) and its talkers: [(unit vector, [(start, end)])]."""
    from pyroomacoustics.directivities import Cardioid, DirectionVector

    rng = random.Random(seed * 6151 + sum(map(ord, kind)))
    nrng = np.random.default_rng(seed * 13 + len(kind))
    rt60 = rng.uniform(0.35, 0.4) if kind == "paper" else rng.uniform(0.3, 0.8)
    n_talkers = rng.choice([2, 3])
    for _ in range(1000):
        dims = np.array([rng.uniform(6.0, 9.0), rng.uniform(5.0, 7.5), rng.uniform(2.7, 3.3)])
        centre = np.array([rng.uniform(2.0, dims[0] - 2.0), rng.uniform(2.0, dims[1] - 2.0), rng.uniform(0.9, 1.4)])
        talkers = []
        for _ in range(300):
            az, el, dist = rng.uniform(-180, 180), rng.uniform(-10, 30), rng.uniform(1.0, 3.5)
            p = centre + dist * R.unit(az, el)
            if R.inside(dims, p, 0.4) and all(az_diff(az, t[0]) >= 30 for t in talkers):
                talkers.append((az, el, p))
                if len(talkers) == n_talkers:
                    break
        if len(talkers) == n_talkers:
            break
    order = [k for k in range(n_talkers) for _ in range(2)]
    rng.shuffle(order)
    t, sched = 0.5, []
    for k in order:
        x = clips[rng.randrange(len(clips))]
        sched.append((k, t, x))
        t += len(x) / rate + rng.uniform(0.3, 0.8)
    n = int((t + 0.5) * rate)
    directivity = None
    if cardioids:
        directivity = []
        for q in mics_local:
            q = np.array(q)
            az = math.degrees(math.atan2(q[1], q[0]))
            col = math.degrees(math.acos(q[2] / np.linalg.norm(q)))
            directivity.append(Cardioid(DirectionVector(az, col, degrees=True)))

    room = R.shoebox(dims, rate, rt60, centre + np.array(mics_local), 30, directivity)

    speech, truth = R.talkers_heard(room, [p for _, _, p in talkers], sched, n, rate, centre)
    fans = [R.ceiling_fan(rng, dims),
            np.array([rng.uniform(0.5, dims[0] - 0.5), rng.choice([0.4, dims[1] - 0.4]), rng.uniform(0.3, 1.0)])]
    noise = R.fans_heard(room, fans, n, rate, nrng, 0.3, 10.0)
    return speech + noise, truth, {"rt60": round(rt60, 2), "talkers": n_talkers}


def score(truth, rows, events, planar):
    """(rows scored, inside, cones, errors), the same for events."""

    def onto(u):
        return np.array([u[0], u[1], abs(u[2])]) if planar else u

    def err(u, r):
        return R.angle(onto(u), np.array([r["x"], r["y"], r["z"]]))

    out = {"rows": [], "events": []}
    for r in rows:
        active = [u for u, spans in truth if any(a - 0.05 <= r["time_s"] <= b + TAIL_S for a, b in spans)]
        if active:
            e = min(err(u, r) for u in active)
            out["rows"].append((e, r["uncertainty_deg"]))
    for ev in events:
        near = [u for u, spans in truth for a, b in spans if a - 0.1 <= ev["end_s"] and ev["start_s"] <= b + TAIL_S]
        if near:
            e = min(err(u, ev) for u in near)
            # How far from every talker: in azimuth on a planar array (whose elevation
            # may err by tens of degrees on the talker).
            off = min(az_diff(ev["azimuth_deg"], math.degrees(math.atan2(u[1], u[0]))) if planar else err(u, ev)
                      for u in near)
            out["events"].append((e, ev["uncertainty_deg"], off))
    return out


def one(ssl, seed, name, work, clips, extra):
    kind, mics, rate, planar, cardioids = ARRAYS[name]
    d = os.path.join(work, f"{seed}-" + "".join(ch if ch.isalnum() else "-" for ch in name))
    os.makedirs(d, exist_ok=True)
    wav, tpath, geo = (os.path.join(d, f) for f in ("rec.wav", "truth.json", "array.toml"))
    if not os.path.exists(tpath):
        audio, truth, info = render(kind, seed, mics, rate, cardioids, clips[rate])
        R.write_wav(wav, audio, rate)
        R.save_scene(geo, tpath, name, mics, info, truth)
    truth, info = R.load_scene(tpath)
    rows, events, _ = R.run_ssl(ssl, wav, geo, extra)
    return score(truth, rows, events, planar), info


def main():
    ap = R.scenes_parser()
    ap.add_argument("--only", default=None, help="kinds or array names containing one of these texts (comma-separated)")
    args = ap.parse_args()
    names = [n for n in ARRAYS if args.only is None or any(o in n or o == ARRAYS[n][0] for o in args.only.split(","))]
    clips = {rate: R.speech_clips(rate) for rate in {ARRAYS[n][2] for n in names}}
    work = args.work or tempfile.mkdtemp(prefix="ssl-cones-")
    jobs = [(s, n) for n in names for s in range(args.seed, args.seed + args.scenes)]
    with ThreadPoolExecutor(args.jobs) as pool:
        futs = [(s, n, pool.submit(one, args.ssl, s, n, work, clips, args.extra)) for s, n in jobs]
        totals = {}
        for s, n, fut in futs:
            got, info = fut.result()
            t = totals.setdefault(n, {"rows": [], "events": []})
            for k in ("rows", "events"):
                t[k] += got[k]
            if args.per_scene:
                rows = got["rows"]
                inside = sum(e <= c for e, c in rows)
                print(f"{n} seed {s} {info}: {inside}/{len(rows)} rows inside, median error "
                      f"{np.median([e for e, _ in rows]) if rows else float('nan'):.1f}, cone "
                      f"{np.median([c for _, c in rows]) if rows else float('nan'):.1f}", file=sys.stderr)
    print(f"Rendered by pyroomacoustics; `python3 benches/cones.py --seed {args.seed} --scenes {args.scenes}"
          + (f" -- {' '.join(args.extra)}" if args.extra else "") + "`.\n")
    print("| kind | array | rows | inside | median cone | median error | 95th percentile error | events | false | others inside | median cone |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for n in names:
        t = totals[n]
        rows, evs = t["rows"], t["events"]
        re, rc = np.array(rows or [(0.0, 0.0)]).T
        ee, ec, eo = np.array(evs or [(0.0, 0.0, 0.0)]).T
        print(f"| {ARRAYS[n][0]} | {n} | {len(rows)} | {100 * np.mean(re <= rc):.1f}% | {np.median(rc):.1f} deg "
              f"| {np.median(re):.1f} deg | {np.percentile(re, 95):.1f} deg | {len(evs)} "
              f"| {int(np.sum(eo > 10))} | {100 * np.mean((ee <= ec)[eo <= 10]) if np.any(eo <= 10) else float('nan'):.0f}% "
              f"| {np.median(ec):.1f} deg |")
    print(f"\nwork: {work}", file=sys.stderr)


if __name__ == "__main__":
    main()
