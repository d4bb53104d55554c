"""Arguments as the CLI's flags take them: a bool is not a number, reals
are finite, counts are whole, the scene scale is positive, and every
refusal names the keyword; apply's options as one reusable object."""

import inspect

import numpy as np
import pytest

import ssskit

IMG = np.ones((16, 16, 3), np.float32)
# apply's keywords beside the kernel, the image, options and out: the
# flags of `ssskit apply` that the binding takes (mm_per_pixel is also
# its third positional argument).
APPLY_KEYWORDS = 20
# The GPU pass against the CPU one, relative to the peak (docs/filter.md).
GPU_TOLERANCE = 1e-4


@pytest.fixture(scope="module")
def profile():
    return ssskit.profile("skin1", "pbd")


@pytest.fixture(scope="module")
def kernel(profile):
    return ssskit.fit(profile, "preintegrate")


@pytest.mark.parametrize(
    "call, error, message",
    [
        # Booleans are refused where a number is meant (True is no 1.0 mm).
        (lambda k, p: ssskit.apply(k, IMG, mm_per_pixel=True), TypeError, "mm_per_pixel: expected a number, got a bool"),
        (lambda k, p: ssskit.apply(k, IMG, True), TypeError, "mm_per_pixel: expected a number, got a bool"),
        (lambda k, p: ssskit.apply(k, IMG, 0.1, frames=True), TypeError, "frames: expected a whole number, got a bool"),
        (lambda k, p: ssskit.fit(p, taps=True), TypeError, "taps: expected a whole number, got a bool"),
        (lambda k, p: ssskit.fit(p, "svd", rank=np.bool_(True)), TypeError, "rank: expected a whole number, got a bool"),
        (lambda k, p: ssskit.simulate("skin1", photons=False), TypeError, "photons: expected a whole number, got a bool"),
        (lambda k, p: ssskit.Material(0.1, 1.0, 0.0, True), TypeError, "eta: expected a number, got a bool"),
        (lambda k, p: ssskit.Material([0.1, True, 0.1], 1.0, 0.0, 1.3), TypeError, "sigma_a: expected a number, got a bool"),
        (lambda k, p: ssskit.advise(p, True), TypeError, "mm_per_pixel: expected a number, got a bool"),
        # Integer conversions name the keyword (no bare OverflowError).
        (lambda k, p: ssskit.apply(k, IMG, 0.1, frames=-1), ValueError, "frames: invalid value -1: expected a whole number"),
        (lambda k, p: ssskit.apply(k, IMG, 0.1, frames=2**40), ValueError, "frames: invalid value 1099511627776: too large"),
        (lambda k, p: ssskit.fit(p, taps=-17), ValueError, "taps: invalid value -17"),
        (lambda k, p: ssskit.simulate("skin1", seed=-1), ValueError, "seed: invalid value -1"),
        (lambda k, p: ssskit.simulate("skin1", photons=1.5), ValueError, "photons: invalid value 1.5"),
        (lambda k, p: ssskit.fit(p, taps="17"), TypeError, "taps: expected a whole number, got str"),
        # Reals are finite, as every real-valued flag of the CLI.
        (lambda k, p: ssskit.apply(k, IMG, float("inf")), ValueError, "mm_per_pixel: invalid value inf: must be a finite number"),
        (lambda k, p: ssskit.fit(p, extent=float("nan")), ValueError, "extent: invalid value NaN: must be a finite number"),
        # The scene scale: finite and > 0 (the library's check), and only with fov_y.
        (lambda k, p: ssskit.apply(k, IMG, fov_y=30.0, units_per_mm=float("nan")), ValueError, "units_per_mm: invalid value NaN"),
        (lambda k, p: ssskit.apply(k, IMG, fov_y=30.0, units_per_mm=0.0), ValueError, "invalid units_per_mm = 0: must be finite and > 0"),
        (lambda k, p: ssskit.apply(k, IMG, fov_y=30.0, units_per_mm=-1), ValueError, "invalid units_per_mm = -1: must be finite and > 0"),
        (lambda k, p: ssskit.apply(k, IMG, 0.1, units_per_mm=0.001), ValueError, "units_per_mm: the perspective scale's"),
        (lambda k, p: ssskit.engine_params(p, "unreal", units_per_mm=0), ValueError, "units per mm = 0: must be finite and > 0"),
        (lambda k, p: ssskit.engine_params(p, "unreal", units_per_mm=float("nan")), ValueError, "units_per_mm: invalid value NaN"),
        (lambda k, p: ssskit.engine_params(p, "unreal", units_per_mm=True), TypeError, "units_per_mm: expected a number, got a bool"),
    ],
)
def test_numbers_as_the_cli_takes_them(kernel, profile, call, error, message):
    with pytest.raises(error, match=message):
        call(kernel, profile)


