#!/usr/bin/env python3
"""Fresh draws: scenes that no bench, test or tuning of this repository uses.

Every scene is drawn from a seed given on the command line (rooms, positions, sentences,
gaps, levels), rendered by `ssl simulate` and analysed by `ssl analyze --events` at its
defaults; the script scores what a user would ask of the result:

- utterances found: a row within 10 deg of the talker during the utterance (0.3 s of
  reverberation after it allowed);
- rows within 10 deg of the source heard at that time, and their mean error;
- separate events: two consecutive utterances from different places never share an event,
  and every clap has an event of its own;
- false events: events more than 10 deg from every source active around them (in the
  background scenes: every event).

Real recordings: with `--rs-mnmf DIR` (a checkout of polimi-ispl/rs-mnmf: measured room
responses of 32-mic linear arrays with 3 cm spacing, 9 loudspeaker positions, and speech), the
same scores on 8 of its microphones at 16 kHz; its audio is used where it is, never copied
into this repository. Linear arrays are scored by the angle to the axis.

    python3 benches/draws.py --ssl target/release/ssl --seed 100 [--rs-mnmf DIR] [--only paper,claps]

Needs numpy and scipy (pip install numpy scipy). Prints a markdown table.
"""

import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import wave
from concurrent.futures import ThreadPoolExecutor

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
SPEECH_DIRS = [os.path.join(REPO, "testdata", "speech"), os.path.join(REPO, "..", "shared", "speech")]
TAIL_S = 0.3
FOUND_DEG = 10.0


def clips():
    seen, out = set(), []
    for d in SPEECH_DIRS:
        if not os.path.isdir(d):
            continue
        for f in sorted(os.listdir(d)):
            if f.endswith(".wav") and f not in seen:
                seen.add(f)
                out.append(os.path.abspath(os.path.join(d, f)))
    return out


def wav_len(path):
    with wave.open(path) as w:
        return w.getnframes() / w.getframerate()


def write_wav(path, data, rate):
    data = np.asarray(data)
    if data.ndim == 1:
        data = data[:, None]
    peak = np.max(np.abs(data)) or 1.0
    pcm = np.clip(data / peak * 0.5 * 32767, -32768, 32767).astype("<i2")
    with wave.open(path, "wb") as w:
        w.setnchannels(data.shape[1])
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(pcm.tobytes())


def read_wav(path):
    with wave.open(path) as w:
        n, ch, rate = w.getnframes(), w.getnchannels(), w.getframerate()
        raw = np.frombuffer(w.readframes(n), dtype="<i2").astype(float) / 32768
    return raw.reshape(-1, ch), rate


def unit(az, el):
    a, e = math.radians(az), math.radians(el)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


def angle(u, v):
    return math.degrees(math.acos(max(-1.0, min(1.0, float(np.dot(u, v)) / (np.linalg.norm(u) * np.linalg.norm(v))))))


# ---------------------------------------------------------------- scenes


def clap_file(dir, rng, kind):
    """A hand clap (a 4 ms noise burst decaying over 10 ms) or a knock (a damped
    300-1500 Hz resonance), 50 ms at 48 kHz."""
    rate = 48000
    t = np.arange(int(0.05 * rate)) / rate
    if kind == "clap":
        x = rng.standard_normal(len(t)) * np.exp(-t / rng.uniform(0.006, 0.012))
    else:
        f = rng.uniform(300, 1500)
        x = np.sin(2 * np.pi * f * t) * np.exp(-t / rng.uniform(0.01, 0.03))
        x += 0.3 * rng.standard_normal(len(t)) * np.exp(-t / 0.002)
    path = os.path.join(dir, f"{kind}.wav")
    write_wav(path, x, rate)
    return path


def room_block(rng):
    dims = [rng.uniform(5.5, 9.0), rng.uniform(4.5, 7.5), rng.uniform(2.6, 3.4)]
    pos = [rng.uniform(1.5, dims[0] - 1.5), rng.uniform(1.5, dims[1] - 1.5), rng.uniform(0.9, 1.4)]
    return dims, pos


def place(rng, dims, pos, az, el, dist):
    """Shrinks `dist` until the source is 0.3 m inside the room."""
    for _ in range(30):
        p = np.array(pos) + dist * unit(az, el)
        if all(0.3 < p[i] < dims[i] - 0.3 for i in range(3)):
            return dist
        dist *= 0.9
    return dist


