"""The package's types hold: mypy finds no error in it, and a misspelled option is an
error before anything runs (the options are typed from the flags)."""

import subprocess
import sys

import pytest

from conftest import ROOT

pytest.importorskip("mypy")


def mypy(*args):
    return subprocess.run([sys.executable, "-m", "mypy", "--no-incremental", *args],
                          capture_output=True, text=True, cwd=ROOT / "python")


def test_the_package_type_checks():
    out = mypy("-p", "ssloc")
    assert out.returncode == 0, out.stdout + out.stderr


def test_a_misspelled_option_is_a_type_error(tmp_path):
    use = tmp_path / "use.py"
    use.write_text(
        "import numpy as np\nimport ssloc\n"
        "r = ssloc.analyze(np.zeros((16000, 8), dtype=np.float32), 'prism.toml', 16000, false_per_hour=1000)\n"
        "azimuths: np.ndarray = r.rows['azimuth_deg']\n"
        "ssloc.Localizer('prism.toml', windw='hann')\n"
    )
    out = mypy(str(use))
    assert out.returncode == 1
    assert 'Unexpected keyword argument "windw"' in out.stdout, out.stdout
    assert out.stdout.count("error:") == 1, out.stdout
