"""ssloc.analyze against the command line, on files, arrays of every dtype and order,
and blocks of any size; directions against a known truth."""

import json
import math

import numpy as np
import pytest

import ssloc

from conftest import EXAMPLE, PRISM, cli_json, read_wav

# Every column of the rows, events and sources, compared as the JSON writes them.
KINDS = [("rows", "detections"), ("events", "events"), ("sources", "sources")]


def assert_same_as_cli(result: ssloc.Result, document: dict) -> None:
    """`result` holds exactly the records of a JSON result."""
    for kind, key in KINDS:
        table = getattr(result, kind)
        records = document.get(key, [])
        assert table.rows == len(records), kind
        for name in table:
            column = table[name]
            written = [r.get(name) for r in records]
            if column.dtype.kind in "fi":
                expect = np.array([math.nan if v is None else v for v in written], dtype=float)
                np.testing.assert_array_equal(column.astype(float), expect, err_msg=f"{kind}.{name}")
            else:
                assert list(column) == written, f"{kind}.{name}"


@pytest.mark.parametrize("scene", ["example", "scene", "circle"])
def test_an_array_gives_exactly_the_command_lines_rows(ssl_bin, scenes, scene):
    wav, geometry = scenes[scene]
    document = cli_json(ssl_bin, wav, geometry)
    assert document["detections"], "the scene gives rows"
    rate, samples = read_wav(wav)
    from_array = ssloc.analyze(samples, geometry, rate, name=str(wav))
    assert_same_as_cli(from_array, document)
    from_path = ssloc.analyze(wav, geometry)
    assert_same_as_cli(from_path, document)
    # The metadata is the JSON result's, key for key.
    for key, value in from_path.metadata.items():
        assert document[key] == value, key
    assert document["files"][0] == from_path.file


def test_options_change_the_run_as_their_flags_do(ssl_bin, scenes):
    wav, geometry = scenes["scene"]
    for flags, options in [
        (["--paper"], {"paper": True}),
        (["--no-track"], {"preset": "untracked"}),
        (["--every-frame"], {"preset": "every_frame"}),
        (["--false-per-hour", "1000", "--band", "300-3400"], {"false_per_hour": 1000, "band": "300-3400"}),
        (["--frame-ms", "32", "--window", "hamming", "--dereverb", "on"],
         {"frame_ms": 32, "window": "hamming", "dereverb": True}),
    ]:
        document = cli_json(ssl_bin, wav, geometry, *flags)
        result = ssloc.analyze(wav, geometry, **options)
        assert_same_as_cli(result, document)
        assert result.metadata["parameters"] == document["parameters"], flags


def test_every_dtype_and_order_gives_the_same_rows():
    rate, x = read_wav(EXAMPLE)
    assert x.dtype == np.int16
    whole = ssloc.analyze(x, PRISM, rate).rows.to_pandas()
    variants = {
        "int32": x.astype(np.int32) << 16,
        "float32": x.astype(np.float32) / 32768,
        "float64": x.astype(np.float64) / 32768,
        "fortran": np.asfortranarray(x),
        # Every other column of a wider array: no order at all.
        "strided": np.repeat(x, 2, axis=1)[:, ::2],
        "big-endian": x.astype(">i2"),
        # Negative strides: a reversed copy, read backwards.
        "negative-strides": x[::-1].copy()[::-1],
    }
    assert not variants["strided"].flags["C_CONTIGUOUS"]
    for name, v in variants.items():
        got = ssloc.analyze(v, PRISM, rate).rows.to_pandas()
        assert got.equals(whole), name


@pytest.mark.parametrize("size", [1, 100, 777, 4096, 1 << 16, "random"])
def test_blocks_of_any_size_give_the_rows_of_the_whole(size):
    rate, x = read_wav(EXAMPLE)
    whole = ssloc.analyze(x, PRISM, rate)
    if size == "random":
        rng = np.random.default_rng(3)
        cuts = np.cumsum(rng.integers(1, 5000, size=200))
        blocks = np.split(x, cuts[cuts < len(x)])
    else:
        blocks = [x[i : i + size] for i in range(0, len(x), size)]
    streamed = ssloc.analyze(iter(blocks), PRISM, rate)
    for kind, _ in KINDS:
        assert getattr(streamed, kind).to_pandas().equals(getattr(whole, kind).to_pandas()), kind


