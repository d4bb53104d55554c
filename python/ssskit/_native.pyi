"""Type stubs of the extension module (see each function's docstring)."""

import os
from typing import Any, Dict, List, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
MODELS: List[str]

PathLike = Union[str, "os.PathLike[str]"]
RGB = Union[float, Sequence[float]]
FloatArray = Union[npt.NDArray[np.float32], npt.NDArray[np.float64]]

class Material:
    def __init__(
        self,
        sigma_a: RGB,
        sigma_s: RGB,
        g: RGB,
        eta: float,
        *,
        name: str = "custom",
        thickness: Optional[float] = None,
        eta_above: float = 1.0,
        eta_below: float = 1.0,
    ) -> None: ...
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
    def save(self, path: PathLike) -> None: ...
    def to_json(self) -> str: ...

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
    def save(self, path: PathLike) -> None: ...
    def to_json(self) -> str: ...

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
    def save(self, path: PathLike) -> None: ...
    def to_json(self) -> str: ...

def materials() -> List[Material]: ...
def material(spec: PathLike) -> Material: ...
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
) -> Profile: ...
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
    profile: Union[Profile, PathLike],
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
    near: Optional[RGB] = None,
    far: Optional[RGB] = None,
    preset: Optional[str] = None,
    manual_fit: bool = False,
    count: int = 4,
    jimenez_width: float = ...,
    jimenez_strength: RGB = ...,
    jimenez_falloff: RGB = ...,
    samples: int = 32,
    radii: Literal["widest", "mean", "per-channel"] = "widest",
) -> Union[Kernel, DiskKernel]: ...
def engine_params(
    profile: Union[Profile, PathLike],
    engine: Literal["unreal", "unity-hdrp", "blender", "godot", "iryoku"],
    *,
    version: Optional[str] = None,
    units_per_mm: Optional[float] = None,
    subsurface_method: Optional[Literal["christensen-burley", "random-walk"]] = None,
) -> Dict[str, Any]: ...
def apply(
    kernel: Union[Kernel, DiskKernel],
    irradiance: FloatArray,
    mm_per_pixel: Optional[float] = None,
    *,
    fov_y: Optional[float] = None,
    units_per_mm: float = ...,
    depth: Optional[FloatArray] = None,
    specular: Optional[FloatArray] = None,
    strength: Optional[FloatArray] = None,
    follow_surface: Optional[float] = None,
    sanitize: bool = False,
    full_factors: bool = False,
    jitter: bool = False,
    precision: Literal["f32", "f64"] = "f32",
    frames: Optional[int] = None,
    frame_seed: Optional[int] = None,
    accumulate: str = "mean",
    normals: Optional[FloatArray] = None,
    light_toward: Optional[Tuple[float, float, float]] = None,
    n_dot_l: Optional[FloatArray] = None,
    entry_weighted: bool = False,
    factors: bool = True,
    backend: Literal["cpu", "gpu"] = "cpu",
) -> FloatArray: ...
def reference(
    profile: Union[Profile, PathLike],
    irradiance: FloatArray,
    mm_per_pixel: float,
    *,
    sampling: Literal["average", "centre"] = "average",
) -> FloatArray: ...
def read_image(path: PathLike, dtype: Literal["float32", "float64"] = "float32") -> FloatArray: ...
def write_image(path: PathLike, image: FloatArray, *, png_bits: Literal[8, 16] = 8) -> None: ...
def load(path: PathLike) -> Union[Profile, Kernel, DiskKernel]: ...
