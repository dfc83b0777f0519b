"""Fixtures: the repository, the `ssl` command line (built if need be) to compare with,
and scenes simulated by it."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.io import wavfile

ROOT = Path(__file__).resolve().parents[2]
TESTDATA = ROOT / "testdata"
PRISM = TESTDATA / "prism.toml"
EXAMPLE = TESTDATA / "example.wav"


@pytest.fixture(scope="session")
def ssl_bin() -> Path:
    """The `ssl` binary of this clone: $SSL_BIN, else target/release/ssl, built when
    missing."""
    given = os.environ.get("SSL_BIN")
    if given:
        return Path(given)
    path = ROOT / "target" / "release" / "ssl"
    if not path.exists():
        subprocess.run(
            ["cargo", "build", "--release", "--locked", "--bin", "ssl"], cwd=ROOT, check=True
        )
    return path


def cli_json(ssl_bin: Path, wav: Path, geometry: Path, *flags: str) -> dict:
    """`ssl analyze --format json --sources` of `wav` (its events and sources when
    tracked)."""
    untracked = "--no-track" in flags or "--every-frame" in flags
    sources = [] if untracked else ["--sources"]
    out = subprocess.run(
        [str(ssl_bin), "analyze", str(wav), "-g", str(geometry), "--format", "json",
         "--quiet", *sources, *flags],
        check=True, capture_output=True, text=True,
    )
    return json.loads(out.stdout)


def read_wav(path: Path):
    """(rate, samples x channels) as the file holds them (int16, int32 or float32)."""
    rate, x = wavfile.read(path)
    return rate, x


@pytest.fixture(scope="session")
def scenes(ssl_bin, tmp_path_factory) -> dict:
    """Three recordings with their geometry: the shipped example; the shipped scene
    (the prism in a room of RT60 0.35 s, 16-bit); a 6-mic circle of radius 4.63 cm
    (float32, 16 kHz) with a talker and a fan in RT60 0.45 s, simulated here."""
    work = tmp_path_factory.mktemp("scenes")
    shutil.copy(PRISM, work / "prism.toml")
    circle = work / "circle.toml"
    circle.write_text(
        "".join(
            f"[[mic]]\nposition = [{0.0463 * np.cos(a):.6f}, {0.0463 * np.sin(a):.6f}, 0.0]\n"
            for a in np.arange(6) * np.pi / 3
        )
    )
    scene = (TESTDATA / "scene.toml").read_text()
    (work / "scene.toml").write_text(scene)
    speech = TESTDATA / "speech" / "arctic_a0010.wav"
    (work / "circle_scene.toml").write_text(f"""
sample_rate = 16000
duration = 3.0
seed = 7
format = "float32"
[room]
dimensions = [6.0, 5.0, 3.0]
rt60 = 0.45
[array]
geometry = "circle.toml"
position = [3.0, 2.5, 1.2]
[[source]]
azimuth_deg = -70.0
elevation_deg = 10.0
distance = 1.8
signal = "file"
file = "{speech}"
level_db = -26
active = [[0.3, 2.8]]
[noise]
snr_db = 15
[[noise.fan]]
position = [5.5, 0.5, 2.5]
signal = "pink"
""")
    for name in ["scene", "circle_scene"]:
        subprocess.run(
            [str(ssl_bin), "simulate", str(work / f"{name}.toml"), "-o", str(work / f"{name}.wav")],
            check=True, capture_output=True,
        )
    return {
        "example": (EXAMPLE, PRISM),
        "scene": (work / "scene.wav", work / "prism.toml"),
        "circle": (work / "circle_scene.wav", circle),
    }
