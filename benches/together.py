#!/usr/bin/env python3
"""Two talkers at once on small arrays, rendered by pyroomacoustics (not by `ssl
simulate`, which the tracking benchmark's two-talker scenes use).

Each scene, drawn from the seed given: a room of RT60 0.3-0.7 s, two talkers 1-2.5 m away
at elevations 0-20 deg, 30-120 deg apart in azimuth, each saying an ARCTIC sentence (of
another speaker) over the same few seconds (the second starts 0-0.5 s after the first),
a fan near the ceiling and diffuse noise 15 dB under them. Arrays at 16 kHz: a 5.7 cm
tetrahedron, a 6-mic circle of radius 4.63 cm (ReSpeaker-like), and an 8-mic array of
two rings 32 cm across (4 at r 16 cm, 4 at r 8 cm turned 45 deg).

Scores per array: the share of (0.1 s window, talker) pairs, over the windows in which
both talkers sound (by the energy of their dry sentences, half of the window's 10 ms
frames within 30 dB of the sentence's loudest), with a row of that talker in the window
(within 10 deg: in azimuth on the planar arrays, as `ssl evaluate` scores them, else the
angle); the rows' mean error; events more than 10 deg from both talkers (false events).

    python3 benches/together.py --ssl target/release/ssl --seed 100 --scenes 6 [--work DIR] [-- FLAGS]

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

RATE = 16000
FOUND_DEG = 10.0


def rings():
    outer = R.circle(4, 0.16)
    inner = [[0.08 * math.cos(math.pi / 4 + i * math.pi / 2), 0.08 * math.sin(math.pi / 4 + i * math.pi / 2), 0.0]
             for i in range(4)]
    return outer + inner


# name -> (positions, planar)
ARRAYS = {
    "tetrahedron, 4 mics, 5.7 cm": (R.tetrahedron(0.057), False),
    "circle, 6 mics, r 4.63 cm": (R.circle(6, 0.0463), True),
    "two rings, 8 mics, 32 cm": (rings(), True),
}


def az_of(u):
    return math.degrees(math.atan2(u[1], u[0]))


def az_diff(a, b):
    return abs((a - b + 180) % 360 - 180)


def render(seed, mics_local, clips):
    rng = random.Random(seed * 4231)
    nrng = np.random.default_rng(seed * 19)
    rt60 = rng.uniform(0.3, 0.7)
    dims, centre, talkers = R.small_room_talkers(
        rng, 2, lambda az, others: all(30 <= az_diff(az, t[0]) <= 120 for t in others), 300)
    picks = rng.sample(range(len(clips)), 2)
    sched = [(0, 0.4, clips[picks[0]]), (1, 0.4 + rng.uniform(0.0, 0.5), clips[picks[1]])]
    n = int((max(s + len(x) / RATE for _, s, x in sched) + 0.5) * RATE)
    room = R.shoebox(dims, RATE, rt60, centre + np.array(mics_local))

    speech, truth = R.talkers_heard(room, [p for _, _, p in talkers], sched, n, RATE, centre)
    noise = R.fans_heard(room, [R.ceiling_fan(rng, dims)], n, RATE, nrng, 0.5, 15.0)
    # The 0.1 s windows in which each talker sounds (its dry sentence, heard dist / c later).
    sounding = []
    for (k, start, x), (_, _, p) in zip(sched, talkers):
        hop = RATE // 100
        power = np.array([np.mean(x[i:i + hop] ** 2) for i in range(0, len(x) - hop, hop)])
        loud = power > power.max() * 1e-3
        delay = np.linalg.norm(p - centre) / 343.0
        wins = set()
        for w in range(int(len(loud) / 10)):
            if sum(loud[w * 10:(w + 1) * 10]) >= 5:
                wins.add(round(start + delay + w * 0.1, 4))
        sounding.append(wins)
    info = {"rt60": round(rt60, 2), "talkers_az": [round(a, 1) for a, _, _ in talkers], "sounding": [sorted(s) for s in sounding]}
    return speech + noise, truth, info


def score(truth, info, rows, events, planar):
    """Shared windows found per talker, the rows' errors, false events."""

    def err(u, r):
        if planar:
            return az_diff(r["azimuth_deg"], az_of(u))
        return R.angle(u, np.array([r["x"], r["y"], r["z"]]))

    starts = [sorted(s) for s in info["sounding"]]
    found, shared, errs = 0, 0, []
    for k, (u, _) in enumerate(truth):
        other = truth[1 - k]
        for w in starts[k]:
            if not any(abs(w - v) < 0.05 for v in starts[1 - k]):
                continue
            shared += 1
            found += int(any(w <= r["time_s"] < w + 0.1 and err(u, r) <= FOUND_DEG and err(u, r) <= err(other[0], r)
                             for r in rows))
    for r in rows:
        errs.append(min(err(u, r) for u, _ in truth))
    false = sum(1 for ev in events if all(err(u, ev) > FOUND_DEG for u, _ in truth))
    return found, shared, errs, false, len(events)


def one(ssl, seed, name, work, clips, extra):
    mics, planar = ARRAYS[name]
    d = os.path.join(work, f"{seed}-" + "".join(ch if ch.isalnum() else "-" for ch in name))
    os.makedirs(d, exist_ok=True)
    wav, tpath, geo = (os.path.join(d, f) for f in ("rec.wav", "truth.json", "array.toml"))
    if not os.path.exists(tpath):
        audio, truth, info = render(seed, mics, clips)
        R.write_wav(wav, audio, RATE)
        R.save_scene(geo, tpath, name, mics, info, truth)
    truth, info = R.load_scene(tpath)
    rows, events, _ = R.run_ssl(ssl, wav, geo, extra)
    return score(truth, info, rows, events, planar), info


def main():
    ap = R.scenes_parser()
    args = ap.parse_args()
    clips = R.speech_clips(RATE)
    work = args.work or tempfile.mkdtemp(prefix="ssl-together-")
    jobs = [(s, n) for n in ARRAYS for s in range(args.seed, args.seed + args.scenes)]
    totals = {}
    with ThreadPoolExecutor(args.jobs) as pool:
        futs = [(s, n, pool.submit(one, args.ssl, s, n, work, clips, args.extra)) for s, n in jobs]
        for s, n, fut in futs:
            (found, shared, errs, false, n_events), info = fut.result()
            t = totals.setdefault(n, {"found": 0, "shared": 0, "errs": [], "false": 0, "events": 0})
            t["found"] += found
            t["shared"] += shared
            t["errs"] += errs
            t["false"] += false
            t["events"] += n_events
            if args.per_scene:
                print(f"{n} seed {s} rt60 {info['rt60']} talkers {info['talkers_az']}: {found}/{shared} shared windows, "
                      f"{false}/{n_events} false events", file=sys.stderr)
    print(f"Rendered by pyroomacoustics; `python3 benches/together.py --seed {args.seed} --scenes {args.scenes}"
          + (f" -- {' '.join(args.extra)}" if args.extra else "") + "`.\n")
    print("| array (16 kHz) | shared windows with the talker's row | rows' mean error | false events |")
    print("|---|---|---|---|")
    for n, t in totals.items():
        print(f"| {n} | {t['found']}/{t['shared']} ({100 * t['found'] / max(1, t['shared']):.0f}%) "
              f"| {np.mean(t['errs']) if t['errs'] else float('nan'):.1f} deg | {t['false']} of {t['events']} |")
    print(f"\nwork: {work}", file=sys.stderr)


if __name__ == "__main__":
    main()
