"""The engine witness: each `--engine`'s own shading of a punctual light, evaluated as the
engine renders it from the light properties attenfit hands out, so that an engine answer is
judged on what the engine draws, never on attenfit's model of it.

One abstract base, `EngineWitness`, and one final class per engine. What an engine does is
stated on its class: its distance falloff with its window and range (`distance`), its spot
cone with the engine's own cosines and clamps (`cone`), what a light size does to the
diffuse term (`diffuse`), whether its light has an emission cosine (none has: a punctual
light emits alike in every direction, so a disk light is answered as a spot whose cone
stands in for the cosine), and the cone properties a fit of the engine's settings may move
(`cone_props`, with their bounds). Every formula cites the engine's file and function.

`render(props, d, cos_s, n_dot_l, spot)` is the irradiance per unit intensity that the
engine computes: `E / I = distance(d) * cone(cos_s) * diffuse(n.l, d)` (a spot's cone only
when the light is a spot in the engine), in NumPy at the scene's precision (float64,
float32 or float16: every operation rounded to it, as attenfit's own curve is judged), with
the engine's CPU-side constants rounded as the engine rounds them (float32). `engine_receiver_errors` is the judged
error of those values against the exact irradiance at a scene's receivers; the worst case
over a scene's receivers (a finite set) is its maximum.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping
from typing import Any, ClassVar, final

import numpy as np

__all__ = [
    "WITNESSES",
    "EngineWitness",
    "engine_receiver_errors",
    "fast_cos",
    "get_witness",
]

Props = Mapping[str, Any]


def _sat(x):
    return np.clip(x, 0.0, 1.0)


def _f32(x) -> float:
    return float(np.float32(x))


def fast_cos(x):
    """Filament's `fast::cos` (libs/math/include/math/fast.h, `cos`): a parabola fit, not
    the cosine (about 1e-3 off), in float32 as Filament's CPU side computes it."""
    x = np.float32(x) * np.float32(0.5 / math.pi)
    x = x - (np.float32(0.25) + np.floor(x + np.float32(0.25)))
    x = x * (np.float32(16.0) * np.abs(x) - np.float32(8.0))
    x = x + np.float32(0.225) * x * (np.abs(x) - np.float32(1.0))
    return np.float32(x)


def _scale_offset(cos_inner: float, cos_outer: float, floor: float) -> tuple[float, float]:
    scale = _f32(1.0 / max(floor, _f32(cos_inner - cos_outer)))
    return scale, _f32(-cos_outer * scale)


class EngineWitness(abc.ABC):
    """One engine's shading of a punctual light (module docstring). Class facts: `name`
    (the `--engine` name), `source` (files and functions), `size_effect` (what a light's
    size does to the diffuse term, in words), `emission_cosine` (False for every punctual
    light), `cone_props` (the spot cone's properties a fit of the engine's settings may
    move, each `(name, low, high)` in the property's own unit; empty: no spot cone),
    `cone_log` (those searched on a log scale), `cone_outer` (the one that sets the cone's
    outer edge), `range_prop` (the property holding the
    range, None where the engine has none)."""

    name: ClassVar[str]
    source: ClassVar[str]
    size_effect: ClassVar[str]
    emission_cosine: ClassVar[bool] = False
    cone_props: ClassVar[tuple[tuple[str, float, float], ...]] = ()
    range_prop: ClassVar[str | None] = None
    #: the cone properties searched on a log scale (their bounds span decades)
    cone_log: ClassVar[frozenset[str]] = frozenset()
    #: the cone property that sets the cone's outer edge (past it the cone is 0)
    cone_outer: ClassVar[str | None] = None
    #: the other light properties a fit of the engine's settings may move (attenfit.
    #: _scenes._engine_search), each `(name, role, unit per metre, low, high)`: role "range"
    #: (the window's range), "decay" (a distance exponent), "scale" (a brightness factor) or
    #: "size" (a light size in the diffuse term); low and high are the engine's own bounds
    #: (inf: none). A property missing from an answer's properties is not moved.
    search_props: ClassVar[tuple[tuple[str, str, float, float, float], ...]] = ()
    #: the light's intensity property, and how many of its units make one candela: an
    #: answer that states it (a tube's point light, `attenfit._scenes._engine_area`) is
    #: rendered at that intensity, else at the scene's (`engine_receiver_errors`)
    intensity_prop: ClassVar[str] = "intensity"
    intensity_per_cd: ClassVar[float] = 1.0

    @classmethod
    def intensity_of(cls, props: Props, default: float) -> float:
        """The intensity in candela that `props` states (`intensity_prop`), else `default`."""
        if cls.intensity_prop in props:
            return float(props[cls.intensity_prop]) / cls.intensity_per_cd
        return default

    @classmethod
    @abc.abstractmethod
    def distance(cls, d: np.ndarray, props: Props) -> np.ndarray:
        """The distance falloff with its window, per unit intensity (1/m^2)."""

    @classmethod
    @abc.abstractmethod
    def cone(cls, cos_s: np.ndarray, props: Props) -> np.ndarray:
        """The spot cone's factor at the cosine `cos_s` from the spot's axis."""

    @classmethod
    def diffuse(cls, n_dot_l: np.ndarray, d: np.ndarray, props: Props) -> np.ndarray:
        """The diffuse term's cosine factor; Lambert's `max(0, n.l)` unless overridden."""
        return np.maximum(n_dot_l, 0.0)

    @classmethod
    def render(
        cls,
        props: Props,
        d: np.ndarray,
        cos_s: np.ndarray,
        n_dot_l: np.ndarray,
        spot: bool,
        precision: str = "float64",
    ) -> np.ndarray:
        """E / I as the engine renders it (module docstring), every operation rounded to
        `precision` (the inputs first; float64 out)."""
        dt = np.dtype(precision)
        d = np.asarray(d, np.float64).astype(dt)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            out = cls.distance(d, props) * cls.diffuse(np.asarray(n_dot_l).astype(dt), d, props)
            if spot:
                out = out * cls.cone(np.asarray(cos_s).astype(dt), props)
        return np.asarray(out).astype(np.float64)


