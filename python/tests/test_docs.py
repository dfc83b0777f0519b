"""docs/python.md says what is: its Python blocks run, in order, in one namespace, and
each text block after one is what it printed."""

import contextlib
import io
import re

import pytest

from conftest import ROOT

DOC = ROOT / "docs" / "python.md"


def blocks():
    """(language, text) of every fenced block, in order."""
    return re.findall(r"```(\w+)\n(.*?)```", DOC.read_text(), re.S)


def normal(text):
    return [" ".join(line.split()) for line in text.strip().splitlines()]


def test_the_python_page_runs_and_prints_what_it_shows(tmp_path, monkeypatch):
    pytest.importorskip("pyroomacoustics")
    pytest.importorskip("matplotlib")
    pytest.importorskip("pandas")
    # The page runs from the top of a clone: testdata/ beside it, its files written here.
    (tmp_path / "testdata").symlink_to(ROOT / "testdata")
    monkeypatch.chdir(tmp_path)
    namespace = {}
    printed = None
    checked = 0
    for language, text in blocks():
        if language == "python":
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                exec(compile(text, str(DOC), "exec"), namespace)
            printed = out.getvalue()
        elif language == "text" and printed is not None:
            assert normal(text) == normal(printed), printed
            checked += 1
            printed = None
    assert checked >= 2
    assert (tmp_path / "directions.png").stat().st_size > 10_000
