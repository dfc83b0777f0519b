#!/usr/bin/env python3
"""`ssl check` on faults made on purpose: for each scene that `benches/uncertainty.py`
rendered (nine arrays in reverberant rooms, real speech), the recording as it is, with
channels 1 and 2 swapped, with channel 3 inverted, and with microphone 3 moved 3 cm in
the geometry; prints what `ssl check` reported for each, and a summary.

    python3 benches/uncertainty.py --ssl target/release/ssl --seed 100 --scenes 8 --work DIR
    python3 benches/check.py --ssl target/release/ssl --work DIR [--scenes 3]

Needs numpy.
"""

import argparse
import json
import os
import re
import struct
import subprocess
import sys

import numpy as np


def read_float_wav(path):
    """The samples of a float32 WAV as `ssl simulate` writes it (frames x channels)."""
    b = open(path, "rb").read()
    i, ch, rate = 12, None, None
    while i < len(b):
        cid, size = b[i:i + 4], struct.unpack("<I", b[i + 4:i + 8])[0]
        if cid == b"fmt ":
            ch, rate = struct.unpack("<H", b[i + 10:i + 12])[0], struct.unpack("<I", b[i + 12:i + 16])[0]
        if cid == b"data":
            return np.frombuffer(b[i + 8:i + 8 + size], dtype="<f4").reshape(-1, ch).copy(), rate
        i += 8 + size + (size & 1)
    raise ValueError(f"{path}: no data")


def write_float_wav(path, x, rate):
    x = np.asarray(x, dtype="<f4")
    ch, data = x.shape[1], x.tobytes()
    fmt = struct.pack("<HHIIHH", 3, ch, rate, rate * ch * 4, ch * 4, 32)
    with open(path, "wb") as f:
        f.write(b"RIFF" + struct.pack("<I", 36 + len(data)) + b"WAVE" + b"fmt " + struct.pack("<I", 16) + fmt
                + b"data" + struct.pack("<I", len(data)) + data)


def check(ssl, wav, geometry):
    out = subprocess.run([ssl, "check", wav, "-g", geometry, "-f", "json"], capture_output=True, text=True)
    if out.returncode == 2:
        return ["error"]
    return [f["kind"] for f in json.loads(out.stdout)["findings"]]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ssl", required=True)
    ap.add_argument("--work", required=True, help="the --work directory of benches/uncertainty.py")
    ap.add_argument("--scenes", type=int, default=3, help="scenes per array")
    args = ap.parse_args()
    counts = {}
    print("| scene | as it is | channels 1, 2 swapped | channel 3 inverted | mic 3 moved 3 cm |")
    print("|---|---|---|---|---|")
    k = 0
    while os.path.exists(os.path.join(args.work, f"array{k}.toml")):
        geometry = os.path.join(args.work, f"array{k}.toml")
        text = open(geometry).read()
        name = re.search(r'name = "([^"]*)"', text).group(1)
        seeds = sorted(d for d in os.listdir(args.work) if d.startswith(f"{k}-"))[: args.scenes]
        for d in seeds:
            d = os.path.join(args.work, d)
            x, rate = read_float_wav(os.path.join(d, "rec.wav"))
            y = x.copy()
            y[:, [0, 1]] = y[:, [1, 0]]
            write_float_wav(os.path.join(d, "swap.wav"), y, rate)
            y = x.copy()
            y[:, 2] = -y[:, 2]
            write_float_wav(os.path.join(d, "inverted.wav"), y, rate)
            positions = [[float(v) for v in m.split(",")] for m in re.findall(r"position = \[([^\]]*)\]", text)]
            moved = "".join(
                f"[[mic]]\nposition = [{p[0] + (0.03 if i == 2 else 0.0)}, {p[1]}, {p[2]}]\n" for i, p in enumerate(positions))
            with open(os.path.join(d, "moved.toml"), "w") as f:
                f.write(moved)
            row = {
                "ok": check(args.ssl, os.path.join(d, "rec.wav"), geometry),
                "swap": check(args.ssl, os.path.join(d, "swap.wav"), geometry),
                "inverted": check(args.ssl, os.path.join(d, "inverted.wav"), geometry),
                "moved": check(args.ssl, os.path.join(d, "rec.wav"), os.path.join(d, "moved.toml")),
            }
            for case, kinds in row.items():
                c = counts.setdefault(case, {})
                key = "fits" if not kinds else "+".join(sorted(set(kinds)))
                c[key] = c.get(key, 0) + 1
            cell = lambda v: ", ".join(v) if v else "fits"
            print(f"| {name} ({os.path.basename(d)}) | {cell(row['ok'])} | {cell(row['swap'])} | {cell(row['inverted'])} | {cell(row['moved'])} |")
        k += 1
    print()
    for case, c in counts.items():
        print(f"{case}: " + ", ".join(f"{v} {k}" for k, v in sorted(c.items(), key=lambda kv: -kv[1])))


if __name__ == "__main__":
    sys.exit(main())