def _window4(d, R):
    """Frostbite's / Unreal's / Bevy's window `saturate(1 - (d^2/R^2)^2)^2`."""
    if R is None or not math.isfinite(R) or R <= 0:
        return np.ones_like(d)
    f = (d * d) * _f32(1.0 / (R * R))
    return _sat(1.0 - f * f) ** 2


@final
class GodotWitness(EngineWitness):
    name = "godot"
    source = (
        "Godot 4 servers/rendering/renderer_rd/shaders/scene_forward_lights_inc.glsl: "
        "get_omni_attenuation, light_process_omni / light_process_spot (size_A), "
        "light_compute (NdotL = min(A + dot(N, L), 1)); storage_rd/light_storage.cpp "
        "update_light_buffers (inv_radius = 1/max(0.001, range), cos_spot_angle = "
        "cos(deg_to_rad(spot_angle)), inv_spot_attenuation = 1/spot_angle_attenuation)"
    )
    size_effect = (
        "light_size > 0 adds size_A = 1 - 1/sqrt(1 + (size/max(0.001, d))^2) to n.l in the "
        "diffuse term (min(A + n.l, 1)), when soft shadows are enabled: it brightens every "
        "receiver near the light"
    )
    cone_props = (("spot_angle", 0.1, 180.0), ("spot_angle_attenuation", 0.01, 50.0))
    cone_log = frozenset({"spot_angle_attenuation"})
    cone_outer = "spot_angle"
    # OmniLight3D / SpotLight3D property hints (scene/3d/light_3d.cpp _bind_methods):
    # *_attenuation "-10,10,or_greater,or_less", light_size "0,1,or_greater"; ranges
    # floored at 0.001 (light_storage.cpp)
    search_props = (
        ("omni_range", "range", 1.0, 0.001, math.inf),
        ("spot_range", "range", 1.0, 0.001, math.inf),
        ("omni_attenuation", "decay", 1.0, -10.0, 10.0),
        ("spot_attenuation", "decay", 1.0, -10.0, 10.0),
        ("light_size", "size", 1.0, 0.0, math.inf),
    )
    # Light3D.light_energy; attenfit reads it as the intensity (its omni's E = energy
    # attenuation n.l, the convention of every Godot answer here)
    intensity_prop = "light_energy"

    @classmethod
    def _key(cls, props: Props) -> str:
        return "spot" if "spot_range" in props else "omni"

    @classmethod
    def distance(cls, d, props):
        k = cls._key(props)
        inv_range = _f32(1.0 / max(0.001, float(props[f"{k}_range"])))
        nd = (d * inv_range) ** 4
        nd = np.maximum(1.0 - nd, 0.0) ** 2
        return nd * np.maximum(d, 0.0001) ** (-float(props[f"{k}_attenuation"]))

    @classmethod
    def cone(cls, cos_s, props):
        cone_angle = _f32(math.cos(math.radians(float(props["spot_angle"]))))
        inv_att = _f32(1.0 / float(props.get("spot_angle_attenuation", 1.0)))
        scos = np.maximum(cos_s, cone_angle)
        rim = np.maximum(0.0001, (1.0 - scos) / (1.0 - cone_angle))
        return 1.0 - rim**inv_att

    @classmethod
    def diffuse(cls, n_dot_l, d, props):
        size = float(props.get("light_size", 0.0))
        if size <= 0:
            return np.maximum(n_dot_l, 0.0)
        t = size / np.maximum(0.001, d)
        a = np.maximum(0.0, 1.0 - 1.0 / np.sqrt(1.0 + t * t))
        return np.maximum(np.minimum(a + n_dot_l, 1.0), 0.0)


