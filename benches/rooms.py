#!/usr/bin/env python3
"""Rooms rendered by pyroomacoustics for the benches that are not `ssl simulate`'s
(`words.py`, `voices.py`, `cones.py`, `together.py`): WAV files, the shipped speech,
array shapes, shoebox rooms with talkers and fans, scene files, and `ssl analyze` run on
a rendered scene. A module, not a bench.

Needs numpy, scipy and pyroomacoustics (pip install numpy scipy pyroomacoustics).
"""

import argparse
import json
import math
import os
import subprocess
import wave

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
SPEECH_DIRS = [os.path.join(REPO, "testdata", "speech"), os.path.join(REPO, "..", "shared", "speech")]

def read_wav(path):
    with wave.open(path) as w:
        n, ch, rate = w.getnframes(), w.getnchannels(), w.getframerate()
        raw = np.frombuffer(w.readframes(n), dtype="<i2").astype(float) / 32768
    return raw.reshape(-1, ch), rate


def write_wav(path, data, rate):
    peak = np.max(np.abs(data)) or 1.0
    pcm = np.clip(data / peak * 0.5 * 32767, -32768, 32767).astype("<i2")
    with wave.open(path, "wb") as w:
        w.setnchannels(data.shape[1])
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(pcm.tobytes())


def speech_clips(rate):
    from scipy.signal import resample_poly

    seen, out = set(), []
    for d in SPEECH_DIRS:
        if not os.path.isdir(d):
            continue
        for f in sorted(os.listdir(d)):
            if f.endswith(".wav") and f not in seen:
                seen.add(f)
                x, r = read_wav(os.path.join(d, f))
                x = x[:, 0]
                if r != rate:
                    g = math.gcd(r, rate)
                    x = resample_poly(x, rate // g, r // g)
                out.append(x)
    return out


def circle(k, r):
    """`k` microphones evenly on a horizontal circle of radius `r` (metres)."""
    return [[r * math.cos(2 * math.pi * i / k), r * math.sin(2 * math.pi * i / k), 0.0] for i in range(k)]


def tetrahedron(edge):
    """A regular tetrahedron of side `edge` (metres) around the origin."""
    a = edge / (2 * math.sqrt(2))
    return [[a, a, a], [a, -a, -a], [-a, a, -a], [-a, -a, a]]


def save_scene(geometry, truth_path, name, mics, info, truth):
    """A rendered scene's geometry file and truth (`info` and [(unit vector, spans)])."""
    with open(geometry, "w") as f:
        f.write(f"name = \"{name}\"\n")
        for q in mics:
            f.write(f"[[mic]]\nposition = [{q[0]:.6f}, {q[1]:.6f}, {q[2]:.6f}]\n")
    with open(truth_path, "w") as f:
        json.dump({"info": info, "talkers": [{"u": list(u), "spans": s} for u, s in truth]}, f)


def load_scene(truth_path):
    """What `save_scene` wrote: ([(unit vector, [(start, end)])], info)."""
    with open(truth_path) as f:
        doc = json.load(f)
    return [(np.array(t["u"]), [tuple(s) for s in t["spans"]]) for t in doc["talkers"]], doc["info"]


def scenes_parser():
    """The options of a benchmark over rendered scenes (`benches/voices.py`, `benches/cones.py`)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--ssl", default=os.path.join(REPO, "target", "release", "ssl"))
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--scenes", type=int, default=4)
    ap.add_argument("--work", default=None, help="keep the rendered scenes here (reused)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--per-scene", action="store_true")
    ap.add_argument("extra", nargs="*", help="arguments for ssl analyze")
    return ap


def fans_heard(room, fans, n, rate, nrng, diffuse, below_db):
    """Pink noise from each of `fans` through a fresh `room()`, plus diffuse (uncorrelated)
    noise of `diffuse` times their RMS, scaled to `below_db` under unit power (the
    talkers' of `talkers_heard`): samples x mics."""
    lead = int(0.5 * rate)
    noise = None
    for f in fans:
        r = room()
        r.add_source(f, signal=pink(n + lead, nrng))
        r.simulate()
        heard = r.mic_array.signals[:, lead:lead + n].T
        noise = heard if noise is None else noise + heard
    noise = noise / math.sqrt(np.mean(noise ** 2)) + diffuse * nrng.standard_normal(noise.shape)
    return noise * 10 ** (-below_db / 20) / math.sqrt(np.mean(noise ** 2))


def shoebox(dims, rate, rt60, positions, max_order=40, directivity=None):
    """A maker of fresh pyroomacoustics rooms of `dims` at `rt60` (Sabine) with the
    microphones at `positions` (metres, mics x 3; with `directivity`, one per mic)."""
    import pyroomacoustics as pra

    e_abs, order = pra.inverse_sabine(rt60, dims)

    def room():
        r = pra.ShoeBox(dims, fs=rate, materials=pra.Material(e_abs), max_order=min(order, max_order))
        r.add_microphone_array(pra.MicrophoneArray(np.array(positions).T, rate, directivity=directivity))
        return r

    return room


def ceiling_fan(rng, dims):
    """A fan in a corner near the ceiling."""
    return np.array([rng.choice([0.4, dims[0] - 0.4]), rng.choice([0.4, dims[1] - 0.4]), dims[2] - 0.3])


def unit(az, el):
    a, e = math.radians(az), math.radians(el)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


def angle(u, v):
    c = float(np.dot(u, v)) / (np.linalg.norm(u) * np.linalg.norm(v))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def mics_of(geometry):
    import tomllib

    with open(geometry, "rb") as f:
        g = tomllib.load(f)
    return np.array([m["position"] for m in g["mic"]])


def pink(n, rng):
    f = np.fft.rfftfreq(n)
    spec = (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f))) / np.sqrt(np.maximum(f, 1.0 / n))
    x = np.fft.irfft(spec, n)
    return x / np.std(x)


