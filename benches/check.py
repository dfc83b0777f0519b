#!/usr/bin/env python3
"""`ssl check`'s confusion table: faults made on purpose on rooms that pyroomacoustics
simulates (a simulator independent of `ssl simulate`), and what `ssl check` says of each.

Arrays: the paper's prism (50 x 40 x 36 cm, 48 kHz), a 6-mic circle of radius 4.63 cm
(a ReSpeaker's, 16 kHz), a 5.7 cm tetrahedron (16 kHz), a 10 cm cube of 8 cardioids
facing outwards (16 kHz) and an 8-mic line at 3 cm spacing (16 kHz). Rooms of RT60 0.2,
0.45 and 0.7 s; sounds: 8 hand claps from 8 directions, or 3 talkers in turn (CMU ARCTIC
sentences). Faults: none, every swap of two channels, channel 0 inverted, channel 1 dead,
channel 3 a copy of channel 2, microphone 1 moved in the geometry by 30% of its distance
to the nearest, and the geometry's units off by 10 and 100. Every check is given
`--expect` with the direction of the first sound (what settles a symmetric array); the
right order is checked without it too.

    python3 -m venv v && v/bin/pip install numpy scipy pyroomacoustics
    v/bin/python benches/check.py --ssl target/release/ssl --work /tmp/check-bench [--seed 1]

With `--rs-mnmf DIR` (a checkout of polimi-ispl/rs-mnmf) it adds a real array: the
measured room responses of 8 microphones of its 3 cm line, claps and its talkers
through them, three draws of each.

Prints the table (markdown) and the cases that went wrong.
"""

import argparse
import json
import os
import struct
import subprocess
import sys

import numpy as np
import pyroomacoustics as pra
from pyroomacoustics.directivities import Cardioid, DirectionVector


def write_wav(path, x, rate):
    """float32 WAV, frames x channels."""
    x = np.asarray(x, dtype="<f4")
    ch, data = x.shape[1], x.tobytes()
    fmt = struct.pack("<HHIIHH", 3, ch, rate, rate * ch * 4, ch * 4, 32)
    with open(path, "wb") as f:
        f.write(b"RIFF" + struct.pack("<I", 36 + len(data)) + b"WAVE" + b"fmt " + struct.pack("<I", 16) + fmt
                + b"data" + struct.pack("<I", len(data)) + data)


def read_wav(path):
    """A mono PCM16 WAV (the ARCTIC clips) as float in [-1, 1] and its rate."""
    b = open(path, "rb").read()
    i, rate, bits = 12, None, None
    while i < len(b):
        cid, size = b[i:i + 4], struct.unpack("<I", b[i + 4:i + 8])[0]
        if cid == b"fmt ":
            rate = struct.unpack("<I", b[i + 12:i + 16])[0]
            bits = struct.unpack("<H", b[i + 22:i + 24])[0]
        if cid == b"data":
            assert bits == 16
            return np.frombuffer(b[i + 8:i + 8 + size], dtype="<i2").astype(float) / 32768.0, rate
        i += 8 + size + (size & 1)
    raise ValueError(path)


def arrays():
    """name, positions (M x 3, metres, array frame), rate, outward-facing cardioids?"""
    prism = [[sx * 0.25, sy * 0.20, sz * 0.18] for sz in (1, -1) for sx, sy in ((1, 1), (1, -1), (-1, -1), (-1, 1))]
    circle = [[0.0463 * np.cos(2 * np.pi * i / 6), 0.0463 * np.sin(2 * np.pi * i / 6), 0.0] for i in range(6)]
    a = 0.057 / (2 * np.sqrt(2))  # edge 5.7 cm
    tetra = [[a * x, a * y, a * z] for x, y, z in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))]
    cube = [[0.05 * x, 0.05 * y, 0.05 * z] for z in (1, -1) for x, y in ((1, 1), (1, -1), (-1, -1), (-1, 1))]
    line = [[0.0, 0.03 * (i - 3.5), 0.0] for i in range(8)]
    return [
        ("prism", np.array(prism), 48000, False),
        ("circle-6", np.array(circle), 16000, False),
        ("tetrahedron", np.array(tetra), 16000, False),
        ("cube-cardioids", np.array(cube), 16000, True),
        ("line-8", np.array(line), 16000, False),
    ]


def geometry_toml(pos, name):
    s = f'name = "{name}"\nspeed_of_sound = 343.0\n'
    for p in pos:
        s += f"[[mic]]\nposition = [{p[0]:.6f}, {p[1]:.6f}, {p[2]:.6f}]\n"
    return s