@final
class ThreeJSWitness(EngineWitness):
    name = "threejs"
    source = (
        "three.js src/renderers/shaders/ShaderChunk/lights_pars_begin.glsl.js: "
        "getDistanceAttenuation, getSpotAttenuation (smoothstep(coneCos, penumbraCos, c)); "
        "src/renderers/webgl/WebGLLights.js (coneCos = cos(angle), penumbraCos = "
        "cos(angle (1 - penumbra)))"
    )
    size_effect = "three.js point and spot lights have no size"
    cone_props = (("angle", 1e-3, 0.5 * math.pi), ("penumbra", 0.0, 1.0))
    cone_outer = "angle"
    range_prop = "distance"
    # PointLight / SpotLight `distance` (0: no cutoff) and `decay` (three.js states no
    # bounds: Godot's editor range is taken)
    search_props = (("distance", "range", 1.0, 0.0, math.inf), ("decay", "decay", 1.0, -10.0, 10.0))

    @classmethod
    def distance(cls, d, props):
        f = 1.0 / np.maximum(d ** float(props["decay"]), 0.01)
        cutoff = float(props.get("distance", 0.0))
        if cutoff > 0:
            f = f * _sat(1.0 - (d / cutoff) ** 4) ** 2
        return f

    @classmethod
    def cone(cls, cos_s, props):
        angle, pen = float(props["angle"]), float(props.get("penumbra", 0.0))
        e0, e1 = _f32(math.cos(angle)), _f32(math.cos(angle * (1.0 - pen)))
        if e1 == e0:  # GLSL smoothstep with edge0 == edge1 is undefined: a step here
            return (cos_s >= e0).astype(cos_s.dtype)
        t = _sat((cos_s - e0) / (e1 - e0))
        return t * t * (3.0 - 2.0 * t)


@final
class UnrealWitness(EngineWitness):
    name = "unreal"
    source = (
        "Unreal (described, not copied): DeferredLightingCommon.ush GetLocalLightAttenuation "
        "(inverse squared: 1/(DistSqr + 1 cm^2) x Square(saturate(1 - Square(DistSqr "
        "InvRadius^2))); else RadialAttenuation pow(1 - saturate(DistSqr InvRadius^2), "
        "FalloffExponent)), SpotAttenuation Square(saturate((dot(L, -Dir) - CosOuterCone) "
        "InvCosConeDifference)); USpotLightComponent::GetHalfConeAngle (outer clamped to "
        "[inner + 0.001 rad, 89 deg + 0.001 rad], inner to [0, 89 deg]); "
        "CapsuleLightIntegrate.ush SphereHorizonCosWrap (SourceRadius)"
    )
    size_effect = (
        "SourceRadius wraps the diffuse cosine near the horizon (SphereHorizonCosWrap, "
        "sin^2 a = SourceRadius^2/d^2); SourceLength makes a capsule: attenfit hands out 0"
    )
    cone_props = (("InnerConeAngle", 0.0, 89.0), ("OuterConeAngle", 0.0, 90.0))
    cone_outer = "OuterConeAngle"
    range_prop = "AttenuationRadius"
    # ULocalLightComponent AttenuationRadius and SourceRadius in cm; UPointLightComponent
    # LightFalloffExponent meta (UIMin 2, UIMax 16); intensity_scale: the exponent mode's
    # Intensity (a brightness scale, no unit) relative to the light's
    search_props = (
        ("AttenuationRadius", "range", 100.0, 0.0, math.inf),
        ("LightFalloffExponent", "decay", 1.0, 2.0, 16.0),
        ("intensity_scale", "scale", 1.0, 0.0, math.inf),
        ("SourceRadius", "size", 100.0, 0.0, math.inf),
    )
    # ULightComponent Intensity with IntensityUnits = Candelas (PointLightComponent.cpp
    # ComputeLightBrightness: x 100 x 100 for its centimetres, undone by the 1/d^2 in cm)
    intensity_prop = "Intensity"

    @classmethod
    def distance(cls, d, props):
        R = float(props["AttenuationRadius"]) / 100.0  # cm -> m
        dsq = d * d
        if props.get("bUseInverseSquaredFalloff", True):
            return _window4(d, R) / (dsq + 1e-4)  # DistBiasSqr = 1 cm^2
        t = _sat(dsq * _f32(1.0 / (R * R)))
        return float(props.get("intensity_scale", 1.0)) * (1.0 - t) ** float(
            props["LightFalloffExponent"]
        )

    @classmethod
    def cone_cosines(cls, props: Props) -> tuple[float, float]:
        """(cos inner, cos outer) after `GetHalfConeAngle`'s clamps."""
        inner = min(max(float(props.get("InnerConeAngle", 0.0)), 0.0), 89.0) * math.pi / 180
        outer = float(props["OuterConeAngle"]) * math.pi / 180
        outer = min(max(outer, inner + 0.001), 89.0 * math.pi / 180 + 0.001)
        return _f32(math.cos(inner)), _f32(math.cos(outer))

    @classmethod
    def cone(cls, cos_s, props):
        ci, co = cls.cone_cosines(props)
        inv = _f32(1.0 / (ci - co))
        return _sat((cos_s - co) * inv) ** 2

    @classmethod
    def diffuse(cls, n_dot_l, d, props):
        r = float(props.get("SourceRadius", 0.0)) / 100.0
        if r <= 0:
            return np.maximum(n_dot_l, 0.0)
        sin_a = np.sqrt(_sat(r * r / (d * d)))
        low = np.maximum(n_dot_l, -sin_a)
        wrapped = (sin_a + low) ** 2 / (4 * np.maximum(sin_a, 1e-30))
        return np.maximum(np.where(n_dot_l < sin_a, wrapped, n_dot_l), 0.0)


