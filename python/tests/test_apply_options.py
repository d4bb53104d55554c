"""The rest of `ssskit apply` from Python, each equal to the CLI bit for
bit: disk kernels (fit, files, frames, accumulation), a strength plane,
sanitized input, and a kernel's angular entry and exit factors."""

import json
import struct
import warnings

import numpy as np
import pytest

import ssskit

# As in test_same_as_cli: a short fixed-seed profile and a scale at which
# skin1's kernel spans a few dozen pixels.
PHOTONS = 20000
SEED = 7
MM_PER_PIXEL = 0.05
# Disk kernels: few samples and frames keep each run well under a second.
SAMPLES = 16
FRAMES = 4
FRAME_SEED = 3
EMA = "ema:0.25"
# A view-space light direction, not normalised (the CLI and the library
# normalise it).
LIGHT = (0.3, 0.2, 1.0)
SHAPE = (40, 48)


def same_bits(a, b):
    return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a.view(np.uint8), b.view(np.uint8))


def write_raw_exr(path, img):
    """An uncompressed scanline EXR of float32 R, G, B as the OpenEXR file
    layout defines it (openexr.com, "OpenEXR File Layout": magic and
    version, the required header attributes, the line offset table, then
    per line y, byte count and the channels in name order), written here
    because ssskit.write_image refuses the NaN samples this test needs."""
    h, w, _ = img.shape

    def attr(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value

    channels = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in "BGR") + b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = (
        attr("channels", "chlist", channels)
        + attr("compression", "compression", b"\0")
        + attr("dataWindow", "box2i", box)
        + attr("displayWindow", "box2i", box)
        + attr("lineOrder", "lineOrder", b"\0")
        + attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
        + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
        + attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
        + b"\0"
    )
    start = 8 + len(header) + 8 * h
    line_bytes = 3 * 4 * w
    offsets = b"".join(struct.pack("<Q", start + y * (8 + line_bytes)) for y in range(h))
    lines = b"".join(
        struct.pack("<ii", y, line_bytes) + b"".join(img[y, :, c].astype("<f4").tobytes() for c in (2, 1, 0))
        for y in range(h)
    )
    path.write_bytes(struct.pack("<ii", 20000630, 2) + header + offsets + lines)


def without_fit_time(text):
    value = json.loads(text)
    value["model"]["params"].pop("fit_seconds")
    return value


