"""Shards from Python: `simulate(shard=(k, n))` and `merge` give the CLI's
parts and merge, and the shards mapped over a Dask cluster of worker
processes (docs/python.md's recipe) merge to the single run bit for bit."""

import importlib.util
import json
import pickle

import pytest

import ssskit

from conftest import ROOT, untimed

# A run small enough for a test: skin1, 60,000 photons per channel (8 chunks
# of 8192), in 3 shards.
RUN = dict(photons=60000, seed=5)
SHARDS = 3


def shard(k, n):
    return ssskit.simulate("skin1", shard=(k, n), threads=1, **RUN)


@pytest.fixture(scope="module")
def single():
    return ssskit.simulate("skin1", **RUN)


def test_shards_and_merge_equal_the_cli(cli, tmp_path, single):
    parts = [shard(k, SHARDS) for k in range(1, SHARDS + 1)]
    for k, part in enumerate(parts, start=1):
        cli("simulate", "--material", "skin1", "--photons", "60000", "--seed", "5",
            "--shard", f"{k}/{SHARDS}", "--threads", "1", "--out", tmp_path / f"part-{k}.json")
        want = json.loads((tmp_path / f"part-{k}.json").read_text())
        assert untimed(json.loads(part.to_json())) == untimed(want), f"shard {k}"
    cli("merge", *[tmp_path / f"part-{k}.json" for k in range(1, SHARDS + 1)],
        "--out", tmp_path / "merged.json")
    # Profiles and files, in any order.
    merged = ssskit.merge([parts[2], tmp_path / "part-1.json", str(tmp_path / "part-2.json")])
    assert untimed(json.loads(merged.to_json())) == untimed(json.loads((tmp_path / "merged.json").read_text()))
    assert untimed(json.loads(merged.to_json())) == untimed(json.loads(single.to_json()))


def test_a_profile_pickles_bit_for_bit(single):
    back = pickle.loads(pickle.dumps(single))
    assert back.to_json() == single.to_json()
    assert (back.rd == single.rd).all()


def test_merge_refuses_what_the_cli_refuses():
    a, b = shard(1, 2), shard(2, 2)
    other_seed = ssskit.simulate("skin1", shard=(2, 2), threads=1, photons=60000, seed=6)
    with pytest.raises(ValueError, match=r"parts\[1\].*different seeds"):
        ssskit.merge([a, other_seed])
    with pytest.raises(ValueError, match="given twice"):
        ssskit.merge([a, a])
    with pytest.raises(ValueError, match=r"missing shard\(s\) 2"):
        ssskit.merge([a])
    with pytest.raises(ValueError, match="not a shard"):
        ssskit.merge([a, ssskit.simulate("skin1", **RUN)])
    with pytest.raises(ValueError, match="no shards"):
        ssskit.merge([])
    with pytest.raises(ValueError, match="shard"):
        ssskit.simulate("skin1", shard=(3, 2), **RUN)
    with pytest.raises(ValueError, match="shard"):
        ssskit.simulate("skin1", shard=(1, 2), mc_error=0.05)
    assert untimed(json.loads(ssskit.merge([b, a]).to_json())) == untimed(
        json.loads(ssskit.simulate("skin1", **RUN).to_json()))


def test_the_docs_dask_recipe_merges_to_the_single_run(single):
    """python/examples/dask_shards.py, which docs/python.md prints, on two
    worker processes at the test's photon count."""
    spec = importlib.util.spec_from_file_location("dask_shards", ROOT / "python/examples/dask_shards.py")
    recipe = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(recipe)
    merged = recipe.traced("skin1", photons=RUN["photons"], shards=SHARDS, workers=2, seed=RUN["seed"])
    assert untimed(json.loads(merged.to_json())) == untimed(json.loads(single.to_json()))