def scene_toml(dims, pos, rt60, rate, duration, seed, geometry, sources, snr, fans, diffuse_db):
    lines = [
        f"sample_rate = {rate}",
        f"duration = {duration:.3f}",
        f"seed = {seed}",
        "format = \"float32\"",
        "[room]",
        f"dimensions = [{dims[0]:.3f}, {dims[1]:.3f}, {dims[2]:.3f}]",
        f"rt60 = {rt60:.3f}",
        "[array]",
        f'geometry = "{geometry}"',
        f"position = [{pos[0]:.3f}, {pos[1]:.3f}, {pos[2]:.3f}]",
    ]
    for s in sources:
        lines += ["[[source]]"]
        for k, v in s.items():
            if isinstance(v, str):
                lines.append(f'{k} = "{v}"')
            elif isinstance(v, list):
                lines.append(f"{k} = {json.dumps(v)}")
            else:
                lines.append(f"{k} = {v}")
    lines += ["[noise]", f"snr_db = {snr:.2f}", "sensor_db = -70"]
    for f, w in fans:
        lines += ["[[noise.fan]]", f"position = [{f[0]:.3f}, {f[1]:.3f}, {f[2]:.3f}]", 'signal = "pink"', f"weight_db = {w:.1f}"]
    if diffuse_db is not None:
        lines += ["[noise.diffuse]", 'signal = "pink"', f"weight_db = {diffuse_db:.1f}"]
    return "\n".join(lines) + "\n"


def fan_positions(rng, dims, pos, near):
    out = []
    corner = [rng.choice([0.4, dims[0] - 0.4]), rng.choice([0.4, dims[1] - 0.4]), dims[2] - 0.3]
    out.append((corner, 0.0))
    if near:
        d = unit(rng.uniform(-180, 180), rng.uniform(-30, 10)) * 0.9
        p = np.array(pos) + d
        p = [min(max(p[i], 0.3), dims[i] - 0.3) for i in range(3)]
        out.append((p, 0.0))
    return out


def speech_turns(rng, dims, pos, n, min_apart, gap, far, speech):
    """n utterances in turn from places at least `min_apart` deg apart in azimuth."""
    t = 0.3
    sources, azs = [], []
    for i in range(n):
        for _ in range(100):
            az = rng.uniform(-180, 180)
            if all(abs((az - a + 180) % 360 - 180) >= min_apart for a in azs[-1:]):
                break
        azs.append(az)
        el = rng.uniform(-10, 30)
        dist = place(rng, dims, pos, az, el, rng.uniform(*far))
        clip = speech[rng.randrange(len(speech))]
        length = wav_len(clip)
        sources.append(
            {"azimuth_deg": round(az, 2), "elevation_deg": round(el, 2), "distance": round(dist, 3), "signal": "file",
             "file": clip, "level_db": round(rng.uniform(-30, -22), 1), "active": [[round(t, 3), round(t + length, 3)]]}
        )
        t += length + rng.uniform(*gap)
    return sources, t + 0.5


