"""Shared fixtures: the CLI binary the package is compared with."""

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
