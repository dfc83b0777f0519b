#!/usr/bin/env python3
"""Short words at a distance, rendered by pyroomacoustics (not by `ssl simulate`).

Three families of fresh scenes, each drawn from a seed given on the command line:

- `words`: the paper's conditions. The prism in a room of RT60 0.35-0.4 s with two fans,
  three talkers at 0.9-3.5 m, each saying single words of 0.2-0.5 s (cut from the
  speech clips by energy) in turn with pauses of 0.15-0.7 s; each talker 10 dB over the
  noise (the mean power of its reverberant image over its active samples, against the
  noise's mean power over the whole file).
- `hard`: one talker at about 2.5 m saying such words in rooms of RT60 0.2-0.8 s at
  0-20 dB (the RT60 and SNR drawn per scene).
- `turns5`: five talkers 12-20 deg apart, at 1.5-2.5 m, each speaking several times in
  turn (phrases of 0.4-1.2 s), RT60 0.3-0.5 s, 15 dB.

Scores per family: words found (a row within 10 deg of its talker from 50 ms before the
word to 0.3 s after it), the rows' mean error, false events (more than 10 deg from every
talker speaking around them: a reflection is a false event), turns merged into another
talker's event, the talkers' purity (the share of a talker's rows under the source id it
has most often; 1: one id per person), and the rows whose nearest talker speaking lies
inside their `uncertainty_deg`.

    python3 benches/words.py --ssl target/release/ssl --seed 500 --draws 4 [--only words,hard] [-- FLAGS]

Needs numpy, scipy and pyroomacoustics (pip install numpy scipy pyroomacoustics).
"""

import argparse
import json
import math
import os
import random
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rooms import (  # noqa: E402  (the rendering helpers)
    REPO,
    angle,
    draw_place,
    mics_of,
    pink,
    run_ssl,
    speech_clips,
    write_wav,
)

TAIL_S = 0.3
FOUND_DEG = 10.0


def cut_words(x, rate, shortest=0.2, longest=0.5):
    """Stretches of speech between pauses, by energy: 10 ms frames over -30 dB of the
    clip's loudest frame, gaps under 60 ms bridged; those 0.2-0.5 s long."""
    hop = rate // 100
    e = np.array([np.mean(x[i:i + hop] ** 2) for i in range(0, len(x) - hop, hop)])
    on = e > e.max() * 10 ** (-30 / 10)
    words, start, quiet = [], None, 0
    for i, v in enumerate(on):
        if v:
            if start is None:
                start = i
            quiet = 0
        elif start is not None:
            quiet += 1
            if quiet >= 6:
                end = i - quiet + 1
                if shortest <= (end - start) / 100 <= longest:
                    words.append(x[start * hop:end * hop])
                start, quiet = None, 0
    return words


def cut_phrases(x, rate):
    return cut_words(x, rate, 0.4, 1.2)