def test_counts_take_exponent_notation_as_the_cli_does():
    # `--photons 2e3` on the command line; 2e3 is a float in Python.
    a = ssskit.simulate("skin1", photons=2e3, seed=1)
    b = ssskit.simulate("skin1", photons=2000, seed=1)
    assert np.array_equal(a.rd, b.rd)
    assert np.array_equal(a.rd, ssskit.simulate("skin1", photons=np.int64(2000), seed=1).rd)


def test_options_are_one_reusable_object(kernel):
    """ApplyOptions holds the keywords; apply with it equals apply with the
    keywords; keywords beside it replace its values; every keyword apply
    shows is one ApplyOptions takes, and an unknown one is refused."""
    img = np.random.default_rng(2).random((24, 32, 3)).astype(np.float32)
    opts = ssskit.ApplyOptions(mm_per_pixel=0.1, precision="f64", full_factors=True)
    assert repr(opts) == "ssskit.ApplyOptions(mm_per_pixel=0.1, precision='f64', full_factors=True)"
    by_keywords = ssskit.apply(kernel, img, mm_per_pixel=0.1, precision="f64", full_factors=True)
    assert np.array_equal(ssskit.apply(kernel, img, options=opts), by_keywords)
    # A keyword beside the options replaces its value; the positional scale too.
    assert np.array_equal(
        ssskit.apply(kernel, img, options=opts, full_factors=False),
        ssskit.apply(kernel, img, mm_per_pixel=0.1, precision="f64"),
    )
    assert np.array_equal(ssskit.apply(kernel, img, 0.2, options=opts),
                          ssskit.apply(kernel, img, 0.2, precision="f64", full_factors=True))
    assert np.array_equal(ssskit.apply(kernel, img, options=opts.replace(full_factors=False)),
                          ssskit.apply(kernel, img, mm_per_pixel=0.1, precision="f64"))
    shown = {n: p.default for n, p in inspect.signature(ssskit.apply).parameters.items()
             if n not in ("kernel", "irradiance", "options", "out")}
    assert len(shown) == APPLY_KEYWORDS
    for name, default in shown.items():
        assert repr(ssskit.ApplyOptions(**{name: default})) == f"ssskit.ApplyOptions({name}={default!r})"
    with pytest.raises(TypeError, match="unexpected keyword argument 'radius'"):
        ssskit.ApplyOptions(radius=3)
    with pytest.raises(TypeError, match="unexpected keyword argument 'radius'"):
        ssskit.apply(kernel, img, 0.1, radius=3)
    with pytest.raises(ValueError, match="precision: invalid value 'f16'"):
        ssskit.ApplyOptions(precision="f16")


def test_out_receives_the_result_or_filters_in_place(kernel):
    img = np.random.default_rng(4).random((20, 24, 4)).astype(np.float32)
    want = ssskit.apply(kernel, img, 0.1)
    out = np.empty_like(img)
    assert ssskit.apply(kernel, img, 0.1, out=out) is out and np.array_equal(out, want)
    # The general path (f64) into out, and in place.
    want64 = ssskit.apply(kernel, img, 0.1, precision="f64")
    out64 = np.empty_like(img)
    ssskit.apply(kernel, img, 0.1, precision="f64", out=out64)
    assert np.array_equal(out64, want64)
    same = img.copy()
    assert ssskit.apply(kernel, same, 0.1, out=same) is same and np.array_equal(same, want)
    with pytest.raises(ValueError, match="out: expected a C-contiguous array of shape"):
        ssskit.apply(kernel, img, 0.1, out=np.empty((20, 24, 4), np.float64))
    with pytest.raises(ValueError, match="out: expected a C-contiguous array of shape"):
        ssskit.apply(kernel, img, 0.1, out=np.empty((20, 24, 3), np.float32))


def test_auto_backend_is_the_clis_rule(kernel):
    """backend="auto" runs on a hardware GPU, else the CPU: under the
    software rasteriser the tests run on, the CPU's bits; on a GPU, within
    the GPU tolerance of the CPU."""
    img = np.random.default_rng(6).random((16, 24, 3)).astype(np.float32)
    cpu = ssskit.apply(kernel, img, 0.1, backend="cpu")
    auto = ssskit.apply(kernel, img, 0.1, backend="auto")
    assert np.abs(auto - cpu).max() <= GPU_TOLERANCE * np.abs(cpu).max()
    with pytest.raises(ValueError, match="backend: invalid value 'tpu': expected cpu, gpu or auto"):
        ssskit.apply(kernel, img, 0.1, backend="tpu")