def plane_wave(positions, azimuth_deg, elevation_deg, rate, seconds, seed):
    """White noise arriving from a direction after 0.5 s of quiet, delayed per
    microphone in the frequency domain (exact fractional delays), with a little
    independent noise in each channel."""
    rng = np.random.default_rng(seed)
    n = int(rate * seconds)
    s = rng.standard_normal(n)
    s[: rate // 2] = 0.0
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    u = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    # A microphone nearer the source hears it earlier: delay = -(p . u) / c.
    delays = -(np.asarray(positions) @ u) / 343.0
    f = np.fft.rfftfreq(n, 1 / rate)
    spectrum = np.fft.rfft(s)
    out = np.stack(
        [np.fft.irfft(spectrum * np.exp(-2j * np.pi * f * d), n) for d in delays], axis=1
    )
    out += 0.01 * rng.standard_normal(out.shape)
    return 0.1 * out / np.abs(out).max()


def test_a_plane_wave_from_numpy_is_found_where_it_comes_from():
    positions = [[0.1 * np.cos(a), 0.1 * np.sin(a), 0.0] for a in np.arange(8) * np.pi / 4]
    positions += [[0.0, 0.0, 0.1]]
    for azimuth, elevation in [(30.0, 10.0), (-135.0, 25.0), (100.0, -5.0)]:
        x = plane_wave(positions, azimuth, elevation, 16000, 2.0, seed=int(azimuth) % 97)
        result = ssloc.analyze(x, positions, 16000)
        assert result.rows.rows > 20
        az = result.rows["azimuth_deg"]
        el = result.rows["elevation_deg"]
        assert np.median(np.abs((az - azimuth + 180) % 360 - 180)) < 2.0, azimuth
        assert np.median(np.abs(el - elevation)) < 3.0, elevation
        truth = {
            "sources": [
                {"azimuth_deg": azimuth, "elevation_deg": elevation, "intervals": [[0.5, 2.0]]}
            ]
        }
        report = ssloc.evaluate(result, truth)
        assert report["sources"][0]["mean_error_deg"] < 2.0
        assert report["false_detections"] == 0


def test_tables_convert_to_pandas_and_records():
    result = ssloc.analyze(EXAMPLE, PRISM)
    frame = result.rows.to_pandas()
    assert list(frame.columns) == list(result.rows)
    records = result.rows.to_records()
    assert records.shape == (result.rows.rows,)
    np.testing.assert_array_equal(records["azimuth_deg"], result.rows["azimuth_deg"])
    assert result.rows["source"].dtype == np.int64
    assert result.rows["file"].dtype.kind == "U"
    # Untracked: no source, no event; the columns stay.
    untracked = ssloc.analyze(EXAMPLE, PRISM, preset="untracked")
    assert np.isnan(untracked.rows["source"]).all()
    assert untracked.events.rows == 0 and "start_s" in untracked.events


def test_the_result_of_a_json_file_scores_as_the_run(ssl_bin, tmp_path):
    document = cli_json(ssl_bin, EXAMPLE, PRISM)
    path = tmp_path / "example.json"
    path.write_text(json.dumps(document))
    truth = EXAMPLE.with_suffix(".truth.json")
    from_file = ssloc.evaluate(path, truth)
    from_run = ssloc.evaluate(ssloc.analyze(EXAMPLE, PRISM), truth)
    assert from_file["sources"] == from_run["sources"]
    assert from_run["sources"][0]["mean_error_deg"] < 0.1
    from_dict = ssloc.evaluate(path, json.loads(truth.read_text()))
    assert from_dict["sources"] == from_file["sources"]


def test_live_blocks_give_their_records_while_they_come():
    rate, x = read_wav(EXAMPLE)
    seen = []
    heard_before_block = []

    def blocks():
        for i in range(0, len(x), 2400):  # 50 ms at a time, as a sound card gives them
            heard_before_block.append(sum(1 for kind, _ in seen if kind == "row"))
            yield x[i : i + 2400]

    result = ssloc.analyze(blocks(), PRISM, rate, on_record=lambda kind, r: seen.append((kind, r)))
    rows = [r for kind, r in seen if kind == "row"]
    assert len(rows) == result.rows.rows
    assert [r["time_s"] for r in rows] == list(result.rows["time_s"])
    assert sum(1 for kind, _ in seen if kind == "event") == result.events.rows == 3
    # Rows arrived while the blocks still came: the first source's, before the last block.
    assert 0 < heard_before_block[len(heard_before_block) // 2] < len(rows)

    def refuse(kind, record):
        raise KeyError("enough")

    with pytest.raises(KeyError, match="enough"):
        ssloc.analyze(x, PRISM, rate, on_record=refuse)
