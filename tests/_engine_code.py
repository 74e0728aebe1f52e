"""Each engine's shading of a punctual light, transcribed for the tests from the engine's own
code (file and function cited per engine), written here scalar by scalar, independently of
attenfit's engine witness (`attenfit._judge._engine_shading`): `RENDER[engine](props, d,
c, nl, spot)` is the irradiance per unit intensity the engine draws at distance `d`, cosine
`c` from the spot's axis and `nl` (n.l), from the properties attenfit hands out.

Constants the engine computes on its CPU side in float32 (cosines, reciprocals) are rounded
to float32 here as they are there; the shading itself is float64.
"""

from __future__ import annotations

import math

import numpy as np

#: a spot over a floor (`str.format` it: umbra, penumbra, profile, extent, resolution)
SPOT_TOML = """
tolerance = 0.05
[[lights]]
kind = "spot"
radius = 0.05
height = 3.0
umbra = {umbra}
penumbra = {penumbra}
profile = "{profile}"
[[receivers]]
kind = "plane"
extent = {extent}
resolution = {resolution}
"""


def _f32(x: float) -> float:
    return float(np.float32(x))


def _clamp01(x: float) -> float:
    return min(max(x, 0.0), 1.0)


def _lambert(nl: float) -> float:
    return max(nl, 0.0)


# Godot 4 servers/rendering/renderer_rd/shaders/scene_forward_lights_inc.glsl:
# get_omni_attenuation(distance, inv_range, decay); light_process_spot: scos = max(dot(-L,
# dir), cone_angle); spot_rim = max(0.0001, (1 - scos) / (1 - cone_angle)); spot_attenuation
# *= 1 - pow(spot_rim, inv_spot_attenuation); size_A = 1 - 1/sqrt(1 + (size/max(0.001, d))^2)
# feeds light_compute's NdotL = min(A + dot(N, L), 1). storage_rd/light_storage.cpp
# update_light_buffers: inv_radius = 1/max(0.001, range); cos_spot_angle =
# cos(deg_to_rad(spot_angle)); inv_spot_attenuation = 1/spot_attenuation.
def godot(p, d, c, nl, spot):
    k = "spot" if "spot_range" in p else "omni"
    inv_range = _f32(1.0 / max(0.001, p[f"{k}_range"]))
    nd = d * inv_range
    nd *= nd
    nd *= nd
    nd = max(1.0 - nd, 0.0)
    nd *= nd
    att = nd * max(d, 0.0001) ** (-p[f"{k}_attenuation"])
    if spot:
        cone_angle = _f32(math.cos(math.radians(p["spot_angle"])))
        scos = max(c, cone_angle)
        rim = max(0.0001, (1.0 - scos) / (1.0 - cone_angle))
        att *= 1.0 - rim ** _f32(1.0 / p["spot_angle_attenuation"])
    size = p.get("light_size", 0.0)
    if size > 0:
        t = size / max(0.001, d)
        a = max(0.0, 1.0 - 1.0 / math.sqrt(1.0 + t * t))
        return att * max(min(a + nl, 1.0), 0.0)
    return att * _lambert(nl)


# three.js src/renderers/shaders/ShaderChunk/lights_pars_begin.glsl.js: getDistanceAttenuation
# (1/max(pow(d, decay), 0.01), times pow2(saturate(1 - pow4(d/cutoff))) when cutoff > 0),
# getSpotAttenuation = smoothstep(coneCos, penumbraCos, angleCos); src/renderers/webgl/
# WebGLLights.js: coneCos = cos(angle), penumbraCos = cos(angle * (1 - penumbra)).
def threejs(p, d, c, nl, spot):
    f = 1.0 / max(d ** p["decay"], 0.01)
    if p.get("distance", 0.0) > 0:
        f *= _clamp01(1.0 - (d / p["distance"]) ** 4) ** 2
    if spot:
        e0 = _f32(math.cos(p["angle"]))
        e1 = _f32(math.cos(p["angle"] * (1.0 - p.get("penumbra", 0.0))))
        if e1 == e0:
            f *= 1.0 if c >= e0 else 0.0
        else:
            t = _clamp01((c - e0) / (e1 - e0))
            f *= t * t * (3.0 - 2.0 * t)
    return f * _lambert(nl)


