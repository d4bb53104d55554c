"""Shared fixtures and helpers: the CLI binary the package is compared
with, and JSON without its timings."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli():
    """Runs the release binary (SSSKIT_BIN, else target/release/ssskit)."""
    exe = Path(os.environ.get("SSSKIT_BIN", ROOT / "target" / "release" / "ssskit"))
    if not exe.exists():
        pytest.fail(f"{exe} is missing: build it with cargo build --release")

    def run(*args, cwd=None):
        done = subprocess.run(
            [str(exe), *map(str, args)], capture_output=True, text=True, cwd=cwd
        )
        if done.returncode != 0:
            raise AssertionError(f"ssskit {' '.join(map(str, args))}: {done.stderr}")
        return done.stdout

    return run


# Keys of the library's JSON that hold wall-clock measurements, the only
# ones allowed to differ between two runs of the same computation.
TIMING_KEYS = {"fit_seconds", "ms_per_megapixel", "elapsed_s"}


def untimed(value):
    """A JSON value without its wall-clock fields (keys in TIMING_KEYS)."""
    if isinstance(value, dict):
        return {k: untimed(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [untimed(v) for v in value]
    return value
