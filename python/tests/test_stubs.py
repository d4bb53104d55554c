"""The stubs and the docs cover the module: mypy's stubtest compares
python/ssskit/_native.pyi (and the package) with the compiled module,
and docs/python.md's table names every public function and class."""

import os
import re
import subprocess
import sys

import ssskit
from conftest import ROOT

# mypy's first run parses numpy's stubs: well under a minute even on a
# loaded 2-core machine; the bound only stops a hang.
STUBTEST_TIMEOUT_S = 600


def test_stubs_match_the_module(tmp_path):
    """stubtest fails on a public name without a stub, a stub without a
    runtime name, and a signature (parameters, kinds, defaults) that
    differs; its cache goes to the test's own folder."""
    env = dict(os.environ, MYPY_CACHE_DIR=str(tmp_path / "cache"))
    done = subprocess.run([sys.executable, "-m", "mypy.stubtest", "ssskit"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=STUBTEST_TIMEOUT_S)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "Success" in done.stdout


def test_the_docs_name_every_public_name():
    text = (ROOT / "docs" / "python.md").read_text()
    table = text[text.index("## What there is"):text.index("## The same numbers as the CLI")]
    missing = [n for n in ssskit.__all__ if not re.search(rf"\b{re.escape(n)}\b", table)]
    assert not missing, f"docs/python.md's table lacks {missing}"
    # Every name the extension exports is in the package's __all__.
    assert set(ssskit._native.__all__) - {"__version__"} <= set(ssskit.__all__)