def clap(rate, rng):
    """A hand clap: a 10 ms noise burst with a 2 ms decay."""
    n = int(0.01 * rate)
    t = np.arange(n) / rate
    return rng.standard_normal(n) * np.exp(-t / 0.002)


def directions(kind, rng, planar_or_line):
    """Azimuth, elevation (degrees) of the sounds: 8 claps around, or 3 talkers."""
    count = 8 if kind == "claps" else 3
    az0 = rng.uniform(0, 360)
    out = []
    for i in range(count):
        az = (az0 + 360.0 * i / count + rng.uniform(-10, 10)) % 360.0
        el = rng.uniform(5, 35) * (1 if i % 2 == 0 else -1)
        if planar_or_line:
            el = rng.uniform(0, 25)
        out.append((az, el))
    return out


def scene(array, rt60, kind, seed, speech, work):
    """Render one scene; return the recording (float, frames x M), rate, and directions."""
    name, pos, rate, cardioid = array
    rng = np.random.default_rng(seed)
    dims = np.array([rng.uniform(6, 9), rng.uniform(5, 7), rng.uniform(2.8, 3.5)])
    centre = dims * np.array([rng.uniform(0.4, 0.6), rng.uniform(0.4, 0.6), 0.0]) + np.array([0, 0, 1.3])
    absorption, max_order = pra.inverse_sabine(rt60, dims)
    room = pra.ShoeBox(dims, fs=rate, materials=pra.Material(absorption), max_order=min(max_order, 30))
    directivity = None
    if cardioid:
        directivity = []
        for p in pos:
            az = np.degrees(np.arctan2(p[1], p[0]))
            col = np.degrees(np.arccos(p[2] / np.linalg.norm(p)))
            directivity.append(Cardioid(DirectionVector(az, col, degrees=True)))
    room.add_microphone_array(pra.MicrophoneArray((pos + centre).T, rate, directivity=directivity))
    planar = np.ptp(pos[:, 2]) < 1e-9
    dirs = directions(kind, rng, planar)
    t = 0.3
    for i, (az, el) in enumerate(dirs):
        dist = rng.uniform(1.5, 2.3)
        u = np.array([np.cos(np.radians(el)) * np.cos(np.radians(az)),
                      np.cos(np.radians(el)) * np.sin(np.radians(az)), np.sin(np.radians(el))])
        src = centre + dist * u
        src = np.clip(src, 0.3, dims - 0.3)
        if kind == "claps":
            sig = clap(rate, rng)
            room.add_source(src, signal=sig, delay=t)
            t += 0.5
        else:
            x, r = speech[i % len(speech)]
            x = x[: int(1.6 * r)]
            if r != rate:
                x = np.interp(np.arange(int(len(x) * rate / r)) * r / rate, np.arange(len(x)), x)
            room.add_source(src, signal=x / (np.std(x) + 1e-12), delay=t)
            t += 1.9
        # The direction actually heard (the source may have been pulled inside the room).
        d = src - centre
        dirs[i] = (np.degrees(np.arctan2(d[1], d[0])) % 360.0, np.degrees(np.arcsin(d[2] / np.linalg.norm(d))))
    room.simulate()
    x = room.mic_array.signals.T
    x = x / np.max(np.abs(x)) * 0.5
    x = x + rng.standard_normal(x.shape) * 10 ** (-70 / 20)
    return x.astype(np.float32), rate, dirs


def check(ssl, wav, geometry, expect):
    cmd = [ssl, "check", wav, "-g", geometry, "-f", "json"]
    if expect is not None:
        cmd += ["--expect", f"{expect[0]:.1f}/{expect[1]:.1f}@0.3"]
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode == 2:
        return {"fits": False, "findings": [{"kind": "error", "message": out.stderr.strip()}]}
    return json.loads(out.stdout)


