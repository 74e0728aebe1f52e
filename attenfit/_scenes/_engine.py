"""What each engine can express (`--engine NAME`): its attenuation families, the parameters
it fixes, its spot falloff, its default range, and the light properties a fitted family
becomes in it. Sources: each engine's code as transcribed in `shared/reference/engines.md`
(and attenfit's families, whose docstrings cite the same functions)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from typing import Any

from .._errors import UnknownNameError
from .._judge import EngineWitness, get_witness
from ._types import SceneLight

__all__ = ["ENGINES", "Engine", "get_engine"]

Props = Callable[[str, Mapping[str, float], SceneLight, Mapping[str, float] | None], dict[str, Any]]


@dataclasses.dataclass(frozen=True)
class Engine:
    """One engine: `families` it can express, `fixed` parameters per family (not fitted),
    the spot falloffs it uses (None: attenfit's two, when its own is not one of them), its
    default range (None: no window by default), and `properties(family, params, light,
    spot)`: the engine's own light properties. `source` cites the engine's code."""

    name: str
    families: tuple[str, ...]
    fixed: Mapping[str, Mapping[str, float]]
    spot_falloffs: tuple[str, ...] | None
    default_range: float | None
    source: str
    properties: Props
    note: str = ""
    #: the property through which a light's size reaches the engine's diffuse term (tried
    #: at 0 and at the light's radius by `_engine_fit`), None where none does
    size_prop: str | None = None
    #: the size property's unit per metre (Unreal's centimetres: 100)
    size_unit: float = 1.0

    @property
    def witness(self) -> type[EngineWitness]:
        """The engine's own shading (`attenfit._judge._engine_shading`), which judges its answers."""
        return get_witness(self.name)


def _godot(family, p, light, spot):
    # Godot 4 OmniLight3D/SpotLight3D (doc/classes/*.xml): omni_attenuation / spot_attenuation
    # is the exponent `a` of get_omni_attenuation, omni_range / spot_range is r_max; a disk is
    # a SpotLight3D (spot_angle 90, spot_angle_attenuation 1: the cone 1 - rim^(1/1) is
    # exactly the disk's cosine); light_size starts at 0 (see _engine_fit)
    key = "spot" if spot is not None else "omni"
    out: dict[str, Any] = {f"{key}_attenuation": p["a"], f"{key}_range": p["r_max"]}
    if spot is not None:
        out["spot_angle"] = spot["umbra"]
        out["spot_angle_attenuation"] = 1.0
    out["light_size"] = 0.0
    return out


def _threejs(family, p, light, spot):
    # three.js PointLight/SpotLight: `decay`, `distance` (the cutoff); SpotLight `angle` (rad)
    # and `penumbra` with penumbraCos = cos(angle (1 - penumbra)) (WebGLLights.js)
    out: dict[str, Any] = {"decay": p["decay"], "distance": p["cutoff"]}
    if spot is not None:
        out["angle"] = math.radians(spot["umbra"])
        out["penumbra"] = 1.0 - spot["penumbra"] / spot["umbra"]
    return out


def _unreal(family, p, light, spot):
    # UPointLightComponent: AttenuationRadius and SourceRadius in cm (Unreal units); the
    # inverse-squared mode's 1/(d^2 + 1 cm^2) is fixed (CapsuleLightIntegrate.ush DistBiasSqr)
    out: dict[str, Any] = {"AttenuationRadius": 100.0 * p["r_max"]}
    if family == "unreal_window":
        out.update(bUseInverseSquaredFalloff=True, SourceRadius=0.0, SourceLength=0.0)
    else:
        out.update(
            bUseInverseSquaredFalloff=False,
            LightFalloffExponent=p["p"],
            intensity_scale=p["scale"],  # the exponent mode's brightness (no 1/d^2): I x scale
        )
    if spot is not None:
        out.update(OuterConeAngle=spot["umbra"], InnerConeAngle=spot["penumbra"])
    return out


def _cone(out: dict[str, Any], light: SceneLight, spot, inner: str, outer: str) -> dict[str, Any]:
    if spot is not None:
        out[outer] = math.radians(spot["umbra"])
        out[inner] = math.radians(spot["penumbra"])
    return out


def _filament(family, p, light, spot):
    # LightManager::Builder::falloff(radius) and spotLightCone(inner, outer) in radians
    return _cone({"falloff": p["r_max"]}, light, spot, "spot_inner", "spot_outer")


def _bevy(family, p, light, spot):
    # PointLight / SpotLight `range` and `radius` (the radius shapes specular only)
    out: dict[str, Any] = {"range": p["r_max"], "radius": light.radius}
    return _cone(out, light, spot, "inner_angle", "outer_angle")


def _unity(family, p, light, spot):
    # Light.range (URP: distanceAttenuation.x = 1/range^2); Light.spotAngle and
    # innerSpotAngle are full angles in degrees
    out: dict[str, Any] = {"range": p["r_max"]}
    if spot is not None:
        out.update(spotAngle=2 * spot["umbra"], innerSpotAngle=2 * spot["penumbra"])
    return out


def _gltf(family, p, light, spot):
    # KHR_lights_punctual: `range`; spot.innerConeAngle / outerConeAngle in radians
    return _cone({"range": p["range"]}, light, spot, "innerConeAngle", "outerConeAngle")


_FILAMENT_R_MIN = 0.01  # max(d^2, 1e-4): light_punctual.fs::getDistanceAttenuation
ENGINES: dict[str, Engine] = {
    e.name: e
    for e in (
        Engine(
            "godot",
            ("godot",),
            {},
            None,
            5.0,
            "Godot 4 scene_forward_lights_inc.glsl::get_omni_attenuation; OmniLight3D.xml "
            "(omni_range default 5)",
            _godot,
            "Godot's spot cone (1 - rim^(1/spot_angle_attenuation)) is not an attenfit "
            "falloff: spot_angle and spot_angle_attenuation are fitted through Godot's own "
            "cone (the engine witness)",
            "light_size",
        ),
        Engine(
            "threejs",
            ("threejs",),
            {},
            ("threejs",),
            None,
            "three.js lights_pars_begin.glsl.js::getDistanceAttenuation (distance 0 = no "
            "cutoff); spot smoothstep(cos(angle), cos(angle (1 - penumbra)), c)",
            _threejs,
        ),
        Engine(
            "unreal",
            ("unreal_window", "unreal_exponent"),
            {"unreal_window": {"eps": 1e-4}},
            ("frostbite",),
            10.0,
            "Unreal DeferredLightingCommon.ush::GetLocalLightAttenuation, "
            "CapsuleLightIntegrate.ush (DistBiasSqr 1 cm^2), DynamicLightingCommon.ush::"
            "RadialAttenuation; AttenuationRadius default 1000 cm",
            _unreal,
            "the outer cone is clamped to 89 deg + 0.001 rad (USpotLightComponent::"
            "GetHalfConeAngle): a wider spot or a disk's hemisphere is cut there",
            "SourceRadius",
            100.0,
        ),
        Engine(
            "filament",
            ("frostbite_window",),
            {"frostbite_window": {"r_min": _FILAMENT_R_MIN}},
            ("frostbite",),
            1.0,
            "Filament light_punctual.fs::getDistanceAttenuation (max(d^2, 1e-4)); "
            "LightManager.h falloff default 1 m",
            _filament,
            "spot cones: FLightManager::setSpotLightCone takes its cosines with fast::cos "
            "(about 1e-3 off the cosine), which the engine witness renders",
        ),
        Engine(
            "bevy",
            ("frostbite_window",),
            {"frostbite_window": {"r_min": _FILAMENT_R_MIN}},
            ("frostbite",),
            20.0,
            "Bevy pbr_lighting.wgsl::getDistanceAttenuation (max(d^2, 1e-4)); "
            "point_light.rs range default 20",
            _bevy,
        ),
        Engine(
            "unity",
            ("frostbite_window",),
            {"frostbite_window": {"r_min": 2.0**-7}},  # d^2 >= HALF_MIN = 2^-14
            ("frostbite",),
            None,
            "Unity URP RealtimeLights.hlsl::DistanceAttenuation (d^2 >= HALF_MIN = 2^-14)",
            _unity,
            "no default range recorded: the saving is against the file's range",
        ),
        Engine(
            "gltf",
            ("gltf_range",),
            {},
            ("frostbite",),
            None,
            "KHR_lights_punctual README, Range Property (range undefined = infinite); spot "
            "reference sat(c scale + offset)^2",
            _gltf,
        ),
    )
}


def get_engine(name: str) -> Engine:
    """The engine called `name` (an `UnknownNameError` listing the others)."""
    if name not in ENGINES:
        raise UnknownNameError(f"unknown engine {name!r}; allowed: {', '.join(ENGINES)}")
    return ENGINES[name]
