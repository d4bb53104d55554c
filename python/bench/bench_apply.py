"""Filters a 1920x1080 float32 array three ways in one run and prints the
times: ssskit.apply from Python, the same filter through the CLI binary
(EXR in and out, as a Python user shelling out would), and, when scipy is
installed, scipy.ndimage.convolve1d with the kernel's factor at pixel
resolution (the library a Python user would otherwise reach for).

    target/pyenv/bin/python python/bench/bench_apply.py [--repeats N]
"""

import argparse
import os
import re
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import ssskit

ROOT = Path(__file__).resolve().parents[2]
# 1080p, the size of the benchmark.
WIDTH, HEIGHT = 1920, 1080
# skin1's pbd kernel spans about +-21 mm: at 0.25 mm a pixel, 1D factors of
# about 170 pixels, the cost class of a real-time blur at close range.
MM_PER_PIXEL = 0.25


def timed(f, repeats):
    """The median of `repeats` wall-clock times of f(), and its last result."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cli", default=os.environ.get("SSSKIT_BIN", ROOT / "target/release/ssskit"))
    a = ap.parse_args()
    kernel = ssskit.fit(ssskit.profile("skin1", "pbd"), "preintegrate", taps=17)
    img = np.random.default_rng(1).random((HEIGHT, WIDTH, 3)).astype(np.float32)
    rows = []

    py_s, mine = timed(lambda: ssskit.apply(kernel, img, mm_per_pixel=MM_PER_PIXEL), a.repeats)
    rows.append(("ssskit.apply (Python)", py_s))

    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        kernel.save(d / "k.json")
        ssskit.write_image(d / "in.exr", img)
        cmd = [str(a.cli), "apply", "--kernel", d / "k.json", "--input", d / "in.exr", "--out", d / "out.exr",
               "--mm-per-pixel", str(MM_PER_PIXEL), "--backend", "cpu"]
        last = {}

        def run_cli():
            last["stderr"] = subprocess.run(cmd, check=True, capture_output=True, text=True).stderr

        cli_s, _ = timed(run_cli, a.repeats)
        same = mine.tobytes() == ssskit.read_image(d / "out.exr").tobytes()
        inner = re.search(r"taps, ([0-9.]+) s ->", last["stderr"])
    rows.append(("ssskit apply (CLI, EXR in and out)", cli_s))
    if inner:
        rows.append(("  of which the CLI's filter and EXR write", float(inner.group(1))))

    try:
        from scipy.ndimage import convolve1d
    except ImportError:
        convolve1d = None
    if convolve1d is not None:
        p = kernel.passes[0]
        half = int(np.ceil(p["offsets_mm"].max() / MM_PER_PIXEL))
        px = np.arange(-half, half + 1) * MM_PER_PIXEL
        weights = [np.interp(px, p["offsets_mm"], p["weights"][:, c]) for c in range(3)]
        weights = [w * p["weights"][:, c].sum() / w.sum() for c, w in enumerate(weights)]

        def scipy_filter():
            out = np.empty_like(img)
            for c in range(3):
                h = convolve1d(img[..., c], weights[c].astype(np.float32), axis=1, mode="nearest")
                out[..., c] = convolve1d(h, weights[c].astype(np.float32), axis=0, mode="nearest")
            return out

        sc_s, _ = timed(scipy_filter, a.repeats)
        rows.append((f"scipy.ndimage.convolve1d ({2 * half + 1}-pixel factor)", sc_s))

    print(f"1D factors of skin1 (pbd, preintegrate) at {MM_PER_PIXEL} mm/px on {WIDTH}x{HEIGHT}x3 float32, "
          f"median of {a.repeats}; {os.cpu_count()} CPUs")
    for name, s in rows:
        print(f"{name:<52} {s:8.3f} s  {s / cli_s:6.2f} x CLI")
    print(f"Python result equals the CLI's bit for bit: {same}")
    print(f"Python time relative to the CLI's: {100 * (py_s - cli_s) / cli_s:+.1f}%")


if __name__ == "__main__":
    main()