def outcome(fault, fix, report):
    """One word for what `check` said of `fault`: right, missed, wrong, or the honest
    middle ones (unclear, symmetric)."""
    kinds = [f["kind"] for f in report["findings"]]
    if fault == "none":
        if report["fits"]:
            return "fits"
        if kinds and set(kinds) <= {"symmetric"}:
            return "symmetric"
        if "unclear" in kinds:
            return "unclear"
        return "false alarm: " + "+".join(sorted(set(kinds)))
    if report["fits"]:
        return "FITS (missed)"
    if fault == "swap":
        order = [f for f in report["findings"] if f["kind"] == "order"]
        if order:
            o = order[0]
            if o["order"] == fix:
                return "caught, fix"
            if fix in o.get("orders", []):
                return "caught, fix among equals"
            return "WRONG FIX"
        if any(f["kind"] == "misfit" and fix in f.get("orders", []) for f in report["findings"]):
            return "caught, named among what fits"
        if "unclear" in kinds:
            return "unclear"
        if "symmetric" in kinds:
            return "symmetric"
        return "caught, no fix: " + "+".join(sorted(set(kinds)))
    want = {"inverted": "inverted", "dead": "dead", "duplicated": "duplicated", "units x10": "unit",
            "units x100": "unit", "moved": "moved"}[fault]
    if want in kinds:
        return "caught"
    if "order" in kinds:
        return "WRONG FIX"
    if "unclear" in kinds:
        return "unclear"
    return "caught as " + "+".join(sorted(set(kinds)))


def rs_scene(root, kind, seed):
    """A real 8-mic line: the measured room responses of polimi-ispl/rs-mnmf (channels
    12-19 of its first 32-mic line, 3 cm apart, resampled to 16 kHz) from its nine
    loudspeakers: 8 claps from 8 of them, or 3 of its talkers from 3. Returns the
    recording, the rate, the directions (array frame: the line along y) and the
    positions."""
    import scipy.io
    from scipy.signal import fftconvolve, resample_poly

    rng = np.random.default_rng(seed)
    src = os.path.join(root, "data", "sources")
    mics = list(range(12, 20))
    rate = 16000
    rirs = [resample_poly(read_any(os.path.join(src, f"rir_source_{k}.wav"))[:, mics], 1, 3, axis=0)
            for k in range(1, 10)]
    loc = scipy.io.loadmat(os.path.join(src, "source_location.mat"))["sourceLocation"]
    zc = (mics[0] + mics[-1]) / 2 * 0.03
    pos = np.array([[0.0, m * 0.03 - zc, 0.0] for m in mics])
    dirs_all = [(np.degrees(np.arctan2(loc[k][1] - zc, loc[k][0])) % 360.0, 0.0) for k in range(9)]
    count = 8 if kind == "claps" else 3
    which = rng.choice(9, count, replace=False)
    parts, t = [], 0.3
    for k in which:
        if kind == "claps":
            sig = clap(rate, rng)
            step = 0.5
        else:
            g = ("male", "female")[rng.integers(2)]
            x = read_any(os.path.join(root, "data", "audio", g, f"{rng.integers(1, 4)}.wav"))[:, 0]
            start = rng.integers(0, len(x) - int(1.6 * rate))
            sig = x[start:start + int(1.6 * rate)]
            sig = sig / (np.std(sig) + 1e-12)
            step = 1.9
        parts.append((sig, k, t))
        t += step
    out = np.zeros((int((t + 1.0) * rate), len(mics)))
    for sig, k, t0 in parts:
        y = fftconvolve(sig[:, None], rirs[k], axes=0)
        i = int(t0 * rate)
        out[i:i + len(y)] += y[: len(out) - i]
    out = out / np.max(np.abs(out)) * 0.5
    out += rng.standard_normal(out.shape) * 10 ** (-70 / 20)
    return out.astype(np.float32), rate, [dirs_all[k] for k in which], pos


def read_any(path):
    """A WAV (PCM 16/24/32 or float) as float frames x channels."""
    from scipy.io import wavfile

    r, x = wavfile.read(path)
    if x.dtype.kind == "i":
        x = x / float(np.iinfo(x.dtype).max)
    return x.reshape(len(x), -1).astype(float)


