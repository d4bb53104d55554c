"""Python and the CLI give the same numbers for the same inputs and seed:
profiles and kernels equal as JSON (the timings aside), files byte for
byte after a load/save round trip, filtered images to the last bit."""

import json
import warnings

import numpy as np
import pytest

import ssskit
from conftest import untimed

# A short fixed-seed Monte Carlo run: enough photons for a profile a kernel
# can be fitted to, few enough to take well under a second.
PHOTONS = 20000
SEED = 7
# The image scale of the filter tests: skin1's kernel spans a few dozen pixels.
MM_PER_PIXEL = 0.05
# The GPU pass against the CPU one, relative to the peak: the bound of
# docs/filter.md's tolerance table for GPU (f32) vs CPU.
GPU_TOLERANCE = 1e-4
# A perspective view: 30 degrees, the surface 2 cm away (a scene in metres,
# the default units_per_mm): about 0.3 mm a pixel on 32 rows.
FOV_Y = 30.0
DEPTH_M = 0.02
# Fields that hold wall-clock times, the only ones allowed to differ.
TIMINGS = [("elapsed_s",), ("metrics", "fit_seconds"), ("metrics", "extra", "kernel_build_seconds")]


def without_timings(text):
    value = json.loads(text)
    for path in TIMINGS:
        node = value
        for key in path[:-1]:
            node = node.get(key, {})
        node.pop(path[-1], None)
    return value


@pytest.fixture(scope="module")
def mc_files(tmp_path_factory, cli):
    d = tmp_path_factory.mktemp("mc")
    cli("simulate", "--material", "skin1", "--photons", PHOTONS, "--seed", SEED, "--out", d / "p.json")
    cli("fit", "--profile", d / "p.json", "--model", "preintegrate", "--taps", 17, "--out", d / "pre.json", "--quiet")
    cli("fit", "--profile", d / "p.json", "--model", "svd", "--rank", 2, "--taps", 21, "--out", d / "svd.json", "--quiet")
    return d


def test_monte_carlo_profile_equals_the_cli(mc_files, tmp_path):
    p = ssskit.simulate("skin1", photons=PHOTONS, seed=SEED)
    cli_p = ssskit.load(mc_files / "p.json")
    assert np.array_equal(p.rd, cli_p.rd)
    assert np.array_equal(p.rd_stderr, cli_p.rd_stderr)
    p.save(tmp_path / "py.json")
    assert without_timings((tmp_path / "py.json").read_text()) == without_timings(
        (mc_files / "p.json").read_text()
    )


def test_monte_carlo_profile_does_not_depend_on_threads():
    one = ssskit.simulate("skin1", photons=PHOTONS, seed=SEED, threads=1)
    two = ssskit.simulate("skin1", photons=PHOTONS, seed=SEED, threads=2)
    assert np.array_equal(one.rd, two.rd) and np.array_equal(one.total_rd, two.total_rd)
    other = ssskit.simulate("skin1", photons=PHOTONS, seed=SEED + 1, threads=1)
    assert not np.array_equal(one.rd, other.rd)


@pytest.mark.parametrize("name", ["p.json", "pre.json", "svd.json"])
def test_files_round_trip_byte_for_byte(mc_files, tmp_path, name):
    obj = ssskit.load(mc_files / name)
    obj.save(tmp_path / name)
    assert (tmp_path / name).read_bytes() == (mc_files / name).read_bytes()


@pytest.mark.parametrize(
    "name, model, kwargs",
    [("pre.json", "preintegrate", {"taps": 17}), ("svd.json", "svd", {"taps": 21, "rank": 2})],
)
def test_kernels_equal_the_cli(mc_files, tmp_path, name, model, kwargs):
    k = ssskit.fit(ssskit.load(mc_files / "p.json"), model, **kwargs)
    k.save(tmp_path / name)
    assert without_timings((tmp_path / name).read_text()) == without_timings(
        (mc_files / name).read_text()
    )
    cli_k = ssskit.load(mc_files / name)
    assert len(k.taps) == len(cli_k.taps) == kwargs.get("rank", 1)
    for mine, theirs in zip(k.taps, cli_k.taps):
        assert mine["weights"].shape == (kwargs["taps"], 3)
        assert np.array_equal(mine["weights"], theirs["weights"])
        assert np.array_equal(mine["offsets_mm"], theirs["offsets_mm"])


@pytest.mark.parametrize("lang", ["hlsl", "glsl", "wgsl"])
def test_emit_equals_the_cli(mc_files, cli, lang):
    k = ssskit.load(mc_files / "pre.json")
    assert k.emit(lang) == cli("fit", "--kernel", mc_files / "pre.json", "--emit", lang, "--quiet")


