"""Mitsuba-rendered `attenfit.Dataset`s: the exact builders' receivers, Mitsuba's irradiance.

`render_dataset(template, spp=..., seed=...)` takes a dataset from an `attenfit` builder
(`facing_sweep`, `plane_receivers`, `random_receivers`, or any `Dataset`) and replaces its
irradiance with the Monte Carlo estimate of `data_gen.estimate`, keeping the emitter and the
receivers, so the two can be compared receiver by receiver and fed to the same fits and
reports. A `plane_receivers` dataset also gets its plane as an opaque occluder in the scene.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

import numpy as np

from attenfit import BadTypeError, BadValueError, Dataset

from .estimate import Estimate, Progress, estimate_detail
from .scenes import Plane, lights_from_emitter
from .variants import mitsuba_version, select_variant

__all__ = [
    "GENERATOR",
    "dataset_from_estimate",
    "fingerprint",
    "mitsuba_provenance",
    "occluder_for",
    "render_dataset",
    "unit_receivers",
]

GENERATOR = "mitsuba"
_DROP = ("generator", "stderr", "versions")


def occluder_for(template: Dataset) -> Plane | None:
    """The plane under the light of a `plane_receivers` dataset (None for other datasets).

    A square centred on the grid's foot point, normal `up`, half side `2 (extent + r)`, so it
    covers the grid in any in-plane rotation.
    """
    prov = template.provenance
    if prov.get("builder") != "plane_receivers":
        return None
    up = np.asarray(prov["up"], dtype=np.float64)
    centre = np.asarray(template.emitter.reference_point(), dtype=np.float64)
    foot = centre - float(prov["height"]) * up
    half = 2.0 * (float(prov["extent"]) + float(template.emitter.radius))
    return Plane(point=foot, normal=up, half_size=half)


def unit_receivers(template: Dataset) -> tuple[np.ndarray, np.ndarray]:
    """`template`'s points and unit normals as float64 arrays."""
    p = np.asarray(template.points, dtype=np.float64)
    n = np.asarray(template.normals, dtype=np.float64)
    return p, n / np.linalg.norm(n, axis=1, keepdims=True)


def _plane_dict(plane: Plane | None) -> dict[str, Any] | None:
    if plane is None:
        return None
    return {"point": list(plane.point), "normal": list(plane.normal), "half_size": plane.half_size}


def fingerprint(
    template: Dataset, *, spp: int, seed: int, variant: str, plane: Plane | None
) -> str:
    """A hash of everything that fixes a render's numbers (receivers, emitter, spp, seed, variant)."""
    p, n = unit_receivers(template)
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(p).tobytes())
    h.update(np.ascontiguousarray(n).tobytes())
    meta = {
        "emitter": template.emitter.to_dict(),
        "spp": int(spp),
        "seed": int(seed),
        "variant": variant,
        "plane": _plane_dict(plane),
    }
    h.update(json.dumps(meta, sort_keys=True).encode())
    return h.hexdigest()[:32]


def mitsuba_provenance(
    template: Dataset, est: Estimate, *, spp: int, seed: int, plane: Plane | None
) -> dict[str, Any]:
    """The provenance of a Mitsuba render of `template`'s receivers (generator "mitsuba")."""
    import drjit

    import attenfit

    choice = select_variant(est.variant)
    kept = {k: v for k, v in template.provenance.items() if k not in _DROP}
    rel = np.divide(est.bias_bound, est.E, out=np.zeros_like(est.E), where=est.E > 0)
    return {
        **kept,
        "generator": GENERATOR,
        "variant": est.variant,
        "spp": int(spp),
        "seed": int(seed),
        "mitsuba_version": mitsuba_version(),
        "llvm_library": choice.llvm_path,
        "variant_reason": choice.reason,
        "estimator": (
            "mean over spp of weight * max(0, n.omega) from Scene.sample_emitter_direction"
            "(test_visibility=True); uniforms from numpy SeedSequence([seed, receiver, component])"
        ),
        "stderr": (
            "Monte Carlo standard error combined in quadrature with float32 bias bounds "
            "b / sqrt(3) where they are real and a rare-hit floor (data_gen.estimate)"
        ),
        "max_relative_bias_bound": float(rel.max()) if rel.size else 0.0,
        "occluder_plane": _plane_dict(plane),
        "versions": {
            "attenfit": attenfit.__version__,
            "mitsuba": mitsuba_version(),
            "drjit": str(drjit.__version__),
            "numpy": np.__version__,
        },
    }


def render_dataset(
    template: Dataset,
    *,
    spp: int,
    seed: int,
    variant: str = "auto",
    plane: Plane | str | None = "auto",
    progress: Progress | None = None,
) -> Dataset:
    """Render `template`'s receivers with Mitsuba: a `Dataset` with generator "mitsuba".

    Keeps the emitter, points, normals and the builder's provenance (so `grid_image` still
    works); `E` and `stderr` come from `data_gen.estimate.estimate_detail` in the dtype of
    `template.E`. `plane="auto"` adds the plane of a `plane_receivers` dataset as an
    occluder (`occluder_for`); pass a `Plane` or None to choose. Same seed and variant, same
    numbers.
    """
    if not isinstance(template, Dataset):
        raise BadTypeError(f"template must be an attenfit.Dataset, got {type(template).__name__}")
    if isinstance(plane, str):
        if plane != "auto":
            raise BadValueError(f"plane must be 'auto', None or a Plane, got {plane!r}")
        plane = occluder_for(template)
    lights = lights_from_emitter(template.emitter)
    p, n = unit_receivers(template)
    est = estimate_detail(
        lights, p, n, spp=spp, seed=seed, variant=variant, plane=plane, progress=progress
    )
    return dataset_from_estimate(template, est, spp=spp, seed=seed, plane=plane)


def dataset_from_estimate(
    template: Dataset, est: Estimate, *, spp: int, seed: int, plane: Plane | None
) -> Dataset:
    """`template` with `E`, `stderr` and provenance replaced by those of `est`."""
    dtype = template.E.dtype
    return Dataset(
        template.emitter,
        template.points,
        template.normals,
        est.E.astype(dtype),
        est.stderr.astype(dtype),
        mitsuba_provenance(template, est, spp=spp, seed=seed, plane=plane),
    )
