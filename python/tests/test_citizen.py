"""A good citizen in Python: the GIL is released during long calls, Ctrl-C
stops them with KeyboardInterrupt, and bad input raises ValueError or
TypeError with the library's message, never a crash."""

import os
import signal
import threading
import time

import numpy as np
import pytest

import ssskit

# The longest pause another Python thread may see while a call runs: a
# thread that gets the GIL (and one of 2 busy cores) runs every few
# milliseconds; one that never gets it pauses for the whole call, which
# lasts at least twice this (checked).
MAX_PAUSE_S = 0.25
# The calls watched: about 3 s each on 2 busy cores (1e6 photons take
# 1.8 s), well above twice MAX_PAUSE_S even on a machine a few times
# faster. The filter is 4K at 0.15 mm a pixel, rank 2, full factors: since
# it filters in place, 1080p took only 0.46 s on an idle 2-core machine,
# under twice MAX_PAUSE_S; 4K is four times that.
GIL_PHOTONS = 1_500_000
GIL_MM_PER_PIXEL = 0.15
GIL_IMAGE_SHAPE = (2160, 3840, 3)
# Photons of the run that Ctrl-C stops: about 18 s of tracing on 2 busy
# cores (1e6 take 1.8 s), several times the deadline below on a machine
# many times faster, so stopping in time is distinguishable from finishing.
INTERRUPTED_PHOTONS = 10_000_000
# When the SIGINT is sent, and by when the call must have raised: the
# Monte Carlo rounds look at the cancel flag before every chunk (a few
# milliseconds of work) and the binding polls for signals every 50 ms.
INTERRUPT_AFTER_S = 0.3
INTERRUPT_DEADLINE_S = 1.5


def longest_pause_during(call):
    """The longest time another Python thread went without running while
    `call` ran, and how long the call took."""
    stamps = []
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            stamps.append(time.perf_counter())
            time.sleep(0)

    t = threading.Thread(target=spin)
    t.start()
    time.sleep(0.05)
    try:
        t0 = time.perf_counter()
        call()
        t1 = time.perf_counter()
    finally:
        stop.set()
        t.join()
    inside = [s for s in stamps if t0 <= s <= t1]
    gaps = np.diff([t0, *inside, t1])
    return gaps.max(), t1 - t0


def test_simulate_releases_the_gil():
    pause, took = longest_pause_during(lambda: ssskit.simulate("skin1", photons=GIL_PHOTONS, seed=1))
    assert took > 2 * MAX_PAUSE_S and pause < MAX_PAUSE_S


def test_apply_releases_the_gil():
    k = ssskit.fit(ssskit.profile("skin1", "pbd"), "svd", rank=2)
    img = np.ones(GIL_IMAGE_SHAPE, np.float32)
    # The full factors: a call long enough to watch (the tap table is faster).
    pause, took = longest_pause_during(
        lambda: ssskit.apply(k, img, mm_per_pixel=GIL_MM_PER_PIXEL, full_factors=True))
    assert took > 2 * MAX_PAUSE_S and pause < MAX_PAUSE_S


