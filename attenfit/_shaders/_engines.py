"""The engines' own attenuation functions, hand-transcribed, to compile beside attenfit's
shader forms (`python -m benchmarks shader`, docs/shaders.md): what an engine pays.

Each snippet is the engine's function as its source writes it (Unreal's is described, not
copied: Epic's EULA), with its uniforms (1/r^2, 1/range, ...) baked in as float32 literals
computed as the engine's CPU side does, and a wrapper `float engine(float d)`. One text
serves GLSL and CUDA: a prelude per language defines `FN`, `saturate` and `clamp`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping

import numpy as np

from ._text import float32_literal

__all__ = ["ENGINE_SNIPPETS", "EngineSnippet", "engine_source"]


@dataclasses.dataclass(frozen=True)
class EngineSnippet:
    """An engine's function (`source`: file and function), `code(params) -> text`."""

    family: str
    source: str
    code: Callable[[Mapping[str, float]], str]


def _f(x: float) -> str:
    return float32_literal(float(np.float32(x))) + "f"


ENGINE_SNIPPETS: dict[str, EngineSnippet] = {}


def _snippet(family: str, source: str):
    def deco(code: Callable[[Mapping[str, float]], str]):
        ENGINE_SNIPPETS[family] = EngineSnippet(family, source, code)
        return code

    return deco


@_snippet("unreal_epsilon", "Unreal CapsuleLightIntegrate.ush (point light: capsule length 0)")
def _unreal_epsilon(p):
    return f"""FN float engine(float d) {{
    float DistSqr = d * d;
    return 1.0f / (DistSqr + {_f(p["eps"])});  // DistBiasSqr
}}"""


@_snippet("yuksel", "Blender eevee_light_lib.glsl::light_point_light")
def _yuksel(p):
    return f"""FN float engine(float dist) {{
    float d_sqr = dist * dist;
    float r_sqr = {_f(p["r"] ** 2)};  // light.radius_squared
    return 2.0f / (d_sqr + r_sqr + dist * sqrt(d_sqr + r_sqr));
}}"""


@_snippet("polynomial", "Ogre Media/RTShaderLib/RTSLib_Lighting.glsl::getDistanceAttenuation")
def _polynomial(p):
    return f"""FN float engine(float d) {{
    return 1.0f / ({_f(p["kc"])} + {_f(p["kl"])} * d + {_f(p["kq"])} * d * d);
}}"""


@_snippet(
    "unreal_window",
    "Unreal DeferredLightingCommon.ush::GetLocalLightAttenuation x CapsuleLightIntegrate.ush",
)
def _unreal_window(p):
    return f"""FN float engine(float d) {{
    float DistanceSqr = d * d;
    float InvRadius = {_f(1 / p["r_max"])};
    float t = DistanceSqr * (InvRadius * InvRadius);
    float LightMask = saturate(1.0f - t * t);
    LightMask *= LightMask;
    float Falloff = 1.0f / (DistanceSqr + {_f(p["eps"])});
    return Falloff * LightMask;
}}"""


@_snippet(
    "frostbite_window",
    "Filament light_punctual.fs::getSquareFalloffAttenuation, getDistanceAttenuation",
)
def _filament(p):
    return f"""FN float getSquareFalloffAttenuation(float distanceSquare, float falloff) {{
    float factor = distanceSquare * falloff;
    float smoothFactor = saturate(1.0f - factor * factor);
    return smoothFactor * smoothFactor;
}}
FN float engine(float d) {{
    float distanceSquare = d * d;
    float attenuation = getSquareFalloffAttenuation(distanceSquare, {_f(1 / p["r_max"] ** 2)});
    return attenuation * 1.0f / max(distanceSquare, {_f(p["r_min"] ** 2)});
}}"""


@_snippet("godot", "Godot scene_forward_lights_inc.glsl::get_omni_attenuation")
def _godot(p):
    return f"""FN float get_omni_attenuation(float distance, float inv_range, float decay) {{
    float nd = distance * inv_range;
    nd *= nd;
    nd *= nd;
    nd = max(1.0f - nd, 0.0f);
    nd *= nd;
    return nd * pow(max(distance, 0.0001f), -decay);
}}
FN float engine(float d) {{ return get_omni_attenuation(d, {_f(1 / p["r_max"])}, {_f(p["a"])}); }}"""


