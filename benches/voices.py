#!/usr/bin/env python3
"""Low voices on small arrays, rendered by pyroomacoustics (not by `ssl simulate`).

Each scene, drawn from the seed given: a room of RT60 0.3-0.73 s with a fan and diffuse
noise 15 dB below the talkers, and two talkers 1-2.5 m away at elevations 0-20 deg, at
least 40 deg apart in azimuth, taking four turns (one ARCTIC sentence each, 0.3-0.8 s
apart): a low voice (speaker `aew`, f0 about 105 Hz, played 1-1.15x slower so its f0 is
90-110 Hz) and another (the clips of the other speakers, f0 130-240 Hz). The same scene
is rendered for four arrays at 16 kHz: a 5.7 cm tetrahedron, a 6-mic circle of radius
4.63 cm (ReSpeaker-like), a 4-mic square of side 4.57 cm (ReSpeaker 4-mic-like), and an
8-mic circle of radius 15 cm for contrast.

Scores per array and voice: the mean azimuth error of the rows against the talker
speaking (0.3 s of reverberation after allowed; azimuth, as a planar array measures it),
the rows within 10 deg, the tracks a talker's rows within 10 deg fall in, the events more
than 10 deg in azimuth from every talker speaking around them (false events), and, over
the same audio of each talker's turns, the azimuth error of pyroomacoustics' SRP-PHAT
(its defaults: 500-4000 Hz, a 512-point STFT; a 1 deg azimuth grid and elevations of
0-40 deg; azimuth only on the planar arrays).

    python3 benches/voices.py --ssl target/release/ssl --seed 100 --scenes 4 [--work DIR] [-- FLAGS]

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
TAIL_S = 0.3
FOUND_DEG = 10.0


# name -> (positions, planar)
ARRAYS = {
    "tetrahedron, 4 mics, 5.7 cm": (R.tetrahedron(0.057), False),
    "circle, 6 mics, r 4.63 cm": (R.circle(6, 0.0463), True),
    "square, 4 mics, 4.57 cm": (R.circle(4, 0.0457 / math.sqrt(2)), True),
    "circle, 8 mics, r 15 cm": (R.circle(8, 0.15), True),
}


def voices():
    """(low voice clips, other clips) at 16 kHz, by speaker."""
    low, other = [], []
    for d in R.SPEECH_DIRS:
        if not os.path.isdir(d):
            continue
        for f in sorted(os.listdir(d)):
            if not f.endswith(".wav") or any(f == g for g, _ in low + other):
                continue
            x, r = R.read_wav(os.path.join(d, f))
            assert r == RATE, f
            (low if "_aew_" in f else other).append((f, x[:, 0]))
    return [x for _, x in low], [x for _, x in other]


def slower(x, factor):
    """`x` played `factor` times slower (its pitch and formants lowered alike)."""
    from scipy.signal import resample

    return resample(x, int(len(x) * factor))


def az_of(u):
    return math.degrees(math.atan2(u[1], u[0]))


def az_diff(a, b):
    return abs((a - b + 180) % 360 - 180)


def draw(seed):
    rng = random.Random(seed * 7451)
    rt60 = rng.uniform(0.3, 0.73)
    dims, centre, talkers = R.small_room_talkers(
        rng, 2, lambda az, others: all(az_diff(az, t[0]) >= 40 for t in others), 200)
    return rng, rt60, dims, centre, talkers


def render(seed, mics_local, low, other):
    """The scene's audio for one array and its talkers: [(unit vector, [(start, end)])]."""
    rng, rt60, dims, centre, talkers = draw(seed)
    nrng = np.random.default_rng(seed * 17)
    factor = rng.uniform(1.0, 1.15)
    order = [0, 1, 0, 1] if rng.random() < 0.5 else [1, 0, 1, 0]
    t, sched = 0.4, []
    lows = rng.sample(range(len(low)), 2)
    others = rng.sample(range(len(other)), 2)
    for i, k in enumerate(order):
        x = slower(low[lows[i // 2]], factor) if k == 0 else other[others[i // 2]]
        sched.append((k, t, x))
        t += len(x) / RATE + rng.uniform(0.3, 0.8)
    n = int((t + 0.5) * RATE)
    room = R.shoebox(dims, RATE, rt60, centre + np.array(mics_local))

    speech, truth = R.talkers_heard(room, [p for _, _, p in talkers], sched, n, RATE, centre)
    noise = R.fans_heard(room, [R.ceiling_fan(rng, dims)], n, RATE, nrng, 0.5, 15.0)
    info = {"rt60": round(rt60, 2), "f0_factor": round(factor, 3), "talkers_az": [round(a, 1) for a, _, _ in talkers]}
    return speech + noise, truth, info


def srp(audio, mics_local, spans, planar):
    """pyroomacoustics' SRP-PHAT azimuth over the given spans of `audio`."""
    import pyroomacoustics as pra

    nfft = 512
    segs = [audio[int(a * RATE):int(b * RATE)] for a, b in spans]
    x = np.concatenate(segs)
    X = np.array([pra.transform.stft.analysis(x[:, m], nfft, nfft // 2) for m in range(x.shape[1])])
    X = np.transpose(X, (0, 2, 1))
    az = np.radians(np.arange(0, 360, 1.0))
    kw = {}
    if not planar:
        kw["colatitude"] = np.radians(90 - np.arange(0, 41, 2.0))
    doa = pra.doa.algorithms["SRP"](np.array(mics_local).T, RATE, nfft, c=343.0, num_src=1, azimuth=az, **kw)
    doa.locate_sources(X, freq_range=[500.0, 4000.0])
    return math.degrees(doa.azimuth_recon[0])


def score(truth, rows, events):
    """Per talker: rows, their azimuth error sum, rows within 10 deg, source ids of those."""
    per = [{"rows": 0, "err": 0.0, "ok": 0, "ids": set()} for _ in truth]
    for r in rows:
        active = [k for k, (u, spans) in enumerate(truth) if any(a - 0.05 <= r["time_s"] <= b + TAIL_S for a, b in spans)]
        if not active:
            continue
        e, k = min((az_diff(r["azimuth_deg"], az_of(truth[k][0])), k) for k in active)
        per[k]["rows"] += 1
        per[k]["err"] += e
        if e <= FOUND_DEG:
            per[k]["ok"] += 1
            per[k]["ids"].add(r.get("source"))
    false = 0
    for ev in events:
        near = [u for u, spans in truth for a, b in spans if a - 0.1 <= ev["end_s"] and ev["start_s"] <= b + TAIL_S]
        if not any(az_diff(ev["azimuth_deg"], az_of(u)) <= FOUND_DEG for u in near):
            false += 1
    return per, false


def one(ssl, seed, k, name, work, low, other, extra):
    mics, planar = ARRAYS[name]
    d = os.path.join(work, f"{seed}-{k}")
    os.makedirs(d, exist_ok=True)
    wav, tpath, geo = (os.path.join(d, f) for f in ("rec.wav", "truth.json", "array.toml"))
    if not os.path.exists(tpath):
        audio, truth, info = render(seed, mics, low, other)
        R.write_wav(wav, audio, RATE)
        info["srp_az"] = [srp(audio, mics, spans, planar) for _, spans in truth]
        R.save_scene(geo, tpath, name, mics, info, truth)
    truth, info = R.load_scene(tpath)
    rows, events, _ = R.run_ssl(ssl, wav, geo, extra)
    per, false = score(truth, rows, events)
    srp_err = [az_diff(a, az_of(u)) for a, (u, _) in zip(info["srp_az"], truth)]
    return per, false, len(events), srp_err, info


def main():
    ap = R.scenes_parser()
    args = ap.parse_args()
    low, other = voices()
    work = args.work or tempfile.mkdtemp(prefix="ssl-voices-")
    names = list(ARRAYS)
    jobs = [(s, k, n) for k, n in enumerate(names) for s in range(args.seed, args.seed + args.scenes)]
    with ThreadPoolExecutor(args.jobs) as pool:
        futs = [(s, n, pool.submit(one, args.ssl, s, k, n, work, low, other, args.extra)) for s, k, n in jobs]
        totals = {}
        for s, n, fut in futs:
            per, false, n_events, srp_err, info = fut.result()
            if args.per_scene:
                print(f"{n} seed {s} {info}: " + "; ".join(
                    f"{v}: {p['err'] / max(1, p['rows']):.1f} deg over {p['rows']} rows, {len(p['ids'])} tracks, srp {e:.1f}"
                    for v, p, e in zip(("low", "other"), per, srp_err)) + f"; {false}/{n_events} false", file=sys.stderr)
            for v, p, e in zip(("low voice", "other voice"), per, srp_err):
                t = totals.setdefault((n, v), {"rows": 0, "err": 0.0, "ok": 0, "tracks": 0, "talkers": 0, "srp": 0.0,
                                               "silent": 0, "false": 0, "events": 0})
                t["rows"] += p["rows"]
                t["err"] += p["err"]
                t["ok"] += p["ok"]
                t["tracks"] += len(p["ids"])
                t["talkers"] += 1
                t["silent"] += int(p["ok"] == 0)
                t["srp"] += e
            t = totals[(n, "low voice")]
            t["false"] += false
            t["events"] += n_events
    print("| array (16 kHz) | voice | mean azimuth error | rows within 10 deg | tracks per talker | SRP-PHAT (pyroomacoustics) | false events |")
    print("|---|---|---|---|---|---|---|")
    for (n, v), t in totals.items():
        fe = f"{t['false']} of {t['events']}" if v == "low voice" else ""
        print(f"| {n} | {v} | {t['err'] / max(1, t['rows']):.1f} deg | {100 * t['ok'] / max(1, t['rows']):.0f}% of {t['rows']} "
              f"| {t['tracks'] / max(1, t['talkers']):.2f} | {t['srp'] / max(1, t['talkers']):.1f} deg | {fe} |")
    print(f"\nwork: {work}", file=sys.stderr)


if __name__ == "__main__":
    main()
