#!/usr/bin/env python3
"""The Python package against the command line on the same audio: time and memory.

Simulates a long recording with `ssl simulate` (the shipped scene's room and sources,
repeated), then times, best of REPEATS runs each:

- `ssl analyze REC -g prism.toml --format json -o /dev/null` (the command line, reading
  the file), on the 16-bit WAV and on the same samples as a float32 WAV;
- `ssloc.analyze(REC, ...)` (the package, reading the same file);
- `ssloc.analyze(samples, ...)` on the samples already in memory as int16 (what the file
  holds), float32, and float64 in Fortran order, each read in place;

each array against the command line on the WAV of its sample type (float64 against
float32: WAV files hold no float64), and measures, in a child process per case, the memory the analysis takes beyond the
samples loaded (the resident set sampled every 5 ms): no copy of the samples.

    python3 benches/python.py --ssl target/release/ssl [--seconds 600] [--repeats 5]

Needs the package installed (pip install ./python) and scipy.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.io import wavfile

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, sys, threading, time
import numpy as np
from scipy.io import wavfile
import ssloc

def rss_kb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 // 1024

case, wav, geometry = sys.argv[1:4]
rate, x = wavfile.read(wav) if case != "path" else (None, np.zeros(0))
if case == "float32":
    x = x.astype(np.float32) / 32768
elif case == "float64-fortran":
    x = np.asfortranarray(x.astype(np.float64) / 32768)
loaded = rss_kb()
peak = [loaded]
done = threading.Event()
def watch():
    while not done.is_set():
        peak[0] = max(peak[0], rss_kb())
        time.sleep(0.005)
watcher = threading.Thread(target=watch)
watcher.start()
start = time.perf_counter()
if case == "path":
    r = ssloc.analyze(wav, geometry)
else:
    r = ssloc.analyze(x, geometry, rate, name=wav)
took = time.perf_counter() - start
done.set()
watcher.join()
print(json.dumps({"seconds": took, "rows": r.rows.rows, "loaded_kb": loaded,
                  "peak_kb": peak[0], "samples_mb": x.nbytes / 1e6}))
"""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ssl", default=str(ROOT / "target" / "release" / "ssl"))
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="ssloc-bench-"))
    try:
        shutil.copy(ROOT / "testdata" / "prism.toml", work / "prism.toml")
        scene = (ROOT / "testdata" / "scene.toml").read_text()
        # 60 s of the scene with its sources again every 4 s (the simulator holds a
        # recording in memory), repeated to the length asked for.
        scene = scene.replace("duration = 4.0", "duration = 60.0").replace("level_db = -26", "level_db = -32")
        starts = range(0, 57, 4)
        scene = scene.replace(
            "active = [[0.5, 1.8]]", "active = [" + ", ".join(f"[{t + 0.5}, {t + 1.8}]" for t in starts) + "]"
        ).replace(
            "active = [[2.3, 3.5]]", "active = [" + ", ".join(f"[{t + 2.3}, {t + 3.5}]" for t in starts) + "]"
        )
        (work / "scene.toml").write_text(scene)
        part = work / "part.wav"
        subprocess.run([args.ssl, "simulate", str(work / "scene.toml"), "-o", str(part)],
                       check=True, capture_output=True)
        rate, x = wavfile.read(part)
        copies = max(1, round(args.seconds / 60.0))
        wav = work / "long.wav"
        wavfile.write(wav, rate, np.tile(x, (copies, 1)))
        del x
        args.seconds = 60.0 * copies
        geometry = str(work / "prism.toml")
        print(f"{args.seconds:.0f} s, 8 ch, 48 kHz, 16-bit ({wav.stat().st_size / 1e6:.0f} MB); best of {args.repeats}")

        def cli(path):
            """The command line's time, and its peak memory by /usr/bin/time (a child's
            rusage through a fork counts the parent's pages)."""
            start = time.perf_counter()
            out = subprocess.run(["/usr/bin/time", "-f", "%M", args.ssl, "analyze", str(path), "-g",
                                  geometry, "--format", "json", "-o", "/dev/null", "--quiet"],
                                 check=True, capture_output=True, text=True)
            return {"seconds": time.perf_counter() - start,
                    "peak_kb": int(out.stderr.strip().splitlines()[-1])}

        def child(case):
            out = subprocess.run([sys.executable, "-c", CHILD, case, str(wav), geometry],
                                 check=True, capture_output=True, text=True).stdout
            return json.loads(out)

        wav32 = work / "long32.wav"
        wavfile.write(wav32, rate, (np.tile(wavfile.read(part)[1], (copies, 1)) / 32768).astype(np.float32))
        # Rounds of every case in turn, so that a slow spell of the machine falls on all.
        cases = [("cli", "int16", wav), ("cli", "float32", wav32), ("py", "path", None),
                 ("py", "int16", None), ("py", "float32", None), ("py", "float64-fortran", None)]
        runs = {c: [] for c in cases}
        for _ in range(args.repeats):
            for c in cases:
                runs[c].append(cli(c[2]) if c[0] == "cli" else child(c[1]))
        best = {c: min(runs[c], key=lambda r: r["seconds"]) for c in cases}
        clis = {c[1]: best[c]["seconds"] for c in cases if c[0] == "cli"}
        against = {"path": "int16", "int16": "int16", "float32": "float32", "float64-fortran": "float32"}
        rows = []
        for c in cases:
            b = best[c]
            if c[0] == "cli":
                rows.append((f"ssl analyze ({c[1]} WAV)", b["seconds"], 1.0, None, b["peak_kb"] / 1e3, None))
            else:
                rows.append((f"ssloc.analyze ({c[1]})", b["seconds"], b["seconds"] / clis[against[c[1]]],
                             b["samples_mb"] if c[1] != "path" else None, b["peak_kb"] / 1e3,
                             (b["peak_kb"] - b["loaded_kb"]) / 1e3))
        print(f"{'run':28} {'time (s)':>9} {'vs CLI':>7} {'samples (MB)':>13} {'peak RSS (MB)':>14} {'beyond loaded (MB)':>19}")
        for name, t, ratio, samples, peak, extra in rows:
            shown = "" if samples is None else f"{samples:.0f}"
            more = "" if extra is None else f"{extra:.0f}"
            print(f"{name:28} {t:9.3f} {ratio:7.3f} {shown:>13} {peak:14.0f} {more:>19}")
    finally:
        shutil.rmtree(work)


if __name__ == "__main__":
    main()