# Unreal (described, not copied): DeferredLightingCommon.ush GetLocalLightAttenuation: with
# inverse-squared falloff 1/(DistSqr + 1 cm^2) x Square(saturate(1 - Square(DistSqr x
# InvRadius^2))); else pow(1 - saturate(DistSqr InvRadius^2), FalloffExponent)
# (DynamicLightingCommon.ush RadialAttenuation). SpotAttenuation: Square(saturate((cos -
# CosOuterCone) / (CosInnerCone - CosOuterCone))); USpotLightComponent::GetHalfConeAngle
# clamps inner to [0, 89 deg] and outer to [inner + 0.001 rad, 89 deg + 0.001 rad].
# CapsuleLightIntegrate.ush SphereHorizonCosWrap(NoL, SinAlphaSqr) for SourceRadius.
def unreal(p, d, c, nl, spot):
    R = p["AttenuationRadius"] / 100.0
    if p.get("bUseInverseSquaredFalloff", True):
        f = _clamp01(1.0 - (d * d / (R * R)) ** 2) ** 2 / (d * d + 1e-4)
    else:
        f = (
            p.get("intensity_scale", 1.0)
            * (1.0 - _clamp01(d * d / (R * R))) ** p["LightFalloffExponent"]
        )
    if spot:
        inner = math.radians(min(max(p.get("InnerConeAngle", 0.0), 0.0), 89.0))
        outer = math.radians(p["OuterConeAngle"])
        outer = min(max(outer, inner + 0.001), math.radians(89.0) + 0.001)
        ci, co = _f32(math.cos(inner)), _f32(math.cos(outer))
        f *= _clamp01((c - co) / (ci - co)) ** 2
    r = p.get("SourceRadius", 0.0) / 100.0
    if r > 0:
        sin_a = math.sqrt(_clamp01(r * r / (d * d)))
        if nl < sin_a:  # SphereHorizonCosWrap
            x = max(nl, -sin_a)
            return f * max((sin_a + x) ** 2 / (4.0 * sin_a), 0.0)
    return f * _lambert(nl)


def _frostbite_window(d: float, R: float) -> float:
    return _clamp01(1.0 - (d * d / (R * R)) ** 2) ** 2


# Filament libs/math/include/math/fast.h: cos(x) (a parabola, in float32).
def _fast_cos(x: float) -> float:
    x = np.float32(x) * np.float32(1.0 / (2.0 * math.pi))
    x -= np.float32(0.25) + np.floor(x + np.float32(0.25))
    x *= np.float32(16.0) * abs(x) - np.float32(8.0)
    x += np.float32(0.225) * x * (abs(x) - np.float32(1.0))
    return float(x)


# Filament shaders/src/light_punctual.fs: getSquareFalloffAttenuation, getDistanceAttenuation
# (attenuation / max(distanceSquare, 1e-4)), getAngleAttenuation (saturate(cd scale +
# offset)^2); filament/src/components/LightManager.cpp FLightManager::setSpotLightCone
# (angles clamped to [0, pi/2], outerClamped = max(inner, outer), fast::cos, scale = 1 /
# max(1/1024, cosInner - cosOuter), offset = -cosOuter scale).
def filament(p, d, c, nl, spot):
    f = _frostbite_window(d, p["falloff"]) / max(d * d, 1e-4)
    if spot:
        inner = min(abs(p.get("spot_inner", 0.0)), math.pi / 2)
        outer = max(inner, min(abs(p["spot_outer"]), math.pi / 2))
        co, ci = _fast_cos(outer), _fast_cos(inner)
        scale = _f32(1.0 / max(1.0 / 1024.0, ci - co))
        offset = _f32(-co * scale)  # stored as a float, as scale is
        f *= _clamp01(c * scale + offset) ** 2
    return f * _lambert(nl)


# Bevy crates/bevy_pbr/src/render/pbr_lighting.wgsl getDistanceAttenuation (window /
# max(d^2, 0.0001)) and the spot factor saturate(cd * spot_scale + spot_offset)^2;
# crates/bevy_pbr/src/render/light.rs: spot_scale = 1/max(cos(inner) - cos(outer), 1e-4),
# spot_offset = -cos(outer) * spot_scale. The radius moves the specular point only.
def bevy(p, d, c, nl, spot):
    f = _frostbite_window(d, p["range"]) / max(d * d, 1e-4)
    if spot:
        co = _f32(math.cos(p["outer_angle"]))
        ci = _f32(math.cos(p.get("inner_angle", 0.0)))
        scale = _f32(1.0 / max(ci - co, 1e-4))
        f *= _clamp01(c * scale + _f32(-co * scale)) ** 2  # the offset: a float too
    return f * _lambert(nl)