def render(family, seed, rate, mics_local, words, phrases):
    """The scene's audio (samples x mics) and its talkers: [(unit vector, [(start, end)])]."""
    import pyroomacoustics as pra

    rng = random.Random(seed * 7919 + sum(map(ord, family)))
    nrng = np.random.default_rng(seed * 31 + len(family))
    if family == "words":
        rt60, snrs, n_talkers, far = rng.uniform(0.35, 0.4), None, 3, (0.9, 3.5)
    elif family == "hard":
        rt60, n_talkers, far = rng.uniform(0.2, 0.8), 1, (2.3, 2.7)
        snrs = rng.choice([0.0, 5.0, 10.0, 15.0, 20.0])
    else:
        rt60, snrs, n_talkers, far = rng.uniform(0.3, 0.5), 15.0, 5, (1.5, 2.5)
    snr = 10.0 if family == "words" else snrs
    for _ in range(100):
        dims = np.array([rng.uniform(6.0, 9.0), rng.uniform(5.0, 7.5), rng.uniform(2.7, 3.3)])
        centre = np.array([rng.uniform(2.0, dims[0] - 2.0), rng.uniform(2.0, dims[1] - 2.0), rng.uniform(1.0, 1.4)])
        talkers = []
        az = rng.uniform(-180, 180)
        ok = True
        for k in range(n_talkers):
            dist = rng.uniform(*far)
            if family == "turns5":
                az += rng.uniform(12, 20) if k else 0.0
                got = draw_place(rng, dims, centre, dist, az=az, el=rng.uniform(0, 15))
            else:
                got = None
                for _ in range(50):
                    got = draw_place(rng, dims, centre, dist)
                    if got and all(abs((got[0] - t[0] + 180) % 360 - 180) >= 25 for t in talkers):
                        break
                    got = None
            if got is None:
                ok = False
                break
            talkers.append(got)
        if ok:
            break
    e_abs, max_order = pra.inverse_sabine(rt60, dims)
    room = pra.ShoeBox(dims, fs=rate, materials=pra.Material(e_abs), max_order=min(max_order, 40))
    room.add_microphone_array((centre[:, None] + mics_local.T))
    # Turns: words (or phrases) from talkers in a random order, every talker several times.
    pool = phrases if family == "turns5" else words
    per = {"words": 5, "hard": 8, "turns5": 3}[family]
    order = [k for k in range(n_talkers) for _ in range(per)]
    rng.shuffle(order)
    if family == "turns5":
        # Each turn another talker than the one before.
        for i in range(1, len(order)):
            if order[i] == order[i - 1]:
                for j in range(i + 1, len(order)):
                    if order[j] != order[i - 1] and (j + 1 >= len(order) or order[j + 1] != order[i]):
                        order[i], order[j] = order[j], order[i]
                        break
    t = 0.5
    sched = []
    for k in order:
        w = pool[rng.randrange(len(pool))]
        sched.append((k, t, w))
        t += len(w) / rate + rng.uniform(0.15, 0.7)
    duration = t + 0.6
    n = int(duration * rate)
    # Each talker's dry track and its image through the room, one at a time (for its SNR).
    images = []
    for k, (az, el, p) in enumerate(talkers):
        dry = np.zeros(n)
        for kk, start, w in sched:
            if kk == k:
                s = int(start * rate)
                dry[s:s + len(w)] += w / (np.std(w) + 1e-12)
        r = pra.ShoeBox(dims, fs=rate, materials=pra.Material(e_abs), max_order=min(max_order, 40))
        r.add_microphone_array((centre[:, None] + mics_local.T))
        r.add_source(p, signal=dry)
        r.simulate()
        images.append(r.mic_array.signals[:, :n].T)
    noise = np.zeros((n, len(mics_local)))
    fans = [np.array([rng.choice([0.4, dims[0] - 0.4]), rng.choice([0.4, dims[1] - 0.4]), dims[2] - 0.3]),
            np.array([rng.uniform(0.5, dims[0] - 0.5), rng.choice([0.4, dims[1] - 0.4]), rng.uniform(0.3, 1.0)])]
    for f in fans:
        r = pra.ShoeBox(dims, fs=rate, materials=pra.Material(e_abs), max_order=min(max_order, 40))
        r.add_microphone_array((centre[:, None] + mics_local.T))
        lead = int(0.5 * rate)
        r.add_source(f, signal=pink(n + lead, nrng))
        r.simulate()
        noise += r.mic_array.signals[:, lead:lead + n].T
    noise_power = np.mean(noise ** 2)
    out = noise + 1e-4 * np.sqrt(noise_power) * nrng.standard_normal(noise.shape)
    truth = []
    for k, (az, el, p) in enumerate(talkers):
        spans = [(start, start + len(w) / rate) for kk, start, w in sched if kk == k]
        mask = np.zeros(n, bool)
        for a, b in spans:
            mask[int(a * rate):int(b * rate)] = True
        power = np.mean(images[k][mask] ** 2)
        out += images[k] * math.sqrt(noise_power * 10 ** (snr / 10) / power)
        u = (p - centre) / np.linalg.norm(p - centre)
        truth.append((u, spans))
    return out, truth, {"rt60": round(rt60, 2), "snr": snr}


def err3d(u, r):
    return angle(u, np.array([r["x"], r["y"], r["z"]]))


def score(truth, rows, events):
    res = {"words": 0, "found": 0, "rows": 0, "rows_ok": 0, "err_sum": 0.0, "events": len(events),
           "false_events": 0, "merged": 0, "pairs": 0, "no_row": int(not rows), "purity_num": 0, "purity_den": 0, "inside": 0}
    words = [(k, u, a, b) for k, (u, spans) in enumerate(truth) for a, b in spans]
    for k, u, a, b in words:
        res["words"] += 1
        if any(a - 0.05 <= r["time_s"] <= b + TAIL_S and err3d(u, r) <= FOUND_DEG for r in rows):
            res["found"] += 1
    ids = {}
    for r in rows:
        active = [(k, u) for k, u, a, b in words if a - 0.05 <= r["time_s"] <= b + TAIL_S]
        if not active:
            continue
        e, k = min((err3d(u, r), k) for k, u in active)
        res["rows"] += 1
        res["inside"] += int(e <= r.get("uncertainty_deg", 0.0))
        if e <= FOUND_DEG:
            res["rows_ok"] += 1
            res["err_sum"] += e
            ids.setdefault(k, {}).setdefault(r.get("source"), 0)
            ids[k][r.get("source")] += 1
    for k, by in ids.items():
        res["purity_num"] += max(by.values())
        res["purity_den"] += sum(by.values())
    for ev in events:
        near = [u for k, u, a, b in words if a - 0.1 <= ev["end_s"] and ev["start_s"] <= b + TAIL_S]
        if not any(err3d(u, ev) <= FOUND_DEG for u in near):
            res["false_events"] += 1
    ordered = sorted(words, key=lambda w: w[2])
    for (k1, u1, a1, b1), (k2, u2, a2, b2) in zip(ordered, ordered[1:]):
        if k1 == k2:
            continue
        res["pairs"] += 1
        if any(ev["start_s"] <= b1 and ev["end_s"] >= a2 and err3d(u1, ev) <= 30 and err3d(u2, ev) <= 30 for ev in events):
            res["merged"] += 1
    return res