class _ScaleOffsetCone(EngineWitness):
    """The `saturate(c scale + offset)^2` cone shared by Filament, Bevy, Unity and glTF.

    Its properties are `cone_inner` and `cone_outer`: half-angles in radians within
    [0, pi/2] (`cone_props` derived so) unless a subclass states its own `cone_props`;
    their cosines are the float32 cosines the engine's CPU side computes (Bevy's light.rs,
    glTF's reference) unless a subclass states its own `cone_cosines` (Filament's
    fast::cos, Unity's full angles in degrees)."""

    cone_floor: ClassVar[float]
    cone_inner: ClassVar[str]
    #: the floor of d^2 in the engine's 1/d^2 (a punctual light's centimetre, or HALF_MIN)
    d2_floor: ClassVar[float] = 1e-4

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "range_prop" in cls.__dict__:  # the window's range, no bound but > 0
            cls.search_props = ((str(cls.range_prop), "range", 1.0, 0.0, math.inf),)
        if "cone_props" not in cls.__dict__:
            cls.cone_props = tuple(
                (n, 0.0, 0.5 * math.pi) for n in (cls.cone_inner, cls.cone_outer)
            )

    @classmethod
    def distance(cls, d, props):
        return _window4(d, float(props[cls.range_prop])) / np.maximum(d * d, cls.d2_floor)

    @classmethod
    def cone_cosines(cls, props: Props) -> tuple[float, float]:
        """(cos inner, cos outer) as the engine computes them (class docstring)."""
        inner = float(props.get(cls.cone_inner, 0.0))
        return _f32(math.cos(inner)), _f32(math.cos(float(props[str(cls.cone_outer)])))

    @classmethod
    def cone(cls, cos_s, props):
        scale, offset = _scale_offset(*cls.cone_cosines(props), cls.cone_floor)
        return _sat(cos_s * scale + offset) ** 2


@final
class FilamentWitness(_ScaleOffsetCone):
    name = "filament"
    source = (
        "Filament shaders/src/surface_light_punctual.fs (light_punctual.fs): "
        "getDistanceAttenuation (attenuation / max(d^2, 1e-4)), getSquareFalloffAttenuation, "
        "getAngleAttenuation (saturate(cd scale + offset)^2); "
        "filament/src/components/LightManager.cpp FLightManager::setFalloff, "
        "setSpotLightCone (angles clamped to [0, pi/2], outer >= inner, fast::cos, "
        "scale = 1/max(1/1024, cosInner - cosOuter))"
    )
    size_effect = "Filament punctual lights have no size"
    cone_inner, cone_outer = "spot_inner", "spot_outer"
    cone_floor = 1.0 / 1024.0
    range_prop = "falloff"
    # LightManager::Builder::intensityCandela
    intensity_prop = "intensityCandela"

    @classmethod
    def cone_cosines(cls, props):
        inner = min(abs(float(props.get("spot_inner", 0.0))), math.pi / 2)
        outer = min(abs(float(props["spot_outer"])), math.pi / 2)
        outer = max(inner, outer)
        return float(fast_cos(inner)), float(fast_cos(outer))


