"""docs/python.md's worked example runs as written, and the docstrings and
signatures make help() useful."""

import inspect
import re

import ssskit
from conftest import ROOT


def python_blocks():
    text = (ROOT / "docs" / "python.md").read_text()
    return re.findall(r"```python\n(.*?)```", text, re.S)


def test_the_worked_example_runs(tmp_path, monkeypatch):
    # The worked example, then the Dask recipe (python/examples/dask_shards.py,
    # printed by a file: block that tests/docs_files.rs checks and
    # test_shards.py runs).
    blocks = python_blocks()
    assert len(blocks) == 2
    monkeypatch.chdir(tmp_path)
    exec(compile(blocks[0], "docs/python.md", "exec"), {})
    assert (tmp_path / "skin1-preintegrate.json").exists()


def test_help_shows_parameters_and_docs():
    for f, words, params in [
        (ssskit.fit, "Fits a kernel to a profile", ["profile", "model", "taps"]),
        (ssskit.apply, "Applies a kernel to an irradiance array", ["kernel", "irradiance", "mm_per_pixel", "backend"]),
        (ssskit.simulate, "Monte Carlo reflectance profile", ["material", "photons", "seed", "threads"]),
    ]:
        assert words in f.__doc__
        assert all(p in inspect.signature(f).parameters for p in params)