def one(ssl, family, seed, work, geometry, mics, words, phrases, rate, extra):
    d = os.path.join(work, f"{family}-{seed}")
    os.makedirs(d, exist_ok=True)
    wav, tpath = os.path.join(d, "rec.wav"), os.path.join(d, "truth.json")
    if not os.path.exists(wav):
        audio, truth, info = render(family, seed, rate, mics, words, phrases)
        write_wav(wav, audio, rate)
        with open(tpath, "w") as f:
            json.dump({"info": info, "talkers": [{"u": list(u), "spans": s} for u, s in truth]}, f)
    with open(tpath) as f:
        doc = json.load(f)
    truth = [(np.array(t["u"]), [tuple(s) for s in t["spans"]]) for t in doc["talkers"]]
    rows, events, warnings = run_ssl(ssl, wav, geometry, extra)
    r = score(truth, rows, events)
    r["info"] = doc["info"]
    r["warned"] = len(warnings)
    return r


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ssl", default=os.path.join(REPO, "target", "release", "ssl"))
    ap.add_argument("--seed", type=int, default=500)
    ap.add_argument("--draws", type=int, default=4, help="scenes per family")
    ap.add_argument("--only", default=None)
    ap.add_argument("--work", default=None, help="keep the rendered scenes here (reused)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--rate", type=int, default=16000)
    ap.add_argument("--per-scene", action="store_true")
    ap.add_argument("extra", nargs="*", help="arguments for ssl analyze")
    args = ap.parse_args()
    geometry = os.path.join(REPO, "testdata", "prism.toml")
    mics = mics_of(geometry)
    clips = speech_clips(args.rate)
    words = [w for c in clips for w in cut_words(c, args.rate)]
    phrases = [w for c in clips for w in cut_phrases(c, args.rate)]
    work = args.work or tempfile.mkdtemp(prefix="ssl-words-")
    families = ["words", "hard", "turns5"]
    if args.only:
        families = [f for f in families if f in args.only.split(",")]
    jobs = [(f, args.seed + k) for f in families for k in range(args.draws)]
    totals = {}
    with ThreadPoolExecutor(args.jobs) as pool:
        futs = [(f, s, pool.submit(one, args.ssl, f, s, work, geometry, mics, words, phrases, args.rate, args.extra))
                for f, s in jobs]
        for f, s, fut in futs:
            r = fut.result()
            if args.per_scene:
                print(f"{f}-{s} {r['info']}: {r['found']}/{r['words']} words, {r['false_events']} false of "
                      f"{r['events']} events, purity {r['purity_num'] / max(1, r['purity_den']):.2f}, "
                      f"mean {r['err_sum'] / max(1, r['rows_ok']):.2f} deg", file=sys.stderr)
            t = totals.setdefault(f, {"n": 0})
            t["n"] += 1
            for k, v in r.items():
                if isinstance(v, (int, float)):
                    t[k] = t.get(k, 0) + v
    print("| scenes | words found | rows within 10 deg | mean error (deg) | rows inside their cone | events | false events | merged turns | purity | scenes without a row |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for f, r in totals.items():
        print(f"| {f} ({r['n']}) | {r['found']}/{r['words']} ({100 * r['found'] / max(1, r['words']):.0f}%) "
              f"| {100 * r['rows_ok'] / max(1, r['rows']):.1f}% of {r['rows']} | {r['err_sum'] / max(1, r['rows_ok']):.2f} "
              f"| {100 * r['inside'] / max(1, r['rows']):.1f}% "
              f"| {r['events']} | {r['false_events']} | {r['merged']}/{r['pairs']} "
              f"| {r['purity_num'] / max(1, r['purity_den']):.2f} | {r['no_row']} |")
    print(f"\nwork: {work}", file=sys.stderr)


if __name__ == "__main__":
    main()
