"""A room simulated by pyroomacoustics (independently of ssl): two talkers in turn, the
directions, events and scores against the truth; the walk-through of docs/python.md.
Skipped where pyroomacoustics does not install (CI installs it)."""

import numpy as np
import pytest
from scipy.io import wavfile

import ssloc

from conftest import TESTDATA

pra = pytest.importorskip("pyroomacoustics")

RATE = 16000


def speech(name):
    rate, x = wavfile.read(TESTDATA / "speech" / name)
    assert rate == RATE
    return x.astype(np.float64) / 32768


def room_scene(seed=0):
    """A 6 x 5 x 3 m room of RT60 0.4 s, the prism 1.2 m up near its middle, two
    talkers in turn at 1.6 and 2.2 m; returns (signals: samples x 8, positions, truth)."""
    rng = np.random.default_rng(seed)
    absorption, order = pra.inverse_sabine(0.4, [6.0, 5.0, 3.0])
    room = pra.ShoeBox(
        [6.0, 5.0, 3.0], fs=RATE, materials=pra.Material(absorption), max_order=order
    )
    centre = np.array([3.0, 2.4, 1.2])
    prism = np.array(
        [[sx * 0.25, sy * 0.2, sz * 0.18] for sz in (1, -1) for sx, sy in
         ((1, 1), (1, -1), (-1, -1), (-1, 1))]
    )
    room.add_microphone_array((centre + prism).T)
    truth = {"sources": []}
    for name, azimuth, elevation, distance, start in [
        ("cmu_arctic_us_aew_a0001.wav", 50.0, 5.0, 1.6, 0.3),
        ("cmu_arctic_us_axb_a0004.wav", -100.0, 15.0, 2.2, 4.6),
    ]:
        az, el = np.radians(azimuth), np.radians(elevation)
        u = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        signal = speech(name)
        room.add_source(centre + distance * u, signal=signal, delay=start)
        truth["sources"].append(
            {
                "azimuth_deg": azimuth,
                "elevation_deg": elevation,
                "intervals": [[start, start + len(signal) / RATE]],
            }
        )
    room.simulate()
    x = room.mic_array.signals.T
    x = x / np.abs(x).max() * 0.5
    x += 0.002 * rng.standard_normal(x.shape)
    return x, prism, truth


def test_a_room_of_pyroomacoustics_two_talkers_in_turn():
    x, positions, truth = room_scene()
    result = ssloc.analyze(x, positions, RATE)
    report = ssloc.evaluate(result, truth)
    for source in report["sources"]:
        assert source["mean_error_deg"] < 2.0, source
        assert source["events_detected"] == 1, source
    events = result.events
    assert events.rows == 2, events.to_pandas()
    # The events start and end about when the talkers do, in the order they spoke.
    starts = events["start_s"]
    assert abs(starts[0] - 0.3) < 0.4 and abs(starts[1] - 4.6) < 0.4, starts
    assert report["tracking"]["false_events"] == 0
    assert report["false_detections"] == 0
    # As float32 and as int16 (the WAV a recorder writes) the same talkers.
    as_int16 = (x * 32767).astype(np.int16)
    again = ssloc.evaluate(ssloc.analyze(as_int16, positions, RATE), truth)
    for source in again["sources"]:
        assert source["mean_error_deg"] < 3.0, source


def test_every_frame_places_more_frames_than_a_steered_response_per_frame():
    """``preset="every_frame"`` (``--every-frame``): a row for every frame; within the
    talkers' words it is right more often than pyroomacoustics' own SRP-PHAT on each
    frame alone (the habit it stands in for), and its cones hold the truth."""
    x, positions, truth = room_scene(seed=1)
    result = ssloc.analyze(x, positions, RATE, preset="every_frame")
    rows = result.rows
    frames = rows["frame"]
    assert np.array_equal(frames, np.arange(len(frames))), "one row a frame"
    n = result.file["frame_size"]
    hop = n // 2
    units = [
        np.array([np.cos(np.radians(s["elevation_deg"])) * np.cos(np.radians(s["azimuth_deg"])),
                  np.cos(np.radians(s["elevation_deg"])) * np.sin(np.radians(s["azimuth_deg"])),
                  np.sin(np.radians(s["elevation_deg"]))])
        for s in truth["sources"]
    ]
    azimuth = np.radians(np.arange(-180, 180, 4.0))
    colatitude = np.radians(np.arange(0, 181, 6.0))
    srp = pra.doa.algorithms["SRP"](positions.T, RATE, n, c=343.0, num_src=1,
                                    azimuth=azimuth, colatitude=colatitude, dim=3)
    window = np.hanning(n)
    ours, theirs, inside = [], [], []
    # Every third frame inside a talker's interval (the SRP over the grid is slow).
    for i in range(0, len(frames), 3):
        t = rows["time_s"][i]
        talking = [u for u, s in zip(units, truth["sources"])
                   if s["intervals"][0][0] <= t <= s["intervals"][0][1]]
        if not talking:
            continue
        u = talking[0]
        v = np.array([rows["x"][i], rows["y"][i], rows["z"][i]])
        error = np.degrees(np.arccos(np.clip(u @ v, -1, 1)))
        ours.append(error)
        inside.append(error <= rows["uncertainty_deg"][i])
        spectrum = np.fft.rfft(x[i * hop:i * hop + n].T * window, axis=1)[:, :, None]
        srp.locate_sources(spectrum, freq_range=[100, 7000])
        a, c = srp.azimuth_recon[0], srp.colatitude_recon[0]
        w = np.array([np.cos(a) * np.sin(c), np.sin(a) * np.sin(c), np.cos(c)])
        theirs.append(np.degrees(np.arccos(np.clip(u @ w, -1, 1))))
    ours, theirs = np.array(ours), np.array(theirs)
    print(f"{len(ours)} frames: within 10 deg {np.mean(ours <= 10):.0%} (SRP-PHAT per frame "
          f"{np.mean(theirs <= 10):.0%}); inside the cone {np.mean(inside):.0%}")
    assert len(ours) > 100
    assert np.mean(ours <= 10) > np.mean(theirs <= 10)
    assert np.mean(inside) >= 0.93
