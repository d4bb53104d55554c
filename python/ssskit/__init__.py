"""ssskit from Python: subsurface-scattering profiles, kernels and filters.

The functions and classes are the Rust library's own (the extension module
``ssskit._native``); this package only re-exports them. Every result equals
what the ``ssskit`` command line writes for the same inputs and seed.

Data flow::

    m = ssskit.material("skin1")
    p = ssskit.simulate(m, mc_error=0.01, seed=1)     # or ssskit.profile(m, "pbd")
    k = ssskit.fit(p, model="preintegrate", taps=17)
    out = ssskit.apply(k, irradiance, mm_per_pixel=0.1)
"""

from ._native import (  # noqa: F401
    MODELS,
    ApplyOptions,
    DiskKernel,
    Kernel,
    Material,
    Profile,
    __version__,
    advise,
    apply,
    compare,
    diff,
    engine_params,
    fit,
    load,
    material,
    materials,
    merge,
    profile,
    read_image,
    reference,
    simulate,
    write_image,
)


def to_frame(rows):
    """A list of dicts (``compare``'s rows, ``advise``'s candidates) as a
    pandas DataFrame; pandas is optional and needed only here."""
    try:
        import pandas  # type: ignore[import-not-found,import-untyped,unused-ignore]
    except ImportError as e:
        raise ImportError("ssskit.to_frame needs pandas (pip install pandas); the rows are plain dicts") from e
    return pandas.DataFrame(rows)


__all__ = [
    "MODELS",
    "ApplyOptions",
    "DiskKernel",
    "Kernel",
    "Material",
    "Profile",
    "advise",
    "apply",
    "compare",
    "diff",
    "merge",
    "engine_params",
    "fit",
    "load",
    "material",
    "materials",
    "profile",
    "read_image",
    "reference",
    "simulate",
    "to_frame",
    "write_image",
]