@final
class BevyWitness(_ScaleOffsetCone):
    name = "bevy"
    source = (
        "Bevy crates/bevy_pbr/src/render/pbr_lighting.wgsl: getDistanceAttenuation "
        "(max(d^2, 1e-4)), spot_light (saturate(cd scale + offset)^2); "
        "crates/bevy_pbr/src/render/light.rs (spot_scale = 1/max(cos inner - cos outer, "
        "1e-4)); point_light's radius moves the specular representative point only"
    )
    size_effect = "radius shapes the specular term only (representative point); diffuse unchanged"
    cone_inner, cone_outer = "inner_angle", "outer_angle"
    cone_floor = 1e-4
    range_prop = "range"
    # PointLight / SpotLight `intensity` in lumens: a point light's 4 pi lm per candela
    intensity_per_cd = 4.0 * math.pi


@final
class UnityWitness(_ScaleOffsetCone):
    name = "unity"
    source = (
        "Unity URP ShaderLibrary/RealtimeLights.hlsl: DistanceAttenuation "
        "(rcp(max(d^2, HALF_MIN)) x saturate(1 - (d^2/range^2)^2)^2), AngleAttenuation "
        "(saturate(SdotL x + y)^2); UniversalRenderPipelineCore.cs "
        "GetPunctualLightDistanceAttenuation / GetSpotAngleAttenuation (full angles in "
        "degrees, halved; 1/max(0.001, cosInner - cosOuter))"
    )
    size_effect = "URP punctual lights have no size in the diffuse term"
    cone_props = (("innerSpotAngle", 0.0, 179.0), ("spotAngle", 1.0, 179.0))
    cone_inner, cone_outer = "innerSpotAngle", "spotAngle"
    cone_floor = 0.001
    range_prop = "range"
    d2_floor = 2.0**-14

    @classmethod
    def cone_cosines(cls, props):
        outer = math.radians(float(props["spotAngle"])) / 2
        inner = math.radians(float(props.get("innerSpotAngle", 0.0))) / 2
        return _f32(math.cos(inner)), _f32(math.cos(outer))


@final
class GltfWitness(_ScaleOffsetCone):
    name = "gltf"
    source = (
        "KHR_lights_punctual README.md: Range Property (recommended "
        "max(min(1 - (d/range)^4, 1), 0)/d^2; range undefined: 1/d^2) and Spot, Inner and "
        "Outer Cone Angles (lightAngleScale = 1/max(0.001, cos inner - cos outer), "
        "saturate(cd scale + offset)^2)"
    )
    size_effect = "glTF punctual lights have no size"
    cone_inner, cone_outer = "innerConeAngle", "outerConeAngle"
    cone_floor = 0.001
    range_prop = "range"

    @classmethod
    def distance(cls, d, props):
        R = props.get("range")
        f = 1.0 / (d * d)
        if R is None or not math.isfinite(float(R)) or float(R) <= 0:
            return f
        return np.maximum(np.minimum(1.0 - (d / float(R)) ** 4, 1.0), 0.0) * f


WITNESSES: tuple[type[EngineWitness], ...] = (
    GodotWitness,
    ThreeJSWitness,
    UnrealWitness,
    FilamentWitness,
    BevyWitness,
    UnityWitness,
    GltfWitness,
)


def get_witness(name: str) -> type[EngineWitness]:
    """The witness of the engine called `name`."""
    for w in WITNESSES:
        if w.name == name:
            return w
    raise KeyError(name)


def engine_receiver_errors(
    witness: type[EngineWitness],
    props: Props,
    *,
    d: np.ndarray,
    cos_s: np.ndarray,
    n_dot_l: np.ndarray,
    spot: bool,
    intensity: float,
    E_true: np.ndarray,
    denom: np.ndarray,
    precision: str = "float64",
) -> np.ndarray:
    """|E_engine - E_true| / denom at a scene's receivers (the scene's judged error), with
    `E_engine = intensity * witness.render(..., precision)` (the scene's precision: what
    the answer claims; `intensity` the one `props` states, if it does:
    `EngineWitness.intensity_of`); inf where it is not finite."""
    E = witness.intensity_of(props, intensity) * witness.render(
        props, d, cos_s, n_dot_l, spot, precision
    )
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        err = np.abs(E - E_true) / denom
    return np.where(np.isfinite(err), err, np.inf)
