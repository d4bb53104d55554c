"""The Unity HDRP Diffusion Profile `ssskit engine --out-dir` writes, read
by a real Unity YAML reader (PyPI unityparser 4.0.0, installed by
scripts/test-python): the document Unity's editor saves, with the
serialized fields of HDRP's DiffusionProfileSettings.cs `DiffusionProfile`
class in declaration order, and the values the CLI printed."""

import json

import pytest
from unityparser import UnityDocument

from conftest import ROOT

# The editor-saved Diffusion Profile the layout is copied from
# (Unity-Technologies/Graphics, com.unity.render-pipelines.high-definition/
# Samples~/MaterialSamples/Settings/Diffusion Profiles/Wool Thick.asset):
# every key in order, a flow mapping as its keys, a scalar as None.
ORACLE_MONOBEHAVIOUR = [
    ("m_ObjectHideFlags", None),
    ("m_CorrespondingSourceObject", ["fileID"]),
    ("m_PrefabInstance", ["fileID"]),
    ("m_PrefabAsset", ["fileID"]),
    ("m_GameObject", ["fileID"]),
    ("m_Enabled", None),
    ("m_EditorHideFlags", None),
    ("m_Script", ["fileID", "guid", "type"]),
    ("m_Name", None),
    ("m_EditorClassIdentifier", None),
    ("profile", "profile"),
    ("m_Version", None),
]
ORACLE_PROFILE = [
    ("scatteringDistance", ["r", "g", "b", "a"]),
    ("scatteringDistanceMultiplier", None),
    ("transmissionTint", ["r", "g", "b", "a"]),
    ("texturingMode", None),
    ("smoothnessMultipliers", ["x", "y"]),
    ("lobeMix", None),
    ("diffuseShadingPower", None),
    ("transmissionMode", None),
    ("thicknessRemap", ["x", "y"]),
    ("worldScale", None),
    ("ior", None),
    ("hash", None),
]
# The MonoScript GUID of DiffusionProfileSettings.cs in the same file.
SCRIPT_GUID = "b2686e09ec7aef44bad2843e4416f057"
# A 32-bit float written with the fewest digits that read back: the text
# is the value to float32's relative resolution (2^-24), with margin.
FLOAT32_REL = 2e-7


def shape(mapping, oracle):
    got = []
    for key, value in mapping.items():
        if key in ("anchor", "extra_anchor_data"):
            continue
        if isinstance(value, dict):
            got.append((key, "profile" if key == "profile" else list(value.keys())))
        else:
            got.append((key, None))
    assert got == oracle


def srgb_to_linear(v):
    # IEC 61966-2-1, the curve Unity's Color.linear applies.
    return v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4


@pytest.fixture(scope="module")
def written(cli, tmp_path_factory):
    out = tmp_path_factory.mktemp("hdrp") / "files"
    cli("engine", "--profile", ROOT / "profiles" / "reference" / "skin1.json",
        "--engine", "unity-hdrp", "--out-dir", out)
    return out


def test_the_asset_is_a_diffusion_profile_as_the_editor_saves_it(written):
    path = written / "skin1.asset"
    doc = UnityDocument.load_yaml(str(path))
    assert len(doc.entries) == 1
    e = doc.entry
    # !u!114 is MonoBehaviour; 11400000 the main object's file ID.
    assert e.__class__.__name__ == "MonoBehaviour" and e.anchor == "11400000"
    shape(vars(e), ORACLE_MONOBEHAVIOUR)
    shape(e.profile, ORACLE_PROFILE)
    assert e.m_Script["guid"] == SCRIPT_GUID and e.m_Script["fileID"] == "11500000"
    assert e.m_Name == "skin1"
    # unityparser writes Unity's own layout: ours reads back byte for byte.
    again = path.with_name("again.asset")
    doc.dump_yaml(file_path=str(again))
    assert again.read_text() == path.read_text()


def test_the_asset_holds_the_printed_values_linear(written):
    fit = json.loads((written / "skin1-unity-hdrp.json").read_text())
    p = UnityDocument.load_yaml(str(written / "skin1.asset")).entry.profile
    shown = fit["params"]["Scattering Color"]
    for c, ch in enumerate("rgb"):
        # The picker shows sRGB and stores Color.linear
        # (DiffusionProfileSettingsEditor DrawScattering).
        want = srgb_to_linear(shown[c])
        assert float(p["scatteringDistance"][ch]) == pytest.approx(want, rel=FLOAT32_REL)
    assert float(p["scatteringDistanceMultiplier"]) == pytest.approx(
        fit["params"]["Multiplier"], rel=FLOAT32_REL)
    assert float(p["worldScale"]) == pytest.approx(fit["params"]["World Scale"], rel=FLOAT32_REL)
    # TexturingMode.PostScatter = 1.
    assert p["texturingMode"] == "1"
    # The shape distance HDRP renders (UpdateKernel: 1 / S = Multiplier x
    # scatteringDistance; mm at World Scale 1 and a scene in metres) is
    # the one ssskit scored.
    for c, ch in enumerate("rgb"):
        d = float(p["scatteringDistanceMultiplier"]) * float(p["scatteringDistance"][ch])
        assert d == pytest.approx(fit["rendered"]["d_mm"][c], rel=1e-6)


# Names a plain YAML scalar reads as something else (a sequence entry, a
# bool, a null, an int, a float): each must read back as the string it is.
HOSTILE_NAMES = ["-", "true", "null", "0x10", "-.inf", "1_000"]


@pytest.mark.parametrize("name", HOSTILE_NAMES)
def test_any_name_reads_back_as_the_assets_name(cli, tmp_path, name):
    profile = json.loads((ROOT / "profiles" / "reference" / "skin1.json").read_text())
    profile["material"]["name"] = name
    src = tmp_path / "p.json"
    src.write_text(json.dumps(profile))
    out = tmp_path / "files"
    cli("engine", "--profile", src, "--engine", "unity-hdrp", "--out-dir", out)
    (asset,) = out.glob("*.asset")
    e = UnityDocument.load_yaml(str(asset)).entry
    # Unity names an asset after its file.
    assert isinstance(e.m_Name, str) and e.m_Name == asset.stem, repr(e.m_Name)
