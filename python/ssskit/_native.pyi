"""Type stubs of the extension module (see each function's docstring)."""

import os
from typing import Any, Dict, Iterable, List, Literal, Optional, Sequence, Tuple, TypedDict, Union, final

from typing_extensions import Unpack

import numpy as np
import numpy.typing as npt

__all__ = [
    "__version__",
    "Material",
    "materials",
    "material",
    "Profile",
    "simulate",
    "merge",
    "profile",
    "Kernel",
    "fit",
    "engine_params",
    "MODELS",
    "DiskKernel",
    "load",
    "reference",
    "read_image",
    "write_image",
    "diff",
    "ApplyOptions",
    "apply",
    "compare",
    "advise",
]
__version__: str
MODELS: List[str]

_PathLike = Union[str, "os.PathLike[str]"]
_RGB = Union[float, Sequence[float]]
_FloatArray = Union[npt.NDArray[np.float32], npt.NDArray[np.float64]]

@final
class Material:
    def __new__(
        cls,
        sigma_a: _RGB,
        sigma_s: _RGB,
        g: _RGB,
        eta: float,
        *,
        name: str = "custom",
        thickness: Optional[float] = None,
        eta_above: float = 1.0,
        eta_below: float = 1.0,
    ) -> "Material": ...
    @staticmethod
    def layered(
        layers: Sequence[Dict[str, Any]],
        *,
        name: str = "custom",
        eta_above: float = 1.0,
        eta_below: float = 1.0,
    ) -> "Material": ...
    @property
    def name(self) -> str: ...
    @property
    def eta_above(self) -> float: ...
    @property
    def eta_below(self) -> float: ...
    @property
    def layers(self) -> List[Dict[str, Any]]: ...
    @property
    def sigma_a(self) -> npt.NDArray[np.float64]: ...
    @property
    def sigma_s(self) -> npt.NDArray[np.float64]: ...
    @property
    def albedo(self) -> npt.NDArray[np.float64]: ...
    @property
    def reduced_albedo(self) -> npt.NDArray[np.float64]: ...
    @property
    def mfp_mm(self) -> npt.NDArray[np.float64]: ...
    def to_json(self) -> str: ...

