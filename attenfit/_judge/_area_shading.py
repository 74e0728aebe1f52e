"""The engine witness of the engines' own area lights: what Unreal's Rect Light and its
point light with a `SourceLength`, three.js's `RectAreaLight` and Godot's `AreaLight3D`
render at a receiver, from the properties attenfit hands out (the punctual lights are
`_engine_shading`'s).

One abstract base, `AreaWitness`, and one final class per engine light. Each states, cited
to the engine's file and function, the light's shape (`shape`: "rect" or "tube"), its class
in the engine (`light_type`), its intensity property and what a unit of it is
(`intensity_prop`, `intensity_unit`), its range property, and `render(props, x,
precision)`: the irradiance the engine computes at receivers given in the light's frame
(`x`: "x", "y", "z", "nx", "ny", "nz"; a rectangle's centre the origin, x along its width,
z its emitting normal; a tube's centre the origin, x along its axis), every operation
rounded to `precision` (the scene's) as `_engine_shading` renders. Where an engine's
diffuse term is one of attenfit's area models (three.js: `three_rect`; Unreal:
`unreal_rect`), the witness evaluates that model's formula through a NumPy back end
(`Np`), so the model and the witness are one arithmetic; tests/test_engine_area.py checks
each witness against the engine's code transcribed there.

`best_intensity(a, t, w)`: the intensity scale `c` that minimises the largest judged error
`max |c a - t| / w` (each term is convex in `c`, so is their largest: bisection on the
error), what a user may set freely in every engine.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping
from typing import Any, ClassVar, final

import numpy as np

from .._curves import ThreeRect, UnrealRect
from ._engine_shading import GodotWitness

__all__ = [
    "AREA_WITNESSES",
    "AreaWitness",
    "GodotAreaLight",
    "Np",
    "ThreeRectAreaLight",
    "UnrealRectLight",
    "UnrealSourceLength",
    "area_witnesses",
    "best_intensity",
    "godot_clipped_integral",
    "window_range",
]

Props = Mapping[str, Any]


class Np:
    """A NumPy back end for the area models' formulas (`_rect_models.Jax`'s operations,
    unguarded where a shader is: the engine's own arithmetic, in the inputs' dtype)."""

    @staticmethod
    def let(name: str, e: Any) -> Any:
        return e

    @staticmethod
    def sqrt(x: Any) -> Any:
        return np.sqrt(np.maximum(x, 0.0))

    abs = staticmethod(np.abs)
    select = staticmethod(np.where)
    max = staticmethod(np.maximum)
    min = staticmethod(np.minimum)
    atan2 = staticmethod(np.arctan2)

    @staticmethod
    def acos(x: Any) -> Any:
        return np.arccos(np.clip(x, -1.0, 1.0))

    @staticmethod
    def ge(a: Any, b: Any) -> Any:
        return a >= b

    @staticmethod
    def nonzero(x: Any) -> Any:
        return np.where(x != 0, x, np.ones_like(x))


def _cast(x: Mapping[str, Any], precision: str) -> dict[str, np.ndarray]:
    dt = np.dtype(precision)
    return {k: np.asarray(v, np.float64).astype(dt) for k, v in x.items()}


def window_range(d_max: float, tolerance: float) -> float:
    """The smallest range at which the engines' window `saturate(1 - (d/R)^4)^2` changes
    no receiver out to `d_max` by more than a twentieth of `tolerance`."""
    keep = 1.0 - tolerance / 20.0
    return float(d_max) / (1.0 - math.sqrt(keep)) ** 0.25


class AreaWitness(abc.ABC):
    """One engine light of an area shape (module docstring). `nominal(I, size)` is the
    intensity property's value for a light of the file's intensity `I` (its intensity along
    the normal for a rectangle, an end disk's along the axis for a tube: `attenfit.
    RectEmitter`, `TubeEmitter`), before `best_intensity` scales it; `candidates(size, R)`
    the properties tried (the engine's size settings), `R` a range in metres."""

    engine: ClassVar[str]
    shape: ClassVar[str]
    light_type: ClassVar[str]
    source: ClassVar[str]
    intensity_prop: ClassVar[str]
    intensity_unit: ClassVar[str]
    note: ClassVar[str] = ""

    @classmethod
    @abc.abstractmethod
    def candidates(cls, size: tuple[float, float], R: float) -> list[dict[str, Any]]:
        """The light's properties to try, without its intensity."""

    @classmethod
    @abc.abstractmethod
    def nominal(cls, intensity: float, size: tuple[float, float]) -> float:
        """The intensity property for the file's intensity (class docstring)."""

    @classmethod
    @abc.abstractmethod
    def shade(cls, props: Props, x: dict[str, np.ndarray]) -> np.ndarray:
        """E per unit of the intensity property, in the dtype of `x`."""

    @classmethod
    def render(cls, props: Props, x: Mapping[str, Any], precision: str = "float64"):
        """E at the receivers `x` (module docstring), at `precision`; float64 out."""
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            e = cls.shade(props, _cast(x, precision))
            return float(props[cls.intensity_prop]) * np.asarray(e, np.float64)


def _window(d, R: float):
    f = (d * d) * np.float64(1.0 / (R * R)).astype(d.dtype)
    return np.clip(1.0 - f * f, 0.0, 1.0) ** 2


def _dist(x) -> np.ndarray:
    return np.sqrt(x["x"] * x["x"] + x["y"] * x["y"] + x["z"] * x["z"])


@final
class UnrealRectLight(AreaWitness):
    engine = "unreal"
    shape = "rect"
    light_type = "RectLight"
    source = (
        "Unreal 4 Engine/Shaders/Private/RectLight.ush RectIrradianceLambert (the area model "
        "unreal_rect), DeferredLightingCommon.ush GetLocalLightAttenuation (inverse-squared "
        "window on the distance to the centre; Rect normal points away from point), "
        "RectLightSceneProxy.cpp / LightSceneInfo FRectLightSceneProxy::"
        "GetLightShaderParameters (Color / (0.5 SourceWidth SourceHeight)), "
        "RectLightComponent.cpp ComputeLightBrightness (Candelas: x 100 x 100)"
    )
    intensity_prop = "Intensity"
    intensity_unit = "cd (IntensityUnits = Candelas)"
    note = (
        "Unreal shades its rect at the radiance Intensity / (0.5 SourceWidth SourceHeight), "
        "twice a Lambertian panel's of that intensity: the Intensity handed out is about "
        "half the panel's"
    )

    @classmethod
    def candidates(cls, size, R):
        return [
            {
                "SourceWidth": 100.0 * size[0],
                "SourceHeight": 100.0 * size[1],
                "BarnDoorAngle": 88.0,  # cos 88 deg < 0.035: no barn doors (GetRect)
                "AttenuationRadius": 100.0 * R,
                "IntensityUnits": "Candelas",
            }
        ]

    @classmethod
    def nominal(cls, intensity, size):
        return 0.5 * intensity

    @classmethod
    def shade(cls, props, x):
        w, h = float(props["SourceWidth"]) / 100.0, float(props["SourceHeight"]) / 100.0
        hw, hh = x["x"].dtype.type(0.5 * w), x["x"].dtype.type(0.5 * h)
        per_radiance = UnrealRect.build(Np, x, hw, hh) * (4.0 * hw * hh)  # BaseIrr NoL
        radiance = x["x"].dtype.type(1.0 / (0.5 * w * h))
        R = float(props["AttenuationRadius"]) / 100.0
        return radiance * per_radiance * _window(_dist(x), R)


@final
class UnrealSourceLength(AreaWitness):
    engine = "unreal"
    shape = "tube"
    light_type = "PointLight"
    source = (
        "Unreal 4 Engine/Shaders/Private/CapsuleLight.ush LineIrradiance (Falloff = "
        "1/(|L0||L1| (cos/2 + 1/2) + DistBiasSqr), NoL the mean of the ends' cosines), "
        "SphereHorizonCosWrap; CapsuleLightIntegrate.ush IntegrateBxDF(FCapsuleLight) "
        "(SinAlphaSqr = saturate(SourceRadius^2 Falloff), NoL = saturate(NoL)); "
        "DeferredLightingCommon.ush GetCapsule (ends at ToLight -/+ SourceLength/2 Tangent, "
        "DistBiasSqr = 1 cm^2), GetLocalLightAttenuation (window on the centre's distance)"
    )
    intensity_prop = "Intensity"
    intensity_unit = "cd (IntensityUnits = Candelas)"
    note = (
        "the capsule's diffuse is an isotropic line (no fading toward the axis), the radius "
        "a horizon wrap"
    )

    @classmethod
    def candidates(cls, size, R):
        length, radius = size
        base = {"bUseInverseSquaredFalloff": True, "AttenuationRadius": 100.0 * R,
                "IntensityUnits": "Candelas"}  # fmt: skip
        return [
            {**base, "SourceLength": 100.0 * L, "SourceRadius": 100.0 * r}
            for L in (length, 0.0)
            for r in (0.0, radius)
        ]

    @classmethod
    def nominal(cls, intensity, size):
        length, radius = size
        return intensity * 2.0 * length / (math.pi * radius)  # the side seen broadside

    @classmethod
    def shade(cls, props, x):
        t = x["x"].dtype.type
        hl = t(0.5 * float(props["SourceLength"]) / 100.0)
        r = t(float(props["SourceRadius"]) / 100.0)
        bias = t(1e-4)  # DistBiasSqr = 1 cm^2
        n = (x["nx"], x["ny"], x["nz"])
        l0 = (-hl - x["x"], -x["y"], -x["z"])
        l1 = (hl - x["x"], -x["y"], -x["z"])
        inv0 = 1.0 / np.sqrt(sum(c * c for c in l0))
        inv1 = 1.0 / np.sqrt(sum(c * c for c in l1))
        inv01 = inv0 * inv1
        cos_sub = sum(a * b for a, b in zip(l0, l1, strict=True)) * inv01
        falloff = inv01 / (cos_sub * 0.5 + 0.5 + bias * inv01)
        nol = 0.5 * (sum(a * b for a, b in zip(n, l0, strict=True)) * inv0
                     + sum(a * b for a, b in zip(n, l1, strict=True)) * inv1)  # fmt: skip
        if r > 0:
            sin_a = np.sqrt(np.clip(r * r * falloff, 0.0, 1.0))
            s = sin_a + np.maximum(nol, -sin_a)
            nol = np.where(nol < sin_a, s * s / (4.0 * sin_a), nol)
        R = float(props["AttenuationRadius"]) / 100.0
        return falloff * np.clip(nol, 0.0, 1.0) * _window(_dist(x), R)


class _ByLuminance(AreaWitness):
    """A rectangle whose intensity property is its luminance: `I / (w h)` nominally."""

    @classmethod
    def nominal(cls, intensity, size):
        return intensity / (size[0] * size[1])


@final
class ThreeRectAreaLight(_ByLuminance):
    engine = "threejs"
    shape = "rect"
    light_type = "RectAreaLight"
    source = (
        "three.js src/lights/RectAreaLight.js (width, height; intensity the luminance in nits: "
        "power = intensity width height pi), src/renderers/webgl/WebGLLights.js (color x "
        "intensity, halfWidth, halfHeight), src/renderers/shaders/ShaderChunk/"
        "lights_physical_pars_fragment.glsl.js RE_Direct_RectArea_Physical and LTC_Evaluate "
        "with mat3(1.0) (the area model three_rect; one-sided, no distance window)"
    )
    intensity_prop = "intensity"
    intensity_unit = "nits (cd/m^2)"
    note = "three.js's RectAreaLight has no range and casts no shadows"

    @classmethod
    def candidates(cls, size, R):
        return [{"width": float(size[0]), "height": float(size[1])}]

    @classmethod
    def shade(cls, props, x):
        t = x["x"].dtype.type
        hw, hh = t(0.5 * float(props["width"])), t(0.5 * float(props["height"]))
        return ThreeRect.build(Np, x, hw, hh) * (4.0 * hw * hh)  # pi ff: E per nit


def _hill_theta_sin(c):
    """Godot's `integrate_edge_hill` fit of theta / sin(theta) (Hill & Heitz), with its
    `M_PI * inversesqrt(1 - x^2) - fit` for a negative cosine."""
    y = np.abs(c)
    a = 5.42031 + (3.12829 + 0.0902326 * y) * y
    b = 3.45068 + (4.18814 + y) * y
    v = a / b
    return np.where(c < 0.0, math.pi / np.sqrt(np.maximum(1.0 - c * c, 0.0)) - v, v)


def _unit3(v):
    inv = 1.0 / np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return tuple(c * inv for c in v)


def _godot_edge(pa, pb, a, b, n):
    """Godot's `integrate_edge(p_proj0, p_proj1, p0, p1)`: the fit times the cross product
    along the normal, split at the point nearest the receiver when the ends are opposite."""

    def hill(u, v):
        c = u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
        cr = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
        return _hill_theta_sin(c) * (cr[0] * n[0] + cr[1] * n[1] + cr[2] * n[2])

    with np.errstate(invalid="ignore", divide="ignore"):
        opposite = pa[0] * pb[0] + pa[1] * pb[1] + pa[2] * pb[2] < -1.0 + 1e-5
        d = _unit3(tuple(q - p for p, q in zip(a, b, strict=True)))  # normalize(p1 - p0)
        m = _unit3(tuple(p - q for p, q in zip(a, b, strict=True)))  # normalize(p0 - p1)
        s = a[0] * m[0] + a[1] * m[1] + a[2] * m[2]
        half = _unit3(tuple(p + dd * s for p, dd in zip(a, d, strict=True)))
        split = hill(pa, half) + hill(half, pb)
    return np.where(opposite, split, hill(pa, pb))


def godot_clipped_integral(v: list, n: tuple) -> np.ndarray:
    """Godot's `ltc_evaluate` with `mat3(1)` (area_lights_inc.glsl): the quad `v` (corners
    relative to the receiver) clipped to the receiver's horizon (`clip_quad_to_horizon`:
    the corners with n.v > 0 kept, each crossing edge cut at `-h_b v_a + h_a v_b`), the
    clipped polygon's edges summed by `integrate_edge`, `abs(I) / (2 pi)`. Sutherland-Hodgman
    gives the polygon Godot's sixteen cases do (a convex quad crosses a plane twice)."""
    k = len(v)
    h = [v[i][0] * n[0] + v[i][1] * n[1] + v[i][2] * n[2] for i in range(k)]
    total = np.zeros_like(h[0])
    exit_pt = entry_pt = tuple(np.zeros_like(h[0]) for _ in range(3))
    with np.errstate(invalid="ignore", divide="ignore"):
        for i in range(k):
            j = (i + 1) % k
            a_in, b_in = h[i] > 0.0, h[j] > 0.0
            q = tuple(-h[j] * v[i][c] + h[i] * v[j][c] for c in range(3))  # Godot's cut
            q = tuple(np.where(h[i] > h[j], 1.0, -1.0) * c for c in q)  # its direction
            a2 = tuple(np.where(a_in, v[i][c], q[c]) for c in range(3))
            b2 = tuple(np.where(b_in, v[j][c], q[c]) for c in range(3))
            term = _godot_edge(_unit3(a2), _unit3(b2), a2, b2, n)
            total = total + np.where(a_in | b_in, np.nan_to_num(term), 0.0)
            exit_pt = tuple(np.where(a_in & ~b_in, q[c], exit_pt[c]) for c in range(3))
            entry_pt = tuple(np.where(~a_in & b_in, q[c], entry_pt[c]) for c in range(3))
        crossing = np.any([(h[i] > 0.0) != (h[(i + 1) % k] > 0.0) for i in range(k)], axis=0)
        chord = _godot_edge(_unit3(exit_pt), _unit3(entry_pt), exit_pt, entry_pt, n)
        total = total + np.where(crossing, np.nan_to_num(chord), 0.0)
    any_in = np.any([hi > 0.0 for hi in h], axis=0)
    return np.where(any_in, np.abs(total), 0.0) / (2.0 * math.pi)


#: Godot's quad corners, `points[0..3]` of `light_process_area` (position -/+ half width
#: -/+ half height), in the light's frame.
_GODOT_ORDER = ((-1, -1), (1, -1), (1, 1), (-1, 1))


@final
class GodotAreaLight(_ByLuminance):
    engine = "godot"
    shape = "rect"
    light_type = "AreaLight3D"
    source = (
        "Godot (godotengine/godot PR #108219, merged after 4.5) servers/rendering/renderer_rd/"
        "shaders/scene_forward_lights_inc.glsl light_process_area (nothing behind the light; "
        "get_omni_attenuation of the distance to the rectangle's nearest point times that "
        "distance squared; ltc_evaluate with mat3(1)), area_lights_inc.glsl ltc_evaluate, "
        "clip_quad_to_horizon, integrate_edge (Hill's fit of theta / sin theta); "
        "doc/classes/AreaLight3D.xml (area_size, area_range, area_attenuation)"
    )
    intensity_prop = "light_energy"
    intensity_unit = (
        "the luminance, in the convention of attenfit's Godot answers (an omni's energy is "
        "its intensity; Godot's CPU-side constant for area lights was not read)"
    )
    note = "area lights are Forward+ only; area_attenuation 2 is the physical falloff"

    @classmethod
    def candidates(cls, size, R):
        return [{"area_size": [float(size[0]), float(size[1])], "area_range": R,
                 "area_attenuation": 2.0}]  # fmt: skip

    @classmethod
    def shade(cls, props, x):
        t = x["x"].dtype.type
        hw, hh = t(0.5 * props["area_size"][0]), t(0.5 * props["area_size"][1])
        p = (x["x"], x["y"], x["z"])
        n = (x["nx"], x["ny"], x["nz"])
        v = [(sx * hw - p[0], sy * hh - p[1], -p[2]) for sx, sy in _GODOT_ORDER]
        ltc = godot_clipped_integral(v, n)
        dx = p[0] - np.clip(p[0], -hw, hw)
        dy = p[1] - np.clip(p[1], -hh, hh)
        dist = np.sqrt(dx * dx + dy * dy + p[2] * p[2])
        omni = {"omni_range": props["area_range"], "omni_attenuation": props["area_attenuation"]}
        atten = GodotWitness.distance(dist, omni) * dist * dist
        return np.where(p[2] > 0.0, math.pi * ltc * atten, 0.0)


AREA_WITNESSES: tuple[type[AreaWitness], ...] = (
    UnrealRectLight,
    UnrealSourceLength,
    ThreeRectAreaLight,
    GodotAreaLight,
)


def area_witnesses(engine: str, shape: str) -> tuple[type[AreaWitness], ...]:
    """The engine's own lights of `shape` ("rect", "tube"); empty where it has none."""
    return tuple(w for w in AREA_WITNESSES if w.engine == engine and w.shape == shape)


def best_intensity(a: np.ndarray, t: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """`(c, e)`: the scale `c >= 0` minimising `e = max |c a - t| / w` (module docstring).
    A receiver with `a = 0` keeps `t / w` whatever `c`; a non-finite `a` gives `inf`."""
    a, t, w = (np.asarray(v, np.float64) for v in (a, t, w))
    if not np.all(np.isfinite(a)):
        return 1.0, math.inf
    on = a > 0
    floor = float(np.max(np.abs(t[~on]) / w[~on])) if (~on).any() else 0.0
    if not on.any():
        return 1.0, floor
    a, t, w = a[on], t[on], w[on]

    def bounds(e: float) -> tuple[float, float]:
        return float(np.max((t - e * w) / a)), float(np.min((t + e * w) / a))

    lo, hi = 0.0, float(np.max(np.abs(np.median(t / a) * a - t) / w))
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        low, high = bounds(mid)
        lo, hi = (lo, mid) if low <= high and high >= 0.0 else (mid, hi)
        if hi - lo <= 1e-13 * max(hi, 1e-300):
            break
    low, high = bounds(hi)
    c = max(0.5 * (max(low, 0.0) + high), 0.0)
    return c, max(float(np.max(np.abs(c * a - t) / w)), floor)