def inside(dims, p, margin=0.3):
    return all(margin < p[i] < dims[i] - margin for i in range(3))


def talkers_heard(room, places, sched, n, rate, centre):
    """Each talker's turns (`sched`: (talker, start s, samples)) through a fresh `room()`,
    each scaled to unit mean power over its own turns, summed: (samples x mics, [(unit
    vector from `centre`, [(start, end)])])."""
    speech, truth = None, []
    for k, p in enumerate(places):
        dry = np.zeros(n)
        spans = []
        for kk, start, x in sched:
            if kk == k:
                s = int(start * rate)
                dry[s:s + len(x)] += x / (np.std(x) + 1e-12)
                spans.append((start, start + len(x) / rate))
        r = room()
        r.add_source(p, signal=dry)
        r.simulate()
        img = r.mic_array.signals[:, :n].T
        mask = np.zeros(n, bool)
        for a, b in spans:
            mask[int(a * rate):int(b * rate)] = True
        img = img / math.sqrt(np.mean(img[mask] ** 2))
        speech = img if speech is None else speech + img
        truth.append(((p - centre) / np.linalg.norm(p - centre), spans))
    return speech, truth


def small_room_talkers(rng, count, apart, tries):
    """A room of 5-8 x 4-6.5 x 2.6-3.2 m, an array centre 1.5 m or more from its walls at
    0.8-1.3 m, and `count` talkers 1-2.5 m from it at elevations 0-20 deg whose azimuths
    pass `apart(az, [(az, el, position)])`: (dims, centre, talkers)."""
    for _ in range(1000):
        dims = np.array([rng.uniform(5.0, 8.0), rng.uniform(4.0, 6.5), rng.uniform(2.6, 3.2)])
        centre = np.array([rng.uniform(1.5, dims[0] - 1.5), rng.uniform(1.5, dims[1] - 1.5), rng.uniform(0.8, 1.3)])
        talkers = []
        for _ in range(tries):
            az, el, dist = rng.uniform(-180, 180), rng.uniform(0, 20), rng.uniform(1.0, 2.5)
            p = centre + dist * unit(az, el)
            if inside(dims, p, 0.4) and apart(az, talkers):
                talkers.append((az, el, p))
                if len(talkers) == count:
                    return dims, centre, talkers
    return dims, centre, talkers


def draw_place(rng, dims, centre, dist, az=None, el=None):
    for _ in range(200):
        a = rng.uniform(-180, 180) if az is None else az
        e = rng.uniform(-10, 25) if el is None else el
        p = centre + dist * unit(a, e)
        if inside(dims, p):
            return a, e, p
        if az is not None:
            dist *= 0.95
    return None


def run_ssl(ssl, wav, geometry, extra):
    out = subprocess.run([ssl, "analyze", wav, "-g", geometry, "--events", "-f", "json", "-q"] + extra,
                         capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(out.stderr)
    doc = json.loads(out.stdout)
    return doc.get("detections", []), doc.get("events", []), doc.get("warnings", [])
