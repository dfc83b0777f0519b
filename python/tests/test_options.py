"""The options are the command line's flags, from their one definition: the keywords,
the typed `ssloc.Options` (generated, kept in sync here) and the presets."""

import os
import re
import subprocess
from pathlib import Path

import numpy as np

import ssloc

from conftest import EXAMPLE, PRISM, read_wav

OPTIONS_PY = Path(ssloc.__file__).with_name("_options.py")


def generated_options() -> str:
    """The text of ssloc/_options.py, from ssloc.options()."""
    lines = [
        '"""The options of :class:`ssloc.Localizer`, typed: one per flag of `ssl analyze`',
        "that changes what is found, generated from the flags' definitions by",
        "python/tests/test_options.py (`SSLOC_UPDATE=1 pytest tests/test_options.py`",
        'rewrites it). Do not edit."""',
        "",
        "from typing import Literal, Sequence, TypedDict, Union",
        "",
        "",
        "class Options(TypedDict, total=False):",
        '    """Keyword arguments of :class:`ssloc.Localizer` and :func:`ssloc.analyze`: the',
        "    command line's flags, ``--false-per-hour 1000`` as ``false_per_hour=1000``, a",
        '    switch as ``True``."""',
    ]
    section = None
    for o in ssloc.options():
        if o["section"] != section:
            section = o["section"]
            lines += ["", f"    # {section}"]
        if o["switch"]:
            kind = "bool"
        elif o["choices"]:
            kind = "Literal[" + ", ".join(repr(c) for c in o["choices"]) + "]"
        else:
            kind = "Union[float, str]"
        if o["repeatable"]:
            kind = f"Union[{kind}, Sequence[{kind}]]"
        lines.append(f"    {o['keyword']}: {kind}")
        help_text = o["help"].replace("\\", "\\\\").replace('"""', "'''")
        default = f" [default: {o['default']}]" if o["default"] else ""
        if default and "[default" not in help_text:
            help_text += default
        lines.append(f'    """{o["flag"]}: {help_text}"""')
    return "\n".join(lines) + "\n"


def test_the_typed_options_are_generated_from_the_flags():
    text = generated_options()
    if os.environ.get("SSLOC_UPDATE"):
        OPTIONS_PY.write_text(text)
    assert OPTIONS_PY.read_text() == text, "run SSLOC_UPDATE=1 pytest tests/test_options.py"
    assert set(ssloc.Options.__annotations__) == {o["keyword"] for o in ssloc.options()}


def test_every_option_is_a_flag_of_ssl_analyze_and_back(ssl_bin):
    help_text = subprocess.run(
        [str(ssl_bin), "analyze", "--help"], check=True, capture_output=True, text=True
    ).stdout
    flags = set(re.findall(r"^\s+(?:-\w, )?(--[a-z0-9-]+)", help_text, re.M))
    ours = {o["flag"] for o in ssloc.options()}
    assert ours <= flags, ours - flags
    # What the command line has besides: input, output and reporting, not the method.
    others = {
        "--files-from", "--glob", "--out-dir", "--resume", "--shard", "--geometry",
        "--format", "--output", "--events", "--sources", "--progress", "--quiet",
        "--timings", "--no-warn", "--help", "--version", "--threads", "--jobs", "--flush",
    }
    assert flags - ours <= others, (flags - ours) - others


def test_presets_are_their_options():
    assert ssloc.PRESETS == {
        "default": {},
        "paper": {"paper": True},
        "untracked": {"no_track": True},
        "every_frame": {"every_frame": True},
    }
    for name, options in ssloc.PRESETS.items():
        a = ssloc.Localizer(PRISM, preset=name).config
        b = ssloc.Localizer(PRISM, **options).config
        assert a == b, name
    assert ssloc.Localizer(PRISM, preset="paper").config["paper"] is True
    assert ssloc.Localizer(PRISM, preset="untracked").config["tracking"]["on"] is False
    assert ssloc.Localizer(PRISM, preset="every_frame").config["every_frame"] is True


def test_options_reach_the_configuration_in_their_units():
    config = ssloc.Localizer(
        PRISM, false_per_hour=1000, band="300-3400", frame_ms=32, dereverb="on", wpe=False
    ).config
    assert config["tracking"]["false_per_hour"] == 1000
    assert config["framing"]["size"] == {"ms": 32.0}
    assert config["weighting"]["band_hz"] == [300.0, 3400.0]
    assert config["room"]["dereverb"] == "on"
    assert config["room"]["wpe"] is False


def test_check_on_an_array_is_check_on_its_file():
    rate, x = read_wav(EXAMPLE)
    from_file = ssloc.check(EXAMPLE, PRISM)
    from_array = ssloc.check(x, PRISM, rate, name=str(EXAMPLE))
    assert from_file == from_array
    # The example's prism is symmetric: a known direction settles its order.
    settled = ssloc.check(x, PRISM, rate, expect=[(30, 10, 0.1)])
    assert settled["fits"] is True, settled["findings"]
    # A wrong channel order is found, and the right one proposed.
    swapped = x[:, [1, 0, 2, 3, 4, 5, 6, 7]]
    report = ssloc.check(swapped, PRISM, rate, expect=[(30, 10, 0.1)])
    assert report["fits"] is False
    assert any(f.get("order") == [1, 0, 2, 3, 4, 5, 6, 7] for f in report["findings"]), report
