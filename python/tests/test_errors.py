"""Bad input is an exception with the command line's message, never a crash or NaN."""

import numpy as np
import pytest

import ssloc

from conftest import EXAMPLE, PRISM, read_wav


def samples():
    return read_wav(EXAMPLE)


def test_files_that_cannot_be_read_are_os_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="missing.wav"):
        ssloc.analyze(tmp_path / "missing.wav", PRISM)
    with pytest.raises(FileNotFoundError, match="nowhere.toml"):
        ssloc.Localizer(tmp_path / "nowhere.toml")
    with pytest.raises(OSError):
        ssloc.analyze(tmp_path, PRISM)


def test_bad_files_are_value_errors_naming_the_file(tmp_path):
    corrupt = tmp_path / "corrupt.wav"
    corrupt.write_bytes(b"RIFF\x10\x00\x00\x00WAVEjunkjunkjunk")
    with pytest.raises(ValueError, match="corrupt.wav"):
        ssloc.analyze(corrupt, PRISM)
    text = tmp_path / "text.wav"
    text.write_text("not audio at all\n")
    with pytest.raises(ValueError, match="text.wav"):
        ssloc.analyze(text, PRISM)


def test_bad_geometries_are_value_errors(tmp_path):
    with pytest.raises(ValueError, match="geometry"):
        ssloc.Localizer([[0, 0, 0], [0, 0, 0], [0, 0, 0]])
    with pytest.raises(ValueError, match="geometry"):
        ssloc.Localizer([[0, 0, 0]])
    with pytest.raises(ValueError, match=r"\(M, 3\)"):
        ssloc.Localizer(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="geometry: invalid length 2, expected an array of 3 numbers"):
        ssloc.Localizer({"mic": [{"position": [0, 0]}]})
    bad = tmp_path / "bad.toml"
    bad.write_text("[[mic]]\nposition = [0, 0, 0]\n[[mic]]\nposition = [nan, 0, 0]\n")
    with pytest.raises(ValueError, match="bad.toml"):
        ssloc.Localizer(bad)
    with pytest.raises(TypeError, match="geometry"):
        ssloc.Localizer(42)


def test_a_geometry_dict_is_the_file_read_the_same():
    import tomllib

    form = tomllib.loads(PRISM.read_text())
    rate, x = samples()
    a = ssloc.analyze(x, form, rate).rows.to_pandas()
    b = ssloc.analyze(x, PRISM, rate).rows.to_pandas()
    assert a.drop(columns="file").equals(b.drop(columns="file"))


def test_bad_options_are_value_errors_with_the_flags_message():
    with pytest.raises(ValueError, match="unexpected argument 'false_per_houre' found tip: a similar argument exists: 'false_per_hour'"):
        ssloc.Localizer(PRISM, false_per_houre=3)
    with pytest.raises(ValueError, match="is not a number"):
        ssloc.Localizer(PRISM, false_per_hour="many")
    with pytest.raises(ValueError, match="possible values: hann"):
        ssloc.Localizer(PRISM, window="blackman")
    with pytest.raises(ValueError, match="cannot be used with 'min_score'"):
        ssloc.Localizer(PRISM, paper=True, min_score=0.2)
    with pytest.raises(ValueError, match="True or False"):
        ssloc.Localizer(PRISM, paper="yes")
    with pytest.raises(ValueError, match="preset `fast`"):
        ssloc.Localizer(PRISM, preset="fast")
    # A value the parser takes but the method cannot run with.
    with pytest.raises(ValueError, match="peaks"):
        ssloc.Localizer(PRISM, peaks=0)


def test_bad_samples_are_errors_naming_what_is_wrong():
    rate, x = samples()
    with pytest.raises(ValueError, match="8 microphones"):
        ssloc.analyze(x[:, :5], PRISM, rate)
    nan = x.astype(np.float32) / 32768
    nan[5000, 3] = np.nan
    with pytest.raises(ValueError, match="sample 5000 of channel 3 is NaN"):
        ssloc.analyze(nan, PRISM, rate)
    with pytest.raises(ValueError, match="sample 5000 of channel 3 is NaN"):
        ssloc.analyze(iter([nan[:4000], nan[4000:]]), PRISM, rate)
    with pytest.raises(ValueError, match="shorter than one|less than one|too short"):
        ssloc.analyze(x[:100], PRISM, rate)
    with pytest.raises(TypeError, match="int16, int32, float32 or float64"):
        ssloc.analyze(x.astype(np.int64), PRISM, rate)
    with pytest.raises(ValueError, match="2-D"):
        ssloc.analyze(x[:, 0], PRISM, rate)
    with pytest.raises(ValueError, match="sample_rate"):
        ssloc.analyze(x, PRISM)
    with pytest.raises(ValueError, match="sample_rate"):
        ssloc.analyze(EXAMPLE, PRISM, 48000)
    with pytest.raises(ValueError, match="channel"):
        ssloc.analyze(iter([x[:4000], x[4000:, :7]]), PRISM, rate)
    with pytest.raises(ValueError, match="no block"):
        ssloc.analyze(iter([]), PRISM, rate)


def test_digital_silence_gives_no_row_and_says_so():
    rate, x = samples()
    result = ssloc.analyze(np.zeros_like(x), PRISM, rate)
    assert result.rows.rows == 0
    assert any("silen" in w for w in result.warnings), result.warnings


def test_an_exception_in_the_blocks_is_raised_as_it_was():
    rate, x = samples()

    def blocks():
        yield x[:10000]
        raise RuntimeError("the microphone was unplugged")

    with pytest.raises(RuntimeError, match="unplugged"):
        ssloc.analyze(blocks(), PRISM, rate)


def test_warnings_are_python_warnings():
    rate, x = samples()
    with pytest.warns(ssloc.SslWarning, match="silen"):
        ssloc.analyze(np.zeros_like(x), PRISM, rate)