def family_scene(family, seed, dir, geometry, speech):
    rng = random.Random(seed * 7919 + sum(map(ord, family)))
    nrng = np.random.default_rng(seed)
    rate = 48000
    if family in ("paper", "paper-far", "hard"):
        rt60 = {"paper": rng.uniform(0.3, 0.4), "paper-far": rng.uniform(0.3, 0.4), "hard": rng.uniform(0.7, 0.85)}[family]
        snr = {"paper": 10.0, "paper-far": 10.0, "hard": 5.0}[family]
        far = (2.5, 3.5) if family == "paper-far" else (1.0, 3.0)
        dims, pos = room_block(rng)
        sources, duration = speech_turns(rng, dims, pos, 4, 30, (0.3, 1.2), far, speech)
        fans = fan_positions(rng, dims, pos, near=False)
        return scene_toml(dims, pos, rt60, rate, duration, seed, geometry, sources, snr, fans, -6.0), sources
    if family == "turns":
        rt60 = rng.uniform(0.25, 0.45)
        dims, pos = room_block(rng)
        base = rng.uniform(-180, 180)
        sources, t = [], 0.3
        for i in range(6):
            az = base + sum(rng.uniform(10, 14) for _ in range(i))
            el = rng.uniform(0, 15)
            dist = place(rng, dims, pos, az, el, rng.uniform(1.5, 2.5))
            clip = speech[rng.randrange(len(speech))]
            length = min(wav_len(clip), 2.0)
            az = (az + 180) % 360 - 180
            sources.append({"azimuth_deg": round(az, 2), "elevation_deg": round(el, 2), "distance": round(dist, 3),
                            "signal": "file", "file": clip, "level_db": -26, "active": [[round(t, 3), round(t + length, 3)]]})
            t += length + 0.5
        fans = fan_positions(rng, dims, pos, near=False)
        return scene_toml(dims, pos, rt60, rate, t + 0.5, seed, geometry, sources, 15.0, fans, -6.0), sources
    if family in ("claps", "knocks"):
        rt60 = rng.uniform(0.25, 0.6)
        dims, pos = room_block(rng)
        kind = "clap" if family == "claps" else "knock"
        path = clap_file(dir, nrng, kind)
        sources, t = [], 0.4
        for i in range(3):
            az, el = rng.uniform(-180, 180), rng.uniform(-20, 30)
            dist = place(rng, dims, pos, az, el, rng.uniform(0.8, 3.0))
            times = []
            for k in range(5):
                times.append([round(t, 3), round(t + 0.05, 3)])
                t += rng.uniform(0.5, 0.8)
            t += 0.8
            sources.append({"azimuth_deg": round(az, 2), "elevation_deg": round(el, 2), "distance": round(dist, 3),
                            "signal": "file", "file": path, "level_db": round(rng.uniform(-20, -12), 1), "active": times})
        fans = fan_positions(rng, dims, pos, near=False)
        return scene_toml(dims, pos, rt60, rate, t + 0.5, seed, geometry, sources, 25.0, fans, -6.0), sources
    if family == "background":
        rt60 = rng.uniform(0.2, 0.6)
        dims, pos = room_block(rng)
        duration = 60.0
        # A reference for the noise's level only: 10 ms at the very end, not scored.
        sources = [{"azimuth_deg": 0.0, "elevation_deg": 0.0, "distance": 1.0, "signal": "white", "level_db": -26,
                    "active": [[duration - 0.01, duration]]}]
        fans = fan_positions(rng, dims, pos, near=rng.random() < 0.5)
        # Air conditioning: a vent in the ceiling.
        fans.append(([rng.uniform(1, dims[0] - 1), rng.uniform(1, dims[1] - 1), dims[2] - 0.05], rng.uniform(-6, 0)))
        snr = rng.uniform(0, 15)
        return scene_toml(dims, pos, rt60, rate, duration, seed, geometry, sources, snr, fans, rng.uniform(-10, 0)), []
    raise ValueError(family)


# ---------------------------------------------------------------- scoring


def truth_units(sources):
    """Per source: (direction, [(start, end)]) in the array frame."""
    out = []
    for s in sources:
        u = unit(s["azimuth_deg"], s["elevation_deg"]) if "u" not in s else s["u"]
        out.append((u, [tuple(a) for a in s["active"]]))
    return out


