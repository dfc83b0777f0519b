"""ssloc: where sounds come from, from a microphone array's recording.

The ``ssl`` command line's localizer (Valin, Michaud, Rouat and Létourneau, IROS 2003,
and what ssl adds: several sources, tracking, events, an uncertainty per row) as a
Python package, on numpy arrays and audio files. The import name is ``ssloc`` so as not
to shadow Python's own ``ssl`` module.

    >>> import ssloc
    >>> result = ssloc.analyze("testdata/example.wav", "testdata/prism.toml")
    >>> result.rows["azimuth_deg"][:3]
    >>> result.events.to_pandas()

Names and units are those of the command line and its results (docs/interface.md):
``ssloc.analyze(audio, geometry, false_per_hour=1000)`` runs what
``ssl analyze AUDIO -g GEOMETRY --false-per-hour 1000`` runs and gives the same rows.

- :func:`analyze` / :class:`Localizer`: directions, events and sources.
- :func:`check`: does a recording fit its geometry and channel order (``ssl check``)?
- :func:`evaluate`: a result against the truth (``ssl evaluate``).
- :func:`options`: every option, its flag, help and default; :data:`PRESETS`.

Errors are exceptions carrying the command line's message: ``ValueError`` for bad
options, geometries, samples and file contents, ``OSError`` for a file that cannot be
opened or read, ``TypeError`` for an argument of the wrong kind. The analysis runs
without the GIL (other Python threads run meanwhile, and several analyses may run at
once) and stops at Ctrl-C with ``KeyboardInterrupt``.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import TYPE_CHECKING, Any, Optional, Union

import numpy as np

if TYPE_CHECKING:
    from typing_extensions import Unpack

from . import _native
from ._options import Options

__all__ = [
    "Localizer",
    "Result",
    "Table",
    "analyze",
    "check",
    "evaluate",
    "options",
    "Options",
    "PRESETS",
    "SslWarning",
    "__version__",
]

__version__: str = _native.version()

#: The presets by name, as the options that make them: ``default`` (the defaults),
#: ``paper`` (the paper's method as published, ``paper=True``), ``untracked``
#: (every frame's detection, no tracker, ``no_track=True``) and ``every_frame`` (a
#: direction for every frame, no detection decision, ``every_frame=True``).
PRESETS: dict[str, dict[str, bool]] = {
    name: {keyword: True for keyword in keywords} for name, keywords in _native.presets()
}

PathLike = Union[str, "os.PathLike[str]"]
#: A geometry: a TOML file's path, a dict of the file's form (``{"mic": [{"position":
#: [x, y, z]}, ...]}``), or an (M, 3) array of positions in metres.
Geometry = Union[PathLike, Mapping[str, Any], np.ndarray, list]
#: Audio: a WAV, RF64 or FLAC file's path; a numpy array (samples x channels) of
#: int16, int32, float32 or float64, in C or Fortran order; or an iterable of such
#: blocks (live audio), of any sizes.
Audio = Union[PathLike, np.ndarray, Iterable[np.ndarray]]


class SslWarning(UserWarning):
    """A remark about a recording or a geometry (the command line's warnings)."""


def options() -> list[dict[str, Any]]:
    """Every option of :class:`Localizer`, in the order of ``ssl analyze --help``.

    Each is a dict: ``keyword`` (the keyword argument), ``flag`` (the command line's),
    ``help``, ``section``, ``switch`` (True/False, else a value), ``value_name``,
    ``choices``, ``default`` (None when it depends on others) and ``repeatable``.
    """
    return _native.options()


class Table(Mapping):
    """Records as columns: ``table["azimuth_deg"]`` is a numpy array, one value per row.

    The columns are the fields of the command line's records, in its order
    (docs/interface.md). Integers are int64 and numbers float64; a numeric column with
    absent values is float64 with NaN there; text columns are arrays of str (object
    when a value is absent).
    """

    def __init__(self, columns: Mapping[str, Any]):
        self._columns: dict[str, np.ndarray] = {}
        for name, values in columns.items():
            if isinstance(values, np.ndarray):
                self._columns[name] = values
            elif all(isinstance(v, str) for v in values):
                self._columns[name] = np.array(values, dtype=str)
            else:
                self._columns[name] = np.array(values, dtype=object)

    def __getitem__(self, name: str) -> np.ndarray:
        return self._columns[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._columns)

    def __len__(self) -> int:
        """The number of columns (a Mapping's); :attr:`rows` is the number of rows."""
        return len(self._columns)

    @property
    def rows(self) -> int:
        """The number of rows."""
        return len(next(iter(self._columns.values()))) if self._columns else 0

    def to_records(self) -> np.ndarray:
        """The rows as one numpy structured array."""
        arrays = list(self._columns.values())
        return np.rec.fromarrays(
            arrays, formats=[a.dtype for a in arrays], names=list(self._columns)
        )

    def to_pandas(self):
        """The rows as a pandas DataFrame (pandas must be installed)."""
        import pandas as pd

        return pd.DataFrame(self._columns)

    def __repr__(self) -> str:
        return f"Table({self.rows} rows: {', '.join(self._columns)})"


class Result:
    """What one recording gave: :attr:`rows`, :attr:`events`, :attr:`sources`,
    :attr:`metadata`, :attr:`file` and :attr:`warnings`.

    - ``rows``: a direction per detection (``time_s``, ``azimuth_deg``,
      ``elevation_deg``, ``x``, ``y``, ``z``, ``score``, ``file``, ``frame``, ``mics``,
      ``source``, ``uncertainty_deg``), as ``ssl analyze`` writes them.
    - ``events``: each source's stretches of activity (``ssl analyze --events``); empty
      untracked.
    - ``sources``: one per tracked source over the whole recording (``--sources``).
    - ``metadata``: the JSON result's metadata (tool, geometry, the resolved
      ``parameters``).
    - ``file``: the JSON result's ``files`` entry (format, frames, tracking counts).
    - ``warnings``: the remarks the command line prints (each also issued as a
      :class:`SslWarning`).
    """

    def __init__(self, run: Any):
        self._run = run
        self.rows = Table(run.rows())
        self.events = Table(run.events())
        self.sources = Table(run.sources())
        self.metadata: dict[str, Any] = run.metadata()
        self.file: dict[str, Any] = run.file()
        self.warnings: list[str] = list(self.file.get("warnings") or [])

    def __repr__(self) -> str:
        return (
            f"Result({self.file.get('file')!r}: {self.rows.rows} rows, "
            f"{self.events.rows} events, {self.sources.rows} sources)"
        )


def _positions(geometry: Geometry) -> Any:
    """A geometry as the native module takes it: a path, a dict, or a list of rows."""
    if isinstance(geometry, (str, os.PathLike)):
        return os.fspath(geometry)
    if isinstance(geometry, Mapping):
        return dict(geometry)
    try:
        array = np.asarray(geometry, dtype=float)
    except (TypeError, ValueError):
        array = np.asarray(None)
    if array.ndim == 0:
        raise TypeError(
            "geometry must be a TOML file's path, a dict of its form, or (M, 3) positions "
            f"in metres, not {type(geometry).__name__}"
        )
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(
            f"geometry: positions must be an (M, 3) array in metres, not shape {array.shape}"
        )
    return array.tolist()


def _samples(block: Any) -> np.ndarray:
    """An array the native module reads in place: native byte order (one conversion
    copy otherwise)."""
    array = np.asarray(block)
    if not array.dtype.isnative:
        array = array.astype(array.dtype.newbyteorder("="))
    return array


def _warn(messages: Iterable[str]) -> None:
    for m in messages:
        warnings.warn(m, SslWarning, stacklevel=3)


class Localizer:
    """An array and the options it is analysed with; analyses any number of recordings,
    from any number of threads at once.

    ``geometry``: a TOML file's path, a dict of the file's form, or an (M, 3) array of
    microphone positions in metres (channel m is microphone m). ``preset``: ``default``,
    ``paper``, ``untracked`` or ``every_frame`` (:data:`PRESETS`). ``options``: the command line's flags
    as keyword arguments, ``--false-per-hour 1000`` as ``false_per_hour=1000``, a switch
    as ``True`` (``paper=True``, ``no_track=True``); :func:`options` lists them and
    :class:`Options` types them. Raises ``ValueError`` for a bad option or geometry,
    ``OSError`` for a geometry file that cannot be read.
    """

    def __init__(
        self, geometry: Geometry, *, preset: Optional[str] = None, **options: Unpack[Options]
    ):
        self._native = _native.Localizer(_positions(geometry), preset, dict(options))
        _warn(self._native.geometry_warnings())

    @property
    def config(self) -> dict[str, Any]:
        """The configuration, every choice made (the JSON result's ``parameters``)."""
        return self._native.config()

    @property
    def metadata(self) -> dict[str, Any]:
        """The metadata a result of this localizer carries."""
        return self._native.metadata()

    def analyze(
        self,
        audio: Audio,
        sample_rate: Optional[int] = None,
        *,
        name: Optional[str] = None,
        on_record: Optional[Callable[[str, dict[str, Any]], Any]] = None,
    ) -> Result:
        """Analyses one recording.

        ``audio``: a file's path (its own sample rate), a numpy array of samples x
        channels, or an iterable of such blocks (both with ``sample_rate`` in Hz). Integer
        samples are scaled as a WAV file's are (int16 by 2^15, int32 by 2^31); floats are
        taken as they are (full scale 1). ``name`` names an array in messages and in the
        rows' ``file`` column (default ``<array>``). ``on_record(kind, record)`` is called
        with each record as the run gives it, ``kind`` being ``"row"``, ``"event"`` or
        ``"source"`` and ``record`` a dict of the record's fields (live audio: blocks
        are analysed as they come, so rows arrive while the iterable still runs); an
        exception it raises stops the run and is raised again.
        """
        if isinstance(audio, (str, os.PathLike)):
            if sample_rate is not None:
                raise ValueError("sample_rate is for arrays and blocks: a file has its own")
            run = self._native.analyze_path(os.fspath(audio), on_record)
        else:
            if sample_rate is None:
                raise ValueError("an array's or blocks' sample_rate (Hz) must be given")
            if int(sample_rate) != sample_rate or sample_rate <= 0:
                raise ValueError(f"sample_rate must be a positive whole number of Hz, not {sample_rate!r}")
            shown = name if name is not None else "<array>"
            if isinstance(audio, np.ndarray) or hasattr(audio, "__array__"):
                run = self._native.analyze_array(_samples(audio), int(sample_rate), shown, on_record)
            elif isinstance(audio, Iterable):
                blocks = (_samples(b) for b in audio)
                run = self._native.analyze_blocks(blocks, int(sample_rate), shown, on_record)
            else:
                raise TypeError(
                    "audio must be a file's path, a numpy array (samples x channels) "
                    f"or an iterable of such blocks, not {type(audio).__name__}"
                )
        result = Result(run)
        _warn(result.warnings)
        return result


def analyze(
    audio: Audio,
    geometry: Geometry,
    sample_rate: Optional[int] = None,
    *,
    name: Optional[str] = None,
    on_record: Optional[Callable[[str, dict[str, Any]], Any]] = None,
    preset: Optional[str] = None,
    **options: Unpack[Options],
) -> Result:
    """``ssl analyze``: one recording's directions, events and sources.

    The same as ``Localizer(geometry, preset=preset, **options).analyze(audio,
    sample_rate, name=name, on_record=on_record)``; see :class:`Localizer`.
    """
    return Localizer(geometry, preset=preset, **options).analyze(
        audio, sample_rate, name=name, on_record=on_record
    )


def check(
    audio: Union[PathLike, np.ndarray],
    geometry: Geometry,
    sample_rate: Optional[int] = None,
    *,
    expect: Iterable[tuple] = (),
    name: Optional[str] = None,
) -> dict[str, Any]:
    """``ssl check``: does a recording fit its geometry and its channel order?

    Returns the report as ``ssl check --format json`` writes it: ``fits``,
    ``findings`` (each with ``kind``, ``message`` and, for a channel order that fits
    better, ``order``), ``remarks``, levels and the far-field fit. ``expect``: sounds
    from known directions, as ``(azimuth_deg, elevation_deg)`` or ``(azimuth_deg,
    elevation_deg, at_s)`` (``--expect AZ/EL@T``).
    """
    wanted = []
    for e in expect:
        e = tuple(e)
        if len(e) not in (2, 3):
            raise ValueError(f"expect: (azimuth_deg, elevation_deg[, at_s]), not {e!r}")
        wanted.append((float(e[0]), float(e[1]), float(e[2]) if len(e) == 3 else None))
    if isinstance(audio, (str, os.PathLike)):
        if sample_rate is not None:
            raise ValueError("sample_rate is for arrays: a file has its own")
        return _native.check(os.fspath(audio), _positions(geometry), None, "<array>", wanted)
    shown = name if name is not None else "<array>"
    return _native.check(_samples(audio), _positions(geometry), sample_rate, shown, wanted)


def evaluate(
    result: Union[Result, PathLike],
    truth: Union[PathLike, Mapping[str, Any]],
    *,
    geometry: Optional[Geometry] = None,
    metric: Optional[str] = None,
    tail: Optional[float] = None,
) -> dict[str, Any]:
    """``ssl evaluate``: a result against the truth; the report as ``--json`` writes it.

    ``result``: a :class:`Result` (scored by what its array observes: the azimuth for a
    planar array, the angle to the axis for a linear one) or a result file's path.
    ``truth``: a truth file (JSON from ``ssl simulate``, CSV, Audacity, ELAN or Praat
    labels) or a dict of the JSON form. ``metric``: ``3d``, ``azimuth`` or ``axis``.
    ``tail``: seconds a source stays audible after it stops (default: one frame, and
    half the truth's RT60 when it has a room).
    """
    given = result._run if isinstance(result, Result) else os.fspath(result)
    array = None if geometry is None else _positions(geometry)
    truth = dict(truth) if isinstance(truth, Mapping) else os.fspath(truth)
    return _native.evaluate(given, truth, array, metric, tail)
