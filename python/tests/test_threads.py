"""Several analyses at once from Python threads; the GIL released meanwhile; Ctrl-C."""

import signal
import subprocess
import sys
import threading
import time

import numpy as np

import ssloc

from conftest import EXAMPLE, PRISM, ROOT, read_wav


def test_threads_at_once_give_what_each_gives_alone():
    rate, x = read_wav(EXAMPLE)
    localizer = ssloc.Localizer(PRISM)
    inputs = [x, x[::-1].copy(), np.roll(x, 5000, axis=0), x.astype(np.float32) / 32768]
    alone = [localizer.analyze(v, rate).rows.to_pandas() for v in inputs]
    together = [None] * (2 * len(inputs))

    def work(i):
        together[i] = localizer.analyze(inputs[i % len(inputs)], rate).rows.to_pandas()

    threads = [threading.Thread(target=work, args=(i,)) for i in range(len(together))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for i, got in enumerate(together):
        assert got.equals(alone[i % len(inputs)]), i


def test_the_gil_is_released_while_analysing():
    rate, x = read_wav(EXAMPLE)
    # 80 s of three sources turning on and off.
    x = np.tile(x, (40, 1))
    localizer = ssloc.Localizer(PRISM)
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    counter = threading.Thread(target=count)
    counter.start()
    start = time.perf_counter()
    localizer.analyze(x, rate)
    took = time.perf_counter() - start
    done.set()
    counter.join()
    during = [t for t in ticks if start <= t <= start + took]
    # Held, the GIL would let the counter tick only at the switch interval's slices
    # after the call; released, it ticks about every millisecond of the analysis.
    assert took > 0.2, took
    assert len(during) > 0.3 * took / 0.001, (len(during), took)


def test_ctrl_c_stops_an_analysis_with_keyboard_interrupt():
    script = f"""
import signal, sys, time, numpy as np, ssloc
# A shell that starts this suite in the background (`bash .ci/run &`) starts it with
# SIGINT ignored, and Python then keeps it ignored: give it back its Ctrl-C.
signal.signal(signal.SIGINT, signal.default_int_handler)
sys.path.insert(0, {str(ROOT / 'python' / 'tests')!r})
from conftest import EXAMPLE, read_wav
rate, x = read_wav(EXAMPLE)
x = np.tile(x, (60, 1))  # 120 s with WPE: about 8 s of work on two cores
print("ready", flush=True)
start = time.perf_counter()
try:
    ssloc.analyze(x, {str(PRISM)!r}, rate, wpe=True)
    print("finished", flush=True)
except KeyboardInterrupt:
    print("interrupted after", round(time.perf_counter() - start, 2), flush=True)
"""
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    time.sleep(1.0)
    sent = time.perf_counter()
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=60)
    assert out.startswith("interrupted after"), out
    assert time.perf_counter() - sent < 2.0