def run_ssl(ssl, wav, geometry, extra):
    out = subprocess.run([ssl, "analyze", wav, "-g", geometry, "--events", "-f", "json", "-q"] + extra,
                         capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(out.stderr)
    doc = json.loads(out.stdout)
    return doc.get("detections", []), doc.get("events", [])


def score(truth, rows, events, err, impulsive=False):
    """Scores one scene: `err(u, record)` is the angle (deg) the metric uses."""
    res = {"utterances": 0, "found": 0, "rows": 0, "rows_ok": 0, "err_sum": 0.0, "events": len(events),
           "false_events": 0, "merged": 0, "pairs": 0, "own_event": 0}
    intervals = [(u, a, b) for u, iv in truth for (a, b) in iv]
    for u, a, b in intervals:
        res["utterances"] += 1
        if any(a - 0.05 <= r["time_s"] <= b + TAIL_S and err(u, r) <= FOUND_DEG for r in rows):
            res["found"] += 1
    for r in rows:
        active = [(u, a, b) for u, a, b in intervals if a - 0.05 <= r["time_s"] <= b + TAIL_S]
        if not active:
            continue
        e = min(err(u, r) for u, _, _ in active)
        res["rows"] += 1
        res["rows_ok"] += e <= FOUND_DEG
        res["err_sum"] += min(e, 90.0)
    for ev in events:
        near = [(u, a, b) for u, a, b in intervals if a - 0.1 <= ev["end_s"] and ev["start_s"] <= b + TAIL_S]
        if not any(err(u, ev) <= FOUND_DEG for u, _, _ in near):
            res["false_events"] += 1
    # Consecutive intervals (in time) from different places: never in one event.
    ordered = sorted(intervals, key=lambda x: x[1])
    for (u1, a1, b1), (u2, a2, b2) in zip(ordered, ordered[1:]):
        if a2 < b1 or (angle(u1, u2) < 1e-6 and not impulsive):
            continue
        res["pairs"] += 1
        if any(ev["start_s"] <= b1 and ev["end_s"] >= a2 and err(u1, ev) <= 30 and err(u2, ev) <= 30 for ev in events):
            res["merged"] += 1
    if impulsive:
        for u, a, b in intervals:
            mine = [ev for ev in events if ev["start_s"] <= b + TAIL_S and ev["end_s"] >= a - 0.05 and err(u, ev) <= FOUND_DEG]
            if len(mine) >= 1 and all(not any(a2 > b and ev["end_s"] >= a2 - 0.05 and ev["start_s"] <= b2 for (_, a2, b2) in intervals) for ev in mine):
                res["own_event"] += 1
    return res


def err3d(u, r):
    return angle(u, np.array([r["x"], r["y"], r["z"]]))


def err_axis(axis):
    def f(u, r):
        v = np.array([r["x"], r["y"], r["z"]])
        return abs(math.degrees(math.acos(max(-1, min(1, float(np.dot(u, axis)))))) -
                   math.degrees(math.acos(max(-1, min(1, float(np.dot(v, axis)))))))
    return f


def simulate_and_score(ssl, family, seed, work, geometry, speech, extra):
    d = os.path.join(work, f"{family}-{seed}")
    os.makedirs(d, exist_ok=True)
    text, sources = family_scene(family, seed, d, geometry, speech)
    scene = os.path.join(d, "scene.toml")
    with open(scene, "w") as f:
        f.write(text)
    wav = os.path.join(d, "scene.wav")
    if not os.path.exists(wav):
        sim = subprocess.run([ssl, "simulate", scene, "-o", wav], capture_output=True, text=True)
        if sim.returncode != 0:
            raise RuntimeError(sim.stderr)
    rows, events = run_ssl(ssl, wav, geometry, extra)
    if family == "background":
        # The level's reference at the very end is not scored.
        rows = [r for r in rows if r["time_s"] < 59.4]
        events = [e for e in events if e["start_s"] < 59.4]
        sources = []
    return score(truth_units(sources), rows, events, err3d, impulsive=family in ("claps", "knocks"))


# ---------------------------------------------------------------- rs-mnmf


def rs_scenes(root, seed, work):
    """Measured responses: 8 microphones (channels 12-19, 3 cm apart) of the first
    32-mic line, at 16 kHz; speech of the repository's male and female talkers and
    synthetic claps through them. Returns [(name, wav, geometry, truth, impulsive)]."""
    from scipy.signal import resample_poly, fftconvolve

    src = os.path.join(root, "data", "sources")
    rng = np.random.default_rng(seed)
    mics = list(range(12, 20))
    rate = 16000
    rirs = []
    for k in range(1, 10):
        x, r = read_wav(os.path.join(src, f"rir_source_{k}.wav"))
        rirs.append(resample_poly(x[:, mics], 1, 3, axis=0))
    # Array positions along z (the line), sources at (x, z): source_location.mat.
    import scipy.io

    loc = scipy.io.loadmat(os.path.join(src, "source_location.mat"))["sourceLocation"]
    # Channel k sits at z = 0.03 k: checked once on the 32-channel responses, where the
    # earliest onset of source 1 (z = 0.086) is on channel 3 and of source 3 (z = 0.78)
    # on channel 25.
    zc = (mics[0] + mics[-1]) / 2 * 0.03
    geometry = os.path.join(work, "ula8.toml")
    with open(geometry, "w") as f:
        f.write('name = "rs-mnmf ULA, 8 of 32 mics, 3 cm"\n')
        for m in mics:
            f.write(f"[[mic]]\nposition = [0.0, {m * 0.03 - zc:.3f}, 0.0]\n")
    talkers = []
    for g in ("male", "female"):
        for k in (1, 2, 3):
            x, r = read_wav(os.path.join(root, "data", "audio", g, f"{k}.wav"))
            talkers.append(x[:, 0])
    dirs = [np.array([loc[k][0], loc[k][1] - zc, 0.0]) for k in range(9)]
    dirs = [d / np.linalg.norm(d) for d in dirs]
    scenes = []

    def render(parts, length):
        out = np.zeros((int(length * rate) + rate, len(mics)))
        for sig, k, t in parts:
            y = fftconvolve(sig[:, None], rirs[k], axes=0)
            i = int(t * rate)
            out[i:i + len(y)] += y[: len(out) - i]
        out += 10 ** (-60 / 20) * np.max(np.abs(out)) * rng.standard_normal(out.shape)
        return out

    def speech_piece(length):
        x = talkers[rng.integers(len(talkers))]
        start = rng.integers(0, len(x) - int(length * rate))
        return x[start:start + int(length * rate)]

    # Nine loudspeakers in turn, 1.5-2 s of speech each, 0.5 s gaps.
    order = list(rng.permutation(9))
    parts, truth, t = [], [], 0.3
    for k in order:
        length = rng.uniform(1.5, 2.0)
        parts.append((speech_piece(length), k, t))
        truth.append({"u": dirs[k], "active": [[t, t + length]], "azimuth_deg": 0, "elevation_deg": 0})
        t += length + 0.5
    wav = os.path.join(work, f"rs-turns-{seed}.wav")
    write_wav(wav, render(parts, t), rate)
    scenes.append(("rs-turns", wav, geometry, truth, False))
    # Two talkers at once, from two of the nine places, 6 s.
    a, b = rng.choice(9, 2, replace=False)
    parts = [(speech_piece(6.0), a, 0.3), (speech_piece(6.0), b, 0.3)]
    truth = [{"u": dirs[k], "active": [[0.3, 6.3]]} for k in (a, b)]
    wav = os.path.join(work, f"rs-two-{seed}.wav")
    write_wav(wav, render(parts, 6.5), rate)
    scenes.append(("rs-two", wav, geometry, truth, False))
    # Claps from three places, 0.5-0.8 s apart.
    parts, truth, t = [], [], 0.3
    for k in rng.choice(9, 3, replace=False):
        times = []
        for _ in range(5):
            tt = np.arange(int(0.05 * rate)) / rate
            clap = rng.standard_normal(len(tt)) * np.exp(-tt / rng.uniform(0.006, 0.012))
            parts.append((clap, k, t))
            times.append([t, t + 0.05])
            t += rng.uniform(0.5, 0.8)
        truth.append({"u": dirs[k], "active": times})
        t += 0.8
    wav = os.path.join(work, f"rs-claps-{seed}.wav")
    write_wav(wav, render(parts, t), rate)
    scenes.append(("rs-claps", wav, geometry, truth, True))
    return scenes


# ---------------------------------------------------------------- main


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ssl", default=os.path.join(REPO, "target", "release", "ssl"))
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--draws", type=int, default=3, help="scenes per family")
    ap.add_argument("--background", type=int, default=6, help="minutes of background alone")
    ap.add_argument("--rs-mnmf", default=None)
    ap.add_argument("--only", default=None)
    ap.add_argument("--work", default=None, help="keep the rendered scenes here (reused)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("extra", nargs="*", help="arguments for ssl analyze")
    args = ap.parse_args()
    speech = clips()
    work = args.work or tempfile.mkdtemp(prefix="ssl-draws-")
    os.makedirs(work, exist_ok=True)
    geometry = os.path.join(REPO, "testdata", "prism.toml")
    families = ["paper", "paper-far", "hard", "turns", "claps", "knocks", "background"]
    if args.only:
        families = [f for f in families if f in args.only.split(",")]
    jobs = []
    for fam in families:
        n = args.background if fam == "background" else args.draws
        for k in range(n):
            jobs.append((fam, args.seed + k))
    totals = {}
    with ThreadPoolExecutor(args.jobs) as pool:
        futures = [(fam, pool.submit(simulate_and_score, args.ssl, fam, s, work, geometry, speech, args.extra)) for fam, s in jobs]
        for fam, fut in futures:
            add(totals, fam, fut.result())
    if args.rs_mnmf and (not args.only or "rs" in args.only):
        for name, wav, geom, truth, imp in rs_scenes(args.rs_mnmf, args.seed, work):
            rows, events = run_ssl(args.ssl, wav, geom, args.extra)
            add(totals, name, score(truth_units(truth), rows, events, err_axis(np.array([0.0, 1.0, 0.0])), impulsive=imp))
    print("| scenes | utterances found | rows within 10 deg | mean error (deg) | events | false events | merged turns | own event |")
    print("|---|---|---|---|---|---|---|---|")
    for fam, r in totals.items():
        found = f"{r['found']}/{r['utterances']} ({100 * r['found'] / max(1, r['utterances']):.0f}%)"
        rows = f"{100 * r['rows_ok'] / max(1, r['rows']):.1f}% of {r['rows']}"
        mean = f"{r['err_sum'] / max(1, r['rows']):.2f}"
        own = f"{r['own_event']}/{r['utterances']}" if fam.endswith(("claps", "knocks")) else ""
        print(f"| {fam} ({r['n']}) | {found} | {rows} | {mean} | {r['events']} | {r['false_events']} | {r['merged']}/{r['pairs']} | {own} |")
    print(f"\nwork: {work}", file=sys.stderr)


def add(totals, fam, r):
    t = totals.setdefault(fam, {"n": 0})
    t["n"] += 1
    for k, v in r.items():
        t[k] = t.get(k, 0) + v


if __name__ == "__main__":
    main()
