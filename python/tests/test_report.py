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
# The disk rows' case: a non-default frame count on a small signal, a
# comparison of a few seconds.
DISK_FRAMES = 4
DISK_SIGNAL = 64


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


def test_compare_disk_rows_equal_the_cli(profile_file, cli):
    """With "disk" among the models, the rows after compare.json's are the
    CLI's disk.json (the rows `compare` prints), at a non-default frame
    count."""
    out = profile_file.parent / "cmp-disk"
    cli("compare", "--profiles", profile_file.parent, "--materials", "skin1", "--models", "preintegrate,disk",
        "--ranks", "1", "--signals", "edge", "--taps", "9", "--frames", DISK_FRAMES, "--signal-size", DISK_SIGNAL,
        "--no-plots", "--out-dir", out)
    rows = ssskit.compare({"skin1": ssskit.load(profile_file)}, models="preintegrate,disk", ranks="1",
                          signals=["edge"], taps=[9], frames=DISK_FRAMES, signal_size=DISK_SIGNAL)
    theirs = json.loads((out / "compare.json").read_text())
    disk = json.loads((out / "disk.json").read_text())
    assert disk and all(d["rows"] for d in disk)
    assert untimed(rows) == untimed(theirs) + untimed(disk)


def test_advise_perspective_equals_the_cli(profile_file, cli):
    """fov_y with view_depth, image_height and units_per_mm: the scale and
    answer of `advise --fov-y --view-depth --image-height --units-per-mm`."""
    view = ["--fov-y", 40, "--view-depth", 25, "--image-height", 720, "--units-per-mm", 0.1]
    theirs = json.loads(cli("advise", "--profile", profile_file, *view, "--models", ",".join(MODELS), "--json"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        answer, _, _ = ssskit.advise(ssskit.load(profile_file), fov_y=40.0, view_depth=25.0, image_height=720,
                                     units_per_mm=0.1, models=MODELS)
    assert untimed(answer) == untimed(theirs)
    with pytest.raises(TypeError, match="give mm_per_pixel, or fov_y with view_depth and image_height"):
        ssskit.advise(ssskit.load(profile_file), fov_y=40.0)


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