def irradiance(shape=SHAPE):
    """Light on the left half, a soft bar in the right: an edge to blur."""
    h, w = shape
    img = np.zeros((h, w, 3), np.float32)
    img[:, : w // 2] = [1.0, 0.8, 0.6]
    img[h // 3 : h // 2, w // 2 :] = [0.2, 0.5, 1.0]
    return img


def sphere_normals(shape=SHAPE):
    """View-space unit normals of a sphere filling the frame, 0 outside."""
    h, w = shape
    y, x = np.mgrid[0:h, 0:w]
    sx = (x + 0.5 - w / 2) / (0.48 * min(h, w))
    sy = -(y + 0.5 - h / 2) / (0.48 * min(h, w))
    r2 = sx**2 + sy**2
    inside = r2 < 1.0
    n = np.zeros((h, w, 3), np.float32)
    n[..., 0] = np.where(inside, sx, 0.0)
    n[..., 1] = np.where(inside, sy, 0.0)
    n[..., 2] = np.where(inside, np.sqrt(np.clip(1.0 - r2, 0.0, 1.0)), 0.0)
    # Unit length in float32 (the check allows 2e-3).
    length = np.linalg.norm(n, axis=2, keepdims=True)
    return np.where(length > 0, n / np.maximum(length, 1e-30), 0.0).astype(np.float32)


@pytest.fixture(scope="module")
def files(tmp_path_factory, cli):
    d = tmp_path_factory.mktemp("opts")
    cli("simulate", "--material", "skin1", "--photons", PHOTONS, "--seed", SEED, "--out", d / "p.json")
    cli("simulate", "--material", "skin1", "--photons", PHOTONS, "--seed", SEED, "--angle-bins", 18,
        "--incidence", "30,60,80", "--out", d / "pa.json")
    cli("fit", "--profile", d / "p.json", "--model", "disk", "--samples", SAMPLES, "--out", d / "disk.json", "--quiet")
    cli("fit", "--profile", d / "p.json", "--model", "preintegrate", "--out", d / "pre.json", "--quiet")
    cli("fit", "--profile", d / "pa.json", "--model", "preintegrate", "--out", d / "pre_a.json", "--quiet")
    cli("fit", "--profile", d / "pa.json", "--model", "disk", "--samples", SAMPLES, "--out", d / "disk_a.json",
        "--quiet")
    ssskit.write_image(d / "in.exr", irradiance())
    ssskit.write_image(d / "normals.exr", sphere_normals())
    return d


def cli_apply(cli, files, tmp_path, kernel, *flags, image="in.exr"):
    out = tmp_path / "out.exr"
    cli("apply", "--kernel", files / kernel, "--input", files / image if isinstance(image, str) else image,
        "--out", out, "--mm-per-pixel", MM_PER_PIXEL, "--backend", "cpu", *flags)
    return ssskit.read_image(out)


def test_disk_kernel_equals_the_cli(files, tmp_path, cli):
    k = ssskit.fit(ssskit.load(files / "p.json"), "disk", samples=SAMPLES)
    assert isinstance(k, ssskit.DiskKernel) and k.samples_per_pixel == SAMPLES
    assert k.radius_mm.shape == (SAMPLES,) and k.weights.shape == (SAMPLES, 3)
    k.save(tmp_path / "py.json")
    assert without_fit_time((tmp_path / "py.json").read_text()) == without_fit_time((files / "disk.json").read_text())
    loaded = ssskit.load(files / "disk.json")
    assert isinstance(loaded, ssskit.DiskKernel)
    loaded.save(tmp_path / "again.json")
    assert (tmp_path / "again.json").read_bytes() == (files / "disk.json").read_bytes()
    assert loaded.emit("hlsl") == cli("fit", "--kernel", files / "disk.json", "--emit", "hlsl", "--quiet")
    # Another sample count is another kernel (the argument reaches the fit).
    assert not np.array_equal(ssskit.fit(ssskit.load(files / "p.json"), "disk", samples=8).radius_mm[:8],
                              k.radius_mm[:8])


@pytest.mark.parametrize("accumulate", ["mean", EMA])
def test_disk_frames_equal_the_cli(files, tmp_path, cli, accumulate):
    k = ssskit.load(files / "disk.json")
    mine = ssskit.apply(k, irradiance(), MM_PER_PIXEL, frames=FRAMES, frame_seed=FRAME_SEED,
                        accumulate=accumulate)
    theirs = cli_apply(cli, files, tmp_path, "disk.json", "--frames", FRAMES, "--frame-seed", FRAME_SEED,
                       "--accumulate", accumulate)
    assert same_bits(mine, theirs)
    # Another first frame turns the samples otherwise: other bits.
    other = ssskit.apply(k, irradiance(), MM_PER_PIXEL, frames=FRAMES, frame_seed=FRAME_SEED + 1,
                         accumulate=accumulate)
    assert not same_bits(mine, other)


def test_disk_frames_default_to_the_kernels(files, tmp_path, cli):
    """A disk kernel that records the frames its predicted error assumes
    (`accumulation`, written by advise and kernels) runs them by default,
    as `ssskit apply` does; one without runs one frame from seed 0."""
    rec = json.loads((files / "disk.json").read_text())
    rec["accumulation"] = {"frames": FRAMES, "first_frame": FRAME_SEED, "accumulate": "mean",
                           "camera": "static"}
    (tmp_path / "rec.json").write_text(json.dumps(rec))
    k = ssskit.load(tmp_path / "rec.json")
    mine = ssskit.apply(k, irradiance(), MM_PER_PIXEL)
    assert same_bits(mine, cli_apply(cli, files, tmp_path, tmp_path / "rec.json"))
    assert same_bits(mine, ssskit.apply(k, irradiance(), MM_PER_PIXEL, frames=FRAMES, frame_seed=FRAME_SEED))
    bare = ssskit.apply(ssskit.load(files / "disk.json"), irradiance(), MM_PER_PIXEL)
    assert same_bits(bare, ssskit.apply(k, irradiance(), MM_PER_PIXEL, frames=1, frame_seed=0))


def test_disk_and_separable_settings_are_kept_apart(files):
    disk = ssskit.load(files / "disk.json")
    sep = ssskit.load(files / "pre.json")
    with pytest.raises(ValueError, match="apply to separable kernels"):
        ssskit.apply(disk, irradiance(), MM_PER_PIXEL, full_factors=True)
    with pytest.raises(ValueError, match="apply to disk kernels"):
        ssskit.apply(sep, irradiance(), MM_PER_PIXEL, frames=2)
    with pytest.raises(ValueError, match="a disk kernel takes samples and radii"):
        ssskit.fit(ssskit.load(files / "p.json"), "disk", taps=9)
    with pytest.raises(ValueError, match="disk kernel's settings"):
        ssskit.fit(ssskit.load(files / "p.json"), "svd", samples=9)
    with pytest.raises(ValueError, match="radii: invalid value 'widest2'"):
        ssskit.fit(ssskit.load(files / "p.json"), "disk", radii="widest2")
    with pytest.raises(ValueError, match="ema"):
        ssskit.apply(disk, irradiance(), MM_PER_PIXEL, accumulate="ema:0")


def test_strength_equals_the_cli(files, tmp_path, cli):
    strength = np.ones(SHAPE, np.float32)
    strength[:, SHAPE[1] // 3 :] = 2.5
    ssskit.write_image(tmp_path / "s.exr", np.repeat(strength[..., None], 3, axis=2))
    k = ssskit.load(files / "pre.json")
    mine = ssskit.apply(k, irradiance(), MM_PER_PIXEL, strength=strength)
    assert same_bits(mine, cli_apply(cli, files, tmp_path, "pre.json", "--strength", tmp_path / "s.exr"))
    assert not same_bits(mine, ssskit.apply(k, irradiance(), MM_PER_PIXEL))


def test_sanitize_equals_the_cli(files, tmp_path, cli):
    img = irradiance()
    img[5, 7, 1] = np.nan
    img[9, 30, 0] = np.inf
    write_raw_exr(tmp_path / "bad.exr", img)
    # The file holds what the array holds (the reader is the CLI's).
    clean = irradiance()
    write_raw_exr(tmp_path / "clean.exr", clean)
    assert same_bits(ssskit.read_image(tmp_path / "clean.exr"), clean)
    k = ssskit.load(files / "pre.json")
    with pytest.warns(UserWarning, match=r"irradiance: replaced 2 NaN/Inf samples \(sanitize=True\)"):
        mine = ssskit.apply(k, img, MM_PER_PIXEL, sanitize=True)
    assert np.isfinite(mine).all()
    assert same_bits(mine, cli_apply(cli, files, tmp_path, "pre.json", "--sanitize", image=tmp_path / "bad.exr"))
    with pytest.raises(ValueError, match="irradiance: 2 NaN/Inf samples"):
        ssskit.apply(k, img, MM_PER_PIXEL)


@pytest.mark.parametrize("kernel", ["pre_a.json", "disk_a.json"])
def test_angular_factors_equal_the_cli(files, tmp_path, cli, kernel):
    k = ssskit.load(files / kernel)
    n = sphere_normals()
    normals = ["--normals", files / "normals.exr"]
    light = ",".join(map(str, LIGHT))
    toward = ssskit.apply(k, irradiance(), MM_PER_PIXEL, normals=n, light_toward=LIGHT)
    assert same_bits(toward, cli_apply(cli, files, tmp_path, kernel, *normals, "--light-toward", light))
    nl = np.clip(n @ (np.array(LIGHT) / np.linalg.norm(LIGHT)), -1, 1).astype(np.float32)
    ssskit.write_image(tmp_path / "nl.exr", np.repeat(nl[..., None], 3, axis=2))
    per_pixel = ssskit.apply(k, irradiance(), MM_PER_PIXEL, normals=n, n_dot_l=nl)
    assert same_bits(per_pixel, cli_apply(cli, files, tmp_path, kernel, *normals, "--n-dot-l", tmp_path / "nl.exr"))
    weighted = ssskit.apply(k, irradiance(), MM_PER_PIXEL, normals=n, entry_weighted=True)
    assert same_bits(weighted, cli_apply(cli, files, tmp_path, kernel, *normals, "--entry-weighted"))
    bare = ssskit.apply(k, irradiance(), MM_PER_PIXEL, normals=n, light_toward=LIGHT, factors=False)
    assert same_bits(bare, cli_apply(cli, files, tmp_path, kernel, "--no-factors"))
    # The factors change the image, and each light differs.
    assert not same_bits(toward, bare) and not same_bits(weighted, toward)


def test_angular_arguments_are_checked(files):
    with_factors = ssskit.load(files / "pre_a.json")
    without = ssskit.load(files / "pre.json")
    n = sphere_normals()
    with pytest.raises(ValueError, match="light_toward: the kernel carries no angular"):
        ssskit.apply(without, irradiance(), MM_PER_PIXEL, light_toward=LIGHT)
    with pytest.raises(ValueError, match="needs the normals"):
        ssskit.apply(with_factors, irradiance(), MM_PER_PIXEL, light_toward=LIGHT)
    with pytest.raises(ValueError, match="needs the light"):
        ssskit.apply(with_factors, irradiance(), MM_PER_PIXEL, normals=n)
    with pytest.raises(ValueError, match="give one of light_toward, n_dot_l and entry_weighted"):
        ssskit.apply(with_factors, irradiance(), MM_PER_PIXEL, normals=n, light_toward=LIGHT, entry_weighted=True)
    with pytest.raises(ValueError, match="normals"):
        ssskit.apply(with_factors, irradiance(), MM_PER_PIXEL, normals=2 * n, light_toward=LIGHT)
    with pytest.raises(ValueError, match="light direction"):
        ssskit.apply(with_factors, irradiance(), MM_PER_PIXEL, normals=n, light_toward=(0, 0, 0))
    # A kernel with factors and no normals: applied without them, as the
    # CLI does, with a warning.
    with pytest.warns(UserWarning, match="no normals are given"):
        plain = ssskit.apply(with_factors, irradiance(), MM_PER_PIXEL)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        assert same_bits(plain, ssskit.apply(with_factors, irradiance(), MM_PER_PIXEL, factors=False))
    assert not [w for w in said if "normals" in str(w.message)]


@pytest.mark.parametrize("kernel", ["pre.json", "pre_a.json", "disk_a.json"])
def test_specular_equals_the_cli(files, tmp_path, cli, kernel):
    """The specular image is added after the pass, and after the exit
    factor where the kernel carries the factors (it is not subsurface
    light)."""
    spec = np.zeros(SHAPE + (3,), np.float32)
    spec[10:14, 5:40] = [0.5, 0.5, 0.5]
    ssskit.write_image(tmp_path / "spec.exr", spec)
    k = ssskit.load(files / kernel)
    angular = dict(normals=sphere_normals(), light_toward=LIGHT) if kernel != "pre.json" else {}
    flags = ["--normals", files / "normals.exr", "--light-toward", ",".join(map(str, LIGHT))] if angular else []
    mine = ssskit.apply(k, irradiance(), MM_PER_PIXEL, specular=spec, **angular)
    assert same_bits(mine, cli_apply(cli, files, tmp_path, kernel, "--specular", tmp_path / "spec.exr", *flags))
    without = ssskit.apply(k, irradiance(), MM_PER_PIXEL, **angular)
    assert np.allclose(mine - without, spec, atol=1e-6)
