"""compare and advise as plain data: the same rows and answer as the CLI's
compare.json and `advise --json`, timings aside."""

import json
import warnings

import pytest

import ssskit
from conftest import untimed

# Two cheap model families, ranks 1 and 2, one signal: a comparison of a
# few seconds that still has several variants and tap tables.
MODELS = ["svd", "preintegrate"]


@pytest.fixture(scope="module")
def profile_file(tmp_path_factory, cli):
    d = tmp_path_factory.mktemp("report")
    cli("profile", "--material", "skin1", "--profile-model", "pbd", "--out", d / "skin1.json")
    return d / "skin1.json"


@pytest.mark.parametrize(
    "models, ranks, signals, taps, labels",
    [
        # svd ranks 1 and 2, each plain and renormalised, and preintegrate.
        (MODELS, "1-2", ["edge"], [17], {"svd1", "svd1-renorm", "svd2", "svd2-renorm", "preintegrate"}),
        # One model as a string (as --models takes it), two signals, two tap tables.
        ("preintegrate", "1", ["checker", "shapes"], [11, 25], {"preintegrate"}),
    ],
)
def test_compare_rows_equal_compare_json(profile_file, cli, models, ranks, signals, taps, labels):
    out = profile_file.parent / f"cmp-{len(labels)}"
    flag = models if isinstance(models, str) else ",".join(models)
    cli("compare", "--profiles", profile_file.parent, "--materials", "skin1", "--models", flag,
        "--ranks", ranks, "--signals", ",".join(signals), "--taps", ",".join(map(str, taps)), "--no-plots",
        "--out-dir", out)
    rows = ssskit.compare({"skin1": ssskit.load(profile_file)}, models=models, ranks=ranks, signals=signals,
                          taps=taps)
    theirs = json.loads((out / "compare.json").read_text())
    # Each label for r, g and b.
    assert {r["label"] for r in rows} == labels and len(rows) == 3 * len(labels)
    assert untimed(rows) == untimed(theirs)


def test_advise_answer_equals_the_cli(profile_file, cli):
    theirs = json.loads(cli("advise", "--profile", profile_file, "--mm-per-pixel", 0.1, "--models", ",".join(MODELS), "--json"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        answer, candidates, kernel = ssskit.advise(ssskit.load(profile_file), 0.1, models=MODELS)
    assert untimed(answer) == untimed(theirs)
    assert kernel.model == answer["model"] and kernel.tap_count == answer["taps"]
    assert len(candidates) > 1 and all(c["model"] in MODELS for c in candidates)


def test_bad_report_arguments(profile_file):
    p = ssskit.load(profile_file)
    with pytest.raises(ValueError, match="image_error: invalid value 5"):
        ssskit.advise(p, 0.1, image_error=5)
    with pytest.raises(ValueError, match="signals: invalid value 'sine'"):
        ssskit.compare([p], signals=["sine"])
    with pytest.raises(TypeError, match="profiles: expected a dict"):
        ssskit.compare(3)


def test_to_frame_needs_pandas_only_when_called():
    try:
        import pandas  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match="needs pandas"):
            ssskit.to_frame([{"a": 1}])
    else:
        assert list(ssskit.to_frame([{"a": 1}])["a"]) == [1]