def test_ctrl_c_stops_simulate_with_keyboard_interrupt():
    timer = threading.Timer(INTERRUPT_AFTER_S, os.kill, (os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            ssskit.simulate("skin1", photons=INTERRUPTED_PHOTONS, seed=1)
    finally:
        timer.cancel()
    assert time.monotonic() - start < INTERRUPT_DEADLINE_S
    # The interpreter and the library are fine afterwards.
    assert ssskit.simulate("skin1", photons=1000, seed=1).rd.shape[0] == 3


@pytest.fixture(scope="module")
def kernel():
    return ssskit.fit(ssskit.profile("skin1", "pbd"), "preintegrate")


IMG = np.ones((16, 16, 3), np.float32)


@pytest.mark.parametrize(
    "image, error, message",
    [
        (np.ones((16, 16), np.float32), ValueError, r"shape \(H, W, 3\) or \(H, W, 4\), got shape \[16, 16\]"),
        (np.ones((16, 16, 5), np.float32), ValueError, r"got shape \[16, 16, 5\]"),
        (np.ones((16, 16, 2), np.float32), ValueError, r"got shape \[16, 16, 2\]"),
        (np.ones((16, 32, 3), np.float32)[:, ::2], ValueError, "not C-contiguous"),
        (np.ones((3, 16, 16), np.float32).transpose(1, 2, 0), ValueError, "not C-contiguous"),
        (np.ones((16, 16, 3), np.int32), TypeError, "float32 or float64 samples, got int32"),
        ([[[1.0, 1.0, 1.0]]], TypeError, "expected a numpy array"),
        (np.ones((0, 16, 3), np.float32), ValueError, "irradiance"),
    ],
)
def test_bad_arrays(kernel, image, error, message):
    with pytest.raises(error, match=message):
        ssskit.apply(kernel, image, mm_per_pixel=0.1)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_pixels(kernel, bad):
    img = IMG.copy()
    img[3, 5, 2] = bad
    with pytest.raises(ValueError, match=r"irradiance: 1 NaN/Inf samples, the first at pixel \(5, 3\) channel B"):
        ssskit.apply(kernel, img, mm_per_pixel=0.1)


def test_read_only_input_is_read_in_place(kernel):
    img = IMG.copy()
    img.flags.writeable = False
    out = ssskit.apply(kernel, img, mm_per_pixel=0.1)
    assert out.flags.writeable and out.flags.c_contiguous


@pytest.mark.parametrize("scale", [-1.0, 0.0, float("nan")])
def test_bad_scale(kernel, scale):
    with pytest.raises(ValueError, match="kernel scale: invalid mm_per_pixel"):
        ssskit.apply(kernel, IMG, mm_per_pixel=scale)


def test_other_bad_arguments(kernel):
    profile = ssskit.profile("skin1", "pbd")
    with pytest.raises(ValueError, match="model: invalid value 'nope'"):
        ssskit.fit(profile, "nope")
    with pytest.raises(TypeError, match="unexpected keyword argument 'ranks'"):
        ssskit.fit(profile, "svd", ranks=2)
    with pytest.raises(ValueError, match="give exactly one of preset"):
        ssskit.fit(profile, "manual")
    with pytest.raises(ValueError, match="unknown material preset"):
        ssskit.material("unobtainium")
    with pytest.raises(ValueError, match="analytic profile: invalid model = nope"):
        ssskit.profile("skin1", "nope")
    with pytest.raises(ValueError, match="backend: invalid value 'tpu'"):
        ssskit.apply(kernel, IMG, 0.1, backend="tpu")
    with pytest.raises(ValueError, match="give exactly one of mm_per_pixel and fov_y"):
        ssskit.apply(kernel, IMG)
    with pytest.raises(ValueError, match="emit: invalid language"):
        kernel.emit("cuda")
    with pytest.raises(ValueError, match="at most one of photons, mc_error and kernel_error"):
        ssskit.simulate("skin1", photons=100, mc_error=0.1)
    with pytest.raises(ValueError, match="sigma_a"):
        ssskit.Material([-1.0, 1.0, 1.0], 1.0, 0.0, 1.3)
    with pytest.raises(ValueError, match="sigma_s: expected three values"):
        ssskit.Material(0.1, [1.0, 1.0], 0.0, 1.3)


def test_load_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        ssskit.load(tmp_path / "missing.json")
    (tmp_path / "x.json").write_text('{"schema": "other/1"}')
    with pytest.raises(ValueError, match="schema 'other/1' is not one ssskit.load reads"):
        ssskit.load(tmp_path / "x.json")
    (tmp_path / "y.json").write_text("{not json")
    with pytest.raises(ValueError):
        ssskit.load(tmp_path / "y.json")