# Unity URP ShaderLibrary/RealtimeLights.hlsl DistanceAttenuation (rcp(max(d^2, HALF_MIN)) x
# saturate(1 - (d^2/range^2)^2)^2) and AngleAttenuation (saturate(SdotL x + y)^2);
# UniversalRenderPipelineCore.cs GetSpotAngleAttenuation: the full angles in degrees,
# halved; invAngleRange = 1/max(0.001, cosInner - cosOuter), y = -cosOuter invAngleRange.
def unity(p, d, c, nl, spot):
    f = _frostbite_window(d, p["range"]) / max(d * d, 2.0**-14)
    if spot:
        co = _f32(math.cos(math.radians(p["spotAngle"]) / 2.0))
        ci = _f32(math.cos(math.radians(p.get("innerSpotAngle", 0.0)) / 2.0))
        inv = _f32(1.0 / max(0.001, ci - co))
        f *= _clamp01(c * inv + _f32(-co * inv)) ** 2  # y = -cosOuter invAngleRange: a float
    return f * _lambert(nl)


# KHR_lights_punctual README.md, "Range Property": max(min(1 - (d/range)^4, 1), 0) / d^2,
# range undefined: 1/d^2; "Inner and Outer Cone Angles": lightAngleScale = 1/max(0.001,
# cos(inner) - cos(outer)), lightAngleOffset = -cos(outer) lightAngleScale,
# saturate(cd scale + offset)^2.
def gltf(p, d, c, nl, spot):
    f = 1.0 / (d * d)
    R = p.get("range")
    if R is not None and math.isfinite(R) and R > 0:
        f *= max(min(1.0 - (d / R) ** 4, 1.0), 0.0)
    if spot:
        co = _f32(math.cos(p["outerConeAngle"]))
        ci = _f32(math.cos(p.get("innerConeAngle", 0.0)))
        scale = _f32(1.0 / max(0.001, ci - co))
        f *= _clamp01(c * scale + _f32(-co * scale)) ** 2  # the offset: a float too
    return f * _lambert(nl)


RENDER = {
    "godot": godot,
    "threejs": threejs,
    "unreal": unreal,
    "filament": filament,
    "bevy": bevy,
    "unity": unity,
    "gltf": gltf,
}


def engine_rendered_errors(scene, choices, engine: str):
    """Per light with an engine answer: (choice, the worst error of what `engine` draws with
    the choice's `properties`, rendered by `RENDER` above, at the light's judged receivers:
    attenfit's ground truth for `scene`, those above the range's threshold with a range)."""
    from attenfit._scenes._light_fits import light_data

    render = RENDER[engine]
    out = []
    for truth, c in zip(scene.ground_truth(), choices, strict=True):
        if c.engine_error is None or "light_type" in c.properties:
            continue  # an engine's own area light: re-judged in tests/test_engine_area.py
        light = scene.lights[c.light]
        x = light_data(scene, truth)
        keep = np.ones(len(x.d), bool)
        if c.range and c.range.get("range"):
            keep = x.E_true > c.range["threshold"]
        to_l = np.asarray(light.position, float)[None, :] - x.points[keep]
        d = np.linalg.norm(to_l, axis=1)
        lv = to_l / d[:, None]
        n = x.normals[keep] / np.linalg.norm(x.normals[keep], axis=1, keepdims=True)
        spot = light.is_spot or light.kind in ("disk", "rect")  # answered as a spot
        axis = np.asarray(light.direction if light.is_spot else light.normal, float)
        cs = -(lv @ (axis / np.linalg.norm(axis)))
        nl = np.sum(n * lv, axis=1)
        p = c.properties
        # a rect's or tube's stand-in states its intensity (the engines' own names and units)
        per_cd = {"bevy": ("intensity", 4 * np.pi), "godot": ("light_energy", 1.0),
                  "unreal": ("Intensity", 1.0), "filament": ("intensityCandela", 1.0)}  # fmt: skip
        name, unit = per_cd.get(engine, ("intensity", 1.0))
        intensity = p[name] / unit if name in p else light.intensity
        E = intensity * np.array(
            [render(p, a, b, e, spot) for a, b, e in zip(d, cs, nl, strict=True)]
        )
        with np.errstate(all="ignore"):
            err = np.abs(E - x.E_true[keep]) / x.denom[keep]
        out.append((c, float(np.max(np.where(np.isfinite(err), err, np.inf)))))
    return out