def test_analytic_profile_equals_the_cli(tmp_path, cli):
    cli("profile", "--material", "marble", "--profile-model", "pbd", "--out", tmp_path / "a.json")
    p = ssskit.profile(ssskit.material("marble"), "pbd")
    p.save(tmp_path / "py.json")
    assert without_timings((tmp_path / "py.json").read_text()) == without_timings(
        (tmp_path / "a.json").read_text()
    )


def irradiance(channels, dtype=np.float32, shape=(48, 64)):
    """A test image with edges and noise, reproducible."""
    rng = np.random.default_rng(5)
    img = rng.random((*shape, channels)).astype(dtype)
    img[:, : shape[1] // 2, :3] += 2.0
    return img


def same_bits(a, b):
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("channels", [3, 4])
@pytest.mark.parametrize("kernel", ["pre.json", "svd.json"])
def test_filtered_image_equals_the_cli_bit_for_bit(mc_files, tmp_path, cli, channels, kernel):
    img = irradiance(channels)
    ssskit.write_image(tmp_path / "in.exr", img)
    cli("apply", "--kernel", mc_files / kernel, "--input", tmp_path / "in.exr", "--out", tmp_path / "out.exr",
        "--mm-per-pixel", MM_PER_PIXEL, "--backend", "cpu")
    theirs = ssskit.read_image(tmp_path / "out.exr")
    mine = ssskit.apply(ssskit.load(mc_files / kernel), img, mm_per_pixel=MM_PER_PIXEL)
    assert same_bits(mine, theirs)
    # The blur moved light: the output is not the input.
    assert not np.array_equal(mine[..., :3], img[..., :3])
    if channels == 4:
        assert np.array_equal(mine[..., 3], img[..., 3])


def test_full_factors_and_f64_equal_the_cli(mc_files, tmp_path, cli):
    img = irradiance(3)
    ssskit.write_image(tmp_path / "in.exr", img)
    cli("apply", "--kernel", mc_files / "pre.json", "--input", tmp_path / "in.exr", "--out", tmp_path / "out.exr",
        "--mm-per-pixel", MM_PER_PIXEL, "--backend", "cpu", "--full-factors", "--precision", "f64")
    mine = ssskit.apply(ssskit.load(mc_files / "pre.json"), img, MM_PER_PIXEL, full_factors=True, precision="f64")
    assert same_bits(mine, ssskit.read_image(tmp_path / "out.exr"))
    # The default is the tap table, as the CLI's: another image.
    default = ssskit.apply(ssskit.load(mc_files / "pre.json"), img, MM_PER_PIXEL, precision="f64")
    assert not same_bits(mine, default)


def test_reference_equals_the_cli(mc_files, tmp_path, cli):
    img = irradiance(3, shape=(24, 32))
    ssskit.write_image(tmp_path / "in.exr", img)
    cli("apply", "--reference", mc_files / "p.json", "--input", tmp_path / "in.exr", "--out", tmp_path / "ref.exr",
        "--mm-per-pixel", MM_PER_PIXEL, "--backend", "cpu")
    mine = ssskit.reference(ssskit.load(mc_files / "p.json"), img, MM_PER_PIXEL)
    assert same_bits(mine, ssskit.read_image(tmp_path / "ref.exr"))


def test_float64_in_float64_out(mc_files):
    k = ssskit.load(mc_files / "pre.json")
    img32 = irradiance(3)
    out64 = ssskit.apply(k, img32.astype(np.float64), MM_PER_PIXEL, precision="f64")
    assert out64.dtype == np.float64 and out64.shape == img32.shape
    out32 = ssskit.apply(k, img32, MM_PER_PIXEL, precision="f64")
    # The same samples in either dtype: the f32 output is the f64 one
    # rounded once, as the EXR writer rounds.
    assert same_bits(out64.astype(np.float32), out32)


@pytest.mark.parametrize("backend", ["cpu", "gpu"])
def test_perspective_with_depth_equals_the_cli(mc_files, tmp_path, cli, backend):
    """--fov-y with a depth image (the per-pixel path: f64 on the CPU, f32
    on the wgpu pass, lavapipe where there is no GPU): the same bits from
    both sides on each backend."""
    img = irradiance(4, shape=(32, 40))
    depth = np.full((32, 40), DEPTH_M, np.float32)
    depth[:, 20:] *= 1.05
    ssskit.write_image(tmp_path / "in.exr", img)
    ssskit.write_image(tmp_path / "depth.exr", np.repeat(depth[..., None], 3, axis=2))
    cli("apply", "--kernel", mc_files / "pre.json", "--input", tmp_path / "in.exr", "--out", tmp_path / "out.exr",
        "--fov-y", FOV_Y, "--depth", tmp_path / "depth.exr", "--depth-channel", "R", "--backend", backend)
    k = ssskit.load(mc_files / "pre.json")
    mine = ssskit.apply(k, img, fov_y=FOV_Y, depth=depth, backend=backend)
    assert same_bits(mine, ssskit.read_image(tmp_path / "out.exr"))
    other = ssskit.apply(k, img, fov_y=FOV_Y, depth=depth, backend="gpu" if backend == "cpu" else "cpu")
    # The two backends differ in the last bits (f32 against f64), within
    # the bound docs/filter.md gives.
    assert not same_bits(mine, other)
    assert np.abs(mine - other).max() < GPU_TOLERANCE * np.abs(other).max()


TWO_LAYERS_TOML = """name = "two"
unit = "mm"
[[layer]]
sigma_a = [0.1, 0.2, 0.3]
sigma_s = [5.0, 4.0, 3.0]
g = 0.8
eta = 1.4
thickness = 0.3
[[layer]]
sigma_a = [0.03, 0.05, 0.2]
sigma_s = [1.0, 1.2, 1.5]
g = 0.0
eta = 1.4
"""


def test_materials_from_coefficients_equal_the_files(tmp_path, cli):
    (tmp_path / "two.toml").write_text(TWO_LAYERS_TOML)
    two = ssskit.Material.layered(
        [
            dict(sigma_a=[0.1, 0.2, 0.3], sigma_s=[5.0, 4.0, 3.0], g=0.8, eta=1.4, thickness=0.3),
            dict(sigma_a=[0.03, 0.05, 0.2], sigma_s=[1.0, 1.2, 1.5], g=0.0, eta=1.4),
        ],
        name="two",
    )
    assert two == ssskit.material(tmp_path / "two.toml")
    cli("simulate", "--material", tmp_path / "two.toml", "--photons", 5000, "--seed", SEED, "--out", tmp_path / "cli.json")
    ssskit.simulate(two, photons=5000, seed=SEED).save(tmp_path / "py.json")
    assert without_timings((tmp_path / "py.json").read_text()) == without_timings((tmp_path / "cli.json").read_text())
    skin = ssskit.material("skin1")
    mine = ssskit.Material(skin.sigma_a, skin.sigma_s, 0.0, 1.3, name="skin1")
    assert mine == skin and mine.albedo.tolist() == skin.albedo.tolist()
    assert [m.name for m in ssskit.materials()][:3] == ["apple", "chicken1", "chicken2"]


# Blender with no method is Random Walk, the CLI's default for Cycles.
@pytest.mark.parametrize("engine,method", [("unreal", None), ("blender", None),
                                           ("blender", "christensen-burley")])
def test_engine_params_equal_the_cli(mc_files, tmp_path, cli, engine, method):
    flags = [] if method is None else ["--subsurface-method", method]
    cli("engine", "--profile", mc_files / "p.json", "--engine", engine, *flags,
        "--out", tmp_path / "e.json")
    mine = ssskit.engine_params(ssskit.load(mc_files / "p.json"), engine, subsurface_method=method)
    assert mine == json.loads((tmp_path / "e.json").read_text())
    assert mine["params"]
    if engine == "blender":
        want = "Random Walk" if method is None else "Christensen-Burley"
        assert mine["params"]["Subsurface Method"] == want


def test_engine_params_refuse_a_walk_elsewhere(mc_files):
    with pytest.raises(ValueError, match="random-walk is the blender engine's method"):
        ssskit.engine_params(ssskit.load(mc_files / "p.json"), "unreal",
                             subsurface_method="random-walk")
    with pytest.raises(ValueError, match="expected christensen-burley or random-walk"):
        ssskit.engine_params(ssskit.load(mc_files / "p.json"), "blender",
                             subsurface_method="walk")


# advise on the default families (the disk kernel among them) at a scale
# where the disk kernel is the answer; 64-pixel signals keep each side to a
# few seconds of CPU.
ADVISE_MM_PER_PIXEL = 0.1
ADVISE_SIGNAL = 64


def without_fit_seconds(text):
    value = json.loads(text)
    value["model"]["params"].pop("fit_seconds", None)
    value.get("metrics", {}).pop("fit_seconds", None)
    return value


@pytest.fixture(scope="module")
def pbd_file(tmp_path_factory, cli):
    d = tmp_path_factory.mktemp("advise")
    cli("profile", "--material", "skin1", "--profile-model", "pbd", "--out", d / "skin1.json")
    return d / "skin1.json"


# models as a list is held to the CLI by test_report.py's advise test.
@pytest.mark.parametrize("models", [None, "disk"])
def test_advise_returns_the_kernel_its_answer_names(pbd_file, tmp_path, cli, models):
    """The default families (disk included), and models as a string: the
    answer equals `advise --json`, and the kernel returned is the file
    `advise --out` writes, a DiskKernel where the answer is disk."""
    flags = [] if models is None else ["--models", "disk"]
    theirs = json.loads(cli("advise", "--profile", pbd_file, "--mm-per-pixel", ADVISE_MM_PER_PIXEL,
                            "--signal-size", ADVISE_SIGNAL, *flags, "--json", "--out", tmp_path / "k.json"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        answer, candidates, kernel = ssskit.advise(pbd_file, ADVISE_MM_PER_PIXEL, models=models,
                                                   signal_size=ADVISE_SIGNAL)
    assert untimed(answer) == untimed(theirs)
    assert answer["model"] == "disk" and isinstance(kernel, ssskit.DiskKernel)
    assert kernel.samples_per_pixel == answer["taps"]
    theirs_file = without_fit_seconds((tmp_path / "k.json").read_text())
    assert without_fit_seconds(kernel.to_json()) == theirs_file
    kernel.save(tmp_path / "py.json")
    assert without_fit_seconds((tmp_path / "py.json").read_text()) == theirs_file
    if models is None:
        # The default families: the separable ones were scored too.
        assert {c["model"] for c in candidates} > {"disk"}


def test_advise_takes_models_as_the_cli_does(pbd_file):
    with pytest.raises(ValueError, match="models"):
        ssskit.advise(pbd_file, ADVISE_MM_PER_PIXEL, models="disk,,svd")
    with pytest.raises(TypeError, match="models: expected a model name"):
        ssskit.advise(pbd_file, ADVISE_MM_PER_PIXEL, models=3)


def test_diff_equals_the_cli(mc_files, tmp_path, cli):
    """`diff` of two arrays, and of the files, gives `ssskit diff --json`'s
    numbers exactly."""
    a = irradiance(3)
    b = ssskit.apply(ssskit.load(mc_files / "pre.json"), a, MM_PER_PIXEL)
    ssskit.write_image(tmp_path / "a.exr", a)
    ssskit.write_image(tmp_path / "b.exr", b)
    theirs = json.loads(cli("diff", tmp_path / "a.exr", tmp_path / "b.exr", "--json"))
    assert ssskit.diff(a, b) == theirs
    assert ssskit.diff(tmp_path / "a.exr", str(tmp_path / "b.exr")) == theirs
    assert min(theirs["rms_rel"]) > 0
    bad = a.copy()
    bad[1, 2, 0] = np.nan
    with pytest.raises(ValueError, match=r"a: 1 NaN/Inf samples"):
        ssskit.diff(bad, b)
    with pytest.raises(ValueError, match="differ in size"):
        ssskit.diff(a, b[:-1])


def test_advise_without_factors_equals_the_cli(tmp_path, cli):
    """factors=False on a profile that carries entry and exit factors (a
    Monte Carlo run with exit-angle bins and oblique incidences): the
    answer of `advise --no-factors` and, as its kernel, the file it writes,
    which holds no factors where the default's does."""
    cli("simulate", "--material", "skin1", "--photons", PHOTONS, "--seed", SEED, "--angle-bins", 9,
        "--incidence", "30,60", "--out", tmp_path / "p.json")
    flags = ["--mm-per-pixel", ADVISE_MM_PER_PIXEL, "--models", "preintegrate", "--signal-size", ADVISE_SIGNAL,
             "--json"]
    theirs = json.loads(cli("advise", "--profile", tmp_path / "p.json", "--no-factors", *flags,
                            "--out", tmp_path / "without.json"))
    cli("advise", "--profile", tmp_path / "p.json", *flags, "--out", tmp_path / "with.json")
    theirs_file = without_timings((tmp_path / "without.json").read_text())
    assert "angular" not in theirs_file
    assert "angular" in json.loads((tmp_path / "with.json").read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        answer, _, kernel = ssskit.advise(tmp_path / "p.json", ADVISE_MM_PER_PIXEL, models="preintegrate",
                                          signal_size=ADVISE_SIGNAL, factors=False)
    assert untimed(answer) == untimed(theirs)
    assert without_timings(kernel.to_json()) == theirs_file