@final
class Profile:
    @property
    def r(self) -> npt.NDArray[np.float64]: ...
    @property
    def r_edges(self) -> npt.NDArray[np.float64]: ...
    @property
    def rd(self) -> npt.NDArray[np.float64]: ...
    @property
    def rd_stderr(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def total_rd(self) -> npt.NDArray[np.float64]: ...
    @property
    def total_rd_stderr(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def channels(self) -> List[str]: ...
    @property
    def material(self) -> Material: ...
    @property
    def source(self) -> Dict[str, Any]: ...
    @property
    def elapsed_s(self) -> float: ...
    def warnings(self) -> List[str]: ...
    def save(self, path: _PathLike) -> None: ...
    def to_json(self) -> str: ...
    @staticmethod
    def from_json(text: str) -> Profile: ...
    def __reduce__(self) -> Tuple[Any, Tuple[str]]: ...

@final
class Kernel:
    @property
    def model(self) -> str: ...
    @property
    def params(self) -> Dict[str, Any]: ...
    @property
    def passes(self) -> List[Dict[str, npt.NDArray[np.float64]]]: ...
    @property
    def taps(self) -> List[Dict[str, npt.NDArray[np.float64]]]: ...
    @property
    def tap_count(self) -> int: ...
    @property
    def total_rd(self) -> npt.NDArray[np.float64]: ...
    @property
    def metrics(self) -> Dict[str, Any]: ...
    @property
    def material(self) -> Optional[Material]: ...
    def emit(self, lang: Literal["hlsl", "glsl", "wgsl"]) -> str: ...
    def save(self, path: _PathLike) -> None: ...
    def to_json(self) -> str: ...

@final
class DiskKernel:
    @property
    def model(self) -> str: ...
    @property
    def samples_per_pixel(self) -> int: ...
    @property
    def radius_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def angle(self) -> npt.NDArray[np.float64]: ...
    @property
    def weights(self) -> npt.NDArray[np.float64]: ...
    @property
    def total_rd(self) -> npt.NDArray[np.float64]: ...
    @property
    def material(self) -> Optional[Material]: ...
    @property
    def has_factors(self) -> bool: ...
    def emit(self, lang: Literal["hlsl", "glsl", "wgsl"]) -> str: ...
    def save(self, path: _PathLike) -> None: ...
    def to_json(self) -> str: ...

def materials() -> List[Material]: ...
def material(spec: _PathLike) -> Material: ...
def simulate(
    material: Union[Material, str],
    *,
    photons: Optional[int] = None,
    mc_error: Optional[float] = None,
    kernel_error: Optional[float] = None,
    max_photons: int = ...,
    seed: int = ...,
    threads: Optional[int] = None,
    channels: str = "rgb",
    dr: Optional[float] = None,
    rmax: Optional[float] = None,
    log_bins: bool = False,
    shard: Optional[Tuple[int, int]] = None,
    max_work: int = ...,
) -> Profile: ...
def merge(parts: Iterable[Union[Profile, _PathLike]]) -> Profile: ...
def profile(
    material: Union[Material, str],
    model: str = "pbd",
    *,
    channels: str = "rgb",
    dr: Optional[float] = None,
    rmax: Optional[float] = None,
    fresnel: Literal["fit", "exact"] = "fit",
) -> Profile: ...
def fit(
    profile: Union[Profile, _PathLike],
    model: str = "preintegrate",
    *,
    taps: Optional[int] = None,
    tap_extent: Optional[float] = None,
    grid_size: Optional[int] = None,
    extent: Optional[float] = None,
    rank: int = 1,
    renormalize: bool = False,
    method: Literal["abel", "grid"] = "abel",
    k: float = ...,
    b: float = ...,
    max_iters: int = ...,
    w: Optional[float] = None,
    near: Optional[_RGB] = None,
    far: Optional[_RGB] = None,
    preset: Optional[str] = None,
    manual_fit: bool = False,
    count: int = 4,
    jimenez_width: float = ...,
    jimenez_strength: _RGB = ...,
    jimenez_falloff: _RGB = ...,
    samples: int = 32,
    radii: Literal["widest", "mean", "per-channel"] = "widest",
) -> Union[Kernel, DiskKernel]: ...
def engine_params(
    profile: Union[Profile, _PathLike],
    engine: Literal["unreal", "unity-hdrp", "blender", "godot", "iryoku"],
    *,
    version: Optional[str] = None,
    units_per_mm: Optional[float] = None,
    subsurface_method: Optional[Literal["christensen-burley", "random-walk"]] = None,
) -> Dict[str, Any]: ...
class _ApplyKeywords(TypedDict, total=False):
    """apply's keywords (help(ssskit.apply) says what each means)."""

    mm_per_pixel: Optional[float]
    fov_y: Optional[float]
    units_per_mm: Optional[float]
    depth: Optional[_FloatArray]
    specular: Optional[_FloatArray]
    strength: Optional[_FloatArray]
    follow_surface: Optional[float]
    sanitize: bool
    full_factors: bool
    jitter: bool
    precision: Literal["f32", "f64"]
    frames: Optional[int]
    frame_seed: Optional[int]
    accumulate: Optional[str]
    normals: Optional[_FloatArray]
    light_toward: Optional[Tuple[float, float, float]]
    n_dot_l: Optional[_FloatArray]
    entry_weighted: bool
    factors: bool
    backend: Literal["cpu", "gpu", "auto"]

@final
class ApplyOptions:
    def __new__(cls, **keywords: Unpack[_ApplyKeywords]) -> "ApplyOptions": ...
    def replace(self, **keywords: Unpack[_ApplyKeywords]) -> "ApplyOptions": ...

def apply(
    kernel: Union[Kernel, DiskKernel],
    irradiance: _FloatArray,
    mm_per_pixel: Optional[float] = None,
    *,
    options: Optional[ApplyOptions] = None,
    out: Optional[_FloatArray] = None,
    fov_y: Optional[float] = None,
    units_per_mm: Optional[float] = None,
    depth: Optional[_FloatArray] = None,
    specular: Optional[_FloatArray] = None,
    strength: Optional[_FloatArray] = None,
    follow_surface: Optional[float] = None,
    sanitize: bool = False,
    full_factors: bool = False,
    jitter: bool = False,
    precision: Literal["f32", "f64"] = "f32",
    frames: Optional[int] = None,
    frame_seed: Optional[int] = None,
    accumulate: Optional[str] = None,
    normals: Optional[_FloatArray] = None,
    light_toward: Optional[Tuple[float, float, float]] = None,
    n_dot_l: Optional[_FloatArray] = None,
    entry_weighted: bool = False,
    factors: bool = True,
    backend: Literal["cpu", "gpu", "auto"] = "cpu",
) -> _FloatArray: ...
def reference(
    profile: Union[Profile, _PathLike],
    irradiance: _FloatArray,
    mm_per_pixel: float,
    *,
    sampling: Literal["average", "centre"] = "average",
) -> _FloatArray: ...
def read_image(path: _PathLike, dtype: Literal["float32", "float64"] = "float32") -> _FloatArray: ...
def write_image(path: _PathLike, image: _FloatArray, *, png_bits: Literal[8, 16] = 8) -> None: ...
def load(path: _PathLike) -> Union[Profile, Kernel, DiskKernel]: ...
def diff(
    a: Union[_FloatArray, _PathLike], b: Union[_FloatArray, _PathLike]
) -> Dict[str, List[float]]: ...
def compare(
    profiles: Union[Dict[str, Union[Profile, _PathLike]], Sequence[Union[Profile, _PathLike]]],
    *,
    models: Union[None, str, Sequence[str]] = None,
    ranks: str = "1-3",
    taps: Union[int, Sequence[int]] = ...,
    signals: Sequence[Literal["edge", "shapes", "dirac", "checker"]] = ...,
    mm_per_pixel: float = ...,
    signal_size: int = ...,
    extent: Optional[float] = None,
    pixels_per_degree: Optional[float] = None,
    frames: int = ...,
) -> List[Dict[str, Any]]: ...
def advise(
    profile: Union[Profile, _PathLike],
    mm_per_pixel: Optional[float] = None,
    *,
    image_error: float = ...,
    models: Union[None, str, Sequence[str]] = None,
    max_passes: Optional[int] = ...,
    max_samples: Optional[int] = None,
    max_taps: Optional[int] = None,
    signal_size: int = ...,
    frames: int = ...,
    fov_y: Optional[float] = None,
    view_depth: Optional[float] = None,
    image_height: Optional[int] = None,
    units_per_mm: float = ...,
    factors: bool = True,
) -> Tuple[Dict[str, Any], List[Dict[str, Any]], Union[Kernel, DiskKernel]]: ...