@_snippet("cryengine_linear", "CRYENGINE shadeLib.cfi::GetPhysicalLightAttenuation")
def _cryengine(p):
    return f"""FN float GetPhysicalLightAttenuation(float d, float radius, float invRadius, float attenuationBulbSize) {{
    float fadeoutFactor = saturate((radius - d) * (invRadius / 0.2f));
    float denom = 1.0f + max(d - attenuationBulbSize, 0.0f) / attenuationBulbSize;
    return fadeoutFactor * fadeoutFactor / (denom * denom);
}}
FN float engine(float d) {{
    return GetPhysicalLightAttenuation(d, {_f(p["r_max"])}, {_f(1 / p["r_max"])}, {_f(p["r_min"])});
}}"""


@_snippet("unreal_exponent", "Unreal DynamicLightingCommon.ush::RadialAttenuation")
def _unreal_exponent(p):
    return f"""FN float engine(float d) {{
    float v = d * {_f(1 / p["r_max"])};  // WorldLightVector = ToLight * InvRadius
    float NormalizeDistanceSquared = v * v;
    return pow(1.0f - saturate(NormalizeDistanceSquared), {_f(p["p"])});
}}"""


@_snippet("threejs", "three.js lights_pars_begin.glsl.js::getDistanceAttenuation")
def _threejs(p):
    return f"""FN float pow2(float x) {{ return x * x; }}
FN float pow4(float x) {{ float x2 = x * x; return x2 * x2; }}
FN float getDistanceAttenuation(float lightDistance, float cutoffDistance, float decayExponent) {{
    float distanceFalloff = 1.0f / max(pow(lightDistance, decayExponent), 0.01f);
    if (cutoffDistance > 0.0f) {{
        distanceFalloff *= pow2(saturate(1.0f - pow4(lightDistance / cutoffDistance)));
    }}
    return distanceFalloff;
}}
FN float engine(float d) {{ return getDistanceAttenuation(d, {_f(p["cutoff"])}, {_f(p["decay"])}); }}"""


@_snippet("gltf_range", "glTF-Sample-Viewer punctual.glsl::getRangeAttenuation")
def _gltf(p):
    return f"""FN float getRangeAttenuation(float range, float distance) {{
    if (range <= 0.0f) {{
        return 1.0f / pow(distance, 2.0f);
    }}
    return max(min(1.0f - pow(distance / range, 4.0f), 1.0f), 0.0f) / pow(distance, 2.0f);
}}
FN float engine(float d) {{ return getRangeAttenuation({_f(p["range"])}, d); }}"""


_PRELUDE = {
    "glsl": "#define FN\n#define saturate(x) clamp(x, 0.0, 1.0)\n",
    "cuda": "#define FN __device__\n#define saturate(x) __saturatef(x)\n",
}


def engine_source(family: str, params: Mapping[str, float], lang: str) -> str:
    """The engine snippet of `family` with `params` baked in, as GLSL or CUDA."""
    return _PRELUDE[lang] + ENGINE_SNIPPETS[family].code(params) + "\n"


def engine_table(families: Mapping[str, object]) -> list[dict[str, object]]:
    """Per family (name -> instance): SPIR-V and SASS counts of its shader form, its stable
    form and, where an engine ships one, the engine's snippet, and the SPIR-V ratio of the
    shader form to the engine's code. Counts are None where a compiler is not installed."""
    from ._compilers import compiled_cost, sass_counts, spirv_counts
    from ._export import scalar_params

    rows: list[dict[str, object]] = []
    for name, fam in families.items():
        shader = compiled_cost(fam)
        stable = compiled_cost(fam, form="stable")
        row: dict[str, object] = {"family": name, "shader": shader, "stable": stable}
        if name in ENGINE_SNIPPETS:
            p = scalar_params(fam)  # type: ignore[arg-type]
            spv = spirv_counts(engine_source(name, p, "glsl"), "engine")
            sass = sass_counts(engine_source(name, p, "cuda"), "engine")
            row.update(engine=ENGINE_SNIPPETS[name].source, engine_spirv=spv, engine_sass=sass)
            if spv is not None and shader.spirv is not None and shader.form == "shader":
                row["ratio"] = shader.spirv.total / spv.total
        rows.append(row)
    return rows