def faults(args, table, wrong, name, tag, d, x, rate, pos, expect, seed):
    """Every fault made on `x` (the recording of `pos`, the right geometry), checked,
    and counted into `table` (and `wrong`)."""
    m = len(pos)
    good = os.path.join(d, "array.toml")
    open(good, "w").write(geometry_toml(pos, name))
    cases = []  # (fault, fix, wav, geometry, expect)

    def wav(label, y):
        p = os.path.join(d, label + ".wav")
        write_wav(p, y, rate)
        return p

    rec = wav("rec", x)
    cases.append(("none", None, rec, good, expect))
    cases.append(("none (no --expect)", None, rec, good, None))
    for i in range(m):
        for j in range(i + 1, m):
            y = x.copy()
            y[:, [i, j]] = y[:, [j, i]]
            fix = list(range(m))
            fix[i], fix[j] = j, i
            cases.append(("swap", fix, wav(f"swap{i}{j}", y), good, expect))
    y = x.copy()
    y[:, 0] = -y[:, 0]
    cases.append(("inverted", None, wav("inverted", y), good, expect))
    y = x.copy()
    y[:, 1] = np.random.default_rng(seed).standard_normal(len(y)) * 10 ** (-70 / 20)
    cases.append(("dead", None, wav("dead", y), good, expect))
    y = x.copy()
    y[:, 3] = y[:, 2]
    cases.append(("duplicated", None, wav("duplicated", y), good, expect))
    moved = pos.copy()
    nearest = min(np.linalg.norm(pos[1] - p) for k, p in enumerate(pos) if k != 1)
    step = np.cross(pos[1] - pos.mean(axis=0), [0.0, 0.0, 1.0])
    if np.linalg.norm(step) < 1e-9:
        step = np.array([1.0, 0.0, 0.0])
    moved[1] += step / np.linalg.norm(step) * 0.3 * nearest
    g = os.path.join(d, "moved.toml")
    open(g, "w").write(geometry_toml(moved, name))
    cases.append(("moved", None, rec, g, expect))
    for f in (10, 100):
        g = os.path.join(d, f"units{f}.toml")
        open(g, "w").write(geometry_toml(pos * f, name))
        cases.append((f"units x{f}", None, rec, g, expect))
    for fault, fix, w, g, e in cases:
        report = check(args.ssl, w, g, e)
        fault_key = "swap" if fault == "swap" else fault
        o = outcome("none" if fault.startswith("none") else fault_key, fix, report)
        row = table.setdefault((name, fault), {})
        row[o] = row.get(o, 0) + 1
        if o.startswith("FITS") or o.startswith("WRONG") or o.startswith("false alarm"):
            msgs = "; ".join(f["kind"] + ": " + f["message"][:160] for f in report["findings"])
            wrong.append(f"{tag} {fault} {os.path.basename(w)} {os.path.basename(g)}: {o}: {msgs}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ssl", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--speech", default=os.path.join(os.path.dirname(__file__), "..", "testdata", "speech"))
    ap.add_argument("--rt60", default="0.2,0.45,0.7")
    ap.add_argument("--kinds", default="claps,speech")
    ap.add_argument("--arrays", default="")
    ap.add_argument("--rs-mnmf", default=None, help="a checkout of polimi-ispl/rs-mnmf: adds its measured 8-mic line")
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    speech = [read_wav(os.path.join(args.speech, f)) for f in sorted(os.listdir(args.speech)) if f.endswith(".wav")]
    table = {}
    wrong = []
    seed = args.seed
    for array in arrays():
        name, pos, rate, _ = array
        if args.arrays and name not in args.arrays.split(","):
            continue
        for rt60 in [float(v) for v in args.rt60.split(",")]:
            for kind in args.kinds.split(","):
                seed += 1
                tag = f"{name}-{kind}-{rt60}"
                d = os.path.join(args.work, tag)
                os.makedirs(d, exist_ok=True)
                x, rate, dirs = scene(array, rt60, kind, seed, speech, d)
                expect = dirs[0]
                json.dump(dirs, open(os.path.join(d, "directions.json"), "w"))
                faults(args, table, wrong, name, tag, d, x, rate, pos, expect, seed)
                print(f"{tag}: done", file=sys.stderr, flush=True)
    if args.rs_mnmf:
        for kind in args.kinds.split(","):
            for draw in range(3):
                seed += 1
                tag = f"rs-mnmf-line-8-{kind}-{draw}"
                d = os.path.join(args.work, tag)
                os.makedirs(d, exist_ok=True)
                x, rate, dirs, pos = rs_scene(args.rs_mnmf, kind, seed)
                json.dump(dirs, open(os.path.join(d, "directions.json"), "w"))
                faults(args, table, wrong, "rs-mnmf line-8 (measured)", tag, d, x, rate, pos, dirs[0], seed)
                print(f"{tag}: done", file=sys.stderr, flush=True)
    print("| array | fault | what `ssl check` said (cases) |")
    print("|---|---|---|")
    for (name, fault), row in table.items():
        cells = ", ".join(f"{k} {v}" for k, v in sorted(row.items(), key=lambda kv: -kv[1]))
        print(f"| {name} | {fault} | {cells} |")
    print()
    print(f"{len(wrong)} case(s) wrong:")
    for w in wrong:
        print("  " + w)


if __name__ == "__main__":
    sys.exit(main())
