"""The engines' own area lights (issue 31 item 4, issue 29 (b)): each engine's area-light
shading transcribed here from its code, line by line, against attenfit's area witness
(`attenfit._judge._area_shading`) and the `unreal_rect` model; the example panel and batten
answered under --engine, their claimed error re-judged through these transcriptions; the
tube's point light no longer 98% dark; the write-back of an area light's properties.

Sources transcribed (read in the copies the search index stores):
* Unreal 4 `Engine/Shaders/Private/RectLight.ush` `RectIrradianceLambert`,
  `CapsuleLight.ush` `LineIrradiance` and `SphereHorizonCosWrap`,
  `CapsuleLightIntegrate.ush` `IntegrateBxDF(FCapsuleLight)`, `DeferredLightingCommon.ush`
  `GetLocalLightAttenuation` and `GetCapsule`, `FRectLightSceneProxy::
  GetLightShaderParameters` (folgerwang/UnrealEngine, chenyong2github/UnrealEngine);
* three.js `lights_physical_pars_fragment.glsl.js` `LTC_Evaluate` (tests/test_rect_models.py
  `three_ltc_evaluate_diffuse`) with `RE_Direct_RectArea_Physical`'s corners;
* Godot `servers/rendering/renderer_rd/shaders/area_lights_inc.glsl` `ltc_evaluate`,
  `clip_quad_to_horizon`, `integrate_edge`, and `scene_forward_lights_inc.glsl`
  `light_process_area` (godotengine/godot, PR #108219).
"""

from __future__ import annotations

import math
from pathlib import Path

import jax
import numpy as np
import pytest
from test_rect_models import three_ltc_evaluate_diffuse

from attenfit import area
from attenfit._curves import ClippedRect, UnrealRect
from attenfit._judge import best_intensity
from attenfit._judge._area_shading import (
    GodotAreaLight,
    ThreeRectAreaLight,
    UnrealRectLight,
    UnrealSourceLength,
)
from attenfit._scenes import Scene
from attenfit._scenes._engine_area import _geometry
from attenfit._scenes._light_fits import LightData
from attenfit._scenes._types import SceneLight

EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "scenes"


# ----------------------------------------------------------------------------- Unreal
def _sat(x):
    return min(max(x, 0.0), 1.0)


def _rsqrt(x):
    return 1.0 / math.sqrt(x)


def ue_sphere_horizon_cos_wrap(nol, sin_alpha_sqr):
    """CapsuleLight.ush SphereHorizonCosWrap (the Hermite spline branch)."""
    sin_alpha = math.sqrt(sin_alpha_sqr)
    if nol < sin_alpha:
        nol = max(nol, -sin_alpha)
        nol = (sin_alpha + nol) ** 2 / (4 * sin_alpha)
    return nol


def ue_light_mask(to_light, inv_radius, rect_direction=None):
    """DeferredLightingCommon.ush GetLocalLightAttenuation, inverse-squared mode."""
    dist_sqr = float(to_light @ to_light)
    mask = _sat(1 - (dist_sqr * inv_radius**2) ** 2) ** 2
    if rect_direction is not None:
        L = to_light * _rsqrt(dist_sqr)
        mask = 0.0 if rect_direction @ L < 0 else mask  # Rect normal points away from point
    return mask


def ue_rect_light(p, n, centre, emit, height_axis, props):
    """Unreal's rect light in its centimetres: FRectLightSceneProxy::GetLightShaderParameters
    (Color = Intensity 100^2 / (0.5 SourceWidth SourceHeight), Direction = -GetDirection(),
    Tangent the light's up), GetRect (Axis[1] = Tangent, Axis[2] = Direction, Axis[0] =
    cross), RectIrradianceLambert, GetLocalLightAttenuation; the irradiance in lux."""
    W, H = props["SourceWidth"], props["SourceHeight"]
    color = props["Intensity"] * 100.0 * 100.0 / (0.5 * W * H)
    direction = -np.asarray(emit, float)
    tangent = np.asarray(height_axis, float)
    axis = [np.cross(tangent, direction), tangent, direction]
    origin = (np.asarray(centre, float) - p) * 100.0  # ToLight, cm
    extent = (0.5 * W, 0.5 * H)
    local = [float(a @ origin) for a in axis]
    x0, x1 = local[0] - extent[0], local[0] + extent[0]
    y0, y1 = local[1] - extent[1], local[1] + extent[1]
    z0 = local[2]
    v = [np.array(c) for c in ((x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0))]
    L0, L1, L2, L3 = (c * _rsqrt(c[0] ** 2 + c[1] ** 2 + z0 * z0) for c in v)
    c01, c12, c23, c30 = L0 @ L1, L1 @ L2, L2 @ L3, L3 @ L0
    w01 = (1.5708 - 0.175 * c01) * _rsqrt(c01 + 1)
    w12 = (1.5708 - 0.175 * c12) * _rsqrt(c12 + 1)
    w23 = (1.5708 - 0.175 * c23) * _rsqrt(c23 + 1)
    w30 = (1.5708 - 0.175 * c30) * _rsqrt(c30 + 1)
    Lv = np.cross(L1, -w01 * L0 + w12 * L2) + np.cross(L3, w30 * L0 + -w23 * L2)
    Lv = Lv[0] * axis[0] + Lv[1] * axis[1] + Lv[2] * axis[2]
    length_sqr = Lv @ Lv
    inv_length = _rsqrt(length_sqr)
    base = 0.5 * length_sqr * inv_length
    nol = ue_sphere_horizon_cos_wrap(float(n @ (Lv * inv_length)), base * (1.0 / math.pi))
    mask = ue_light_mask(origin, 1.0 / props["AttenuationRadius"], direction)
    return color * base * nol * mask


def ue_capsule_light(p, n, centre, axis, props):
    """Unreal's point light with SourceLength and SourceRadius in centimetres: GetCapsule,
    IntegrateBxDF(FCapsuleLight) with LineIrradiance, SphereHorizonCosWrap, saturate, and
    the window; Color = Intensity 100^2 (Candelas)."""
    to_light = (np.asarray(centre, float) - p) * 100.0
    length, radius, bias = props["SourceLength"], props["SourceRadius"], 1.0
    pos0 = to_light - 0.5 * length * np.asarray(axis, float)
    pos1 = to_light + 0.5 * length * np.asarray(axis, float)
    if length > 0:
        inv0, inv1 = _rsqrt(pos0 @ pos0), _rsqrt(pos1 @ pos1)
        inv01 = inv0 * inv1
        cos_sub = (pos0 @ pos1) * inv01
        falloff = inv01 / (cos_sub * 0.5 + 0.5 + bias * inv01)
        nol = 0.5 * ((n @ pos0) * inv0 + (n @ pos1) * inv1)
    else:
        dist_sqr = pos0 @ pos0
        falloff = 1.0 / (dist_sqr + bias)
        nol = n @ (pos0 * _rsqrt(dist_sqr))
    if radius > 0:
        nol = ue_sphere_horizon_cos_wrap(nol, _sat(radius**2 * falloff))
    nol = _sat(nol)
    color = props["Intensity"] * 100.0 * 100.0
    return color * falloff * nol * ue_light_mask(to_light, 1.0 / props["AttenuationRadius"])


# ----------------------------------------------------------------------------- Godot
def _norm(v):
    return v / np.linalg.norm(v)


def godot_integrate_edge_hill(p0, p1):
    x = p0 @ p1
    y = abs(x)
    a = 5.42031 + (3.12829 + 0.0902326 * y) * y
    b = 3.45068 + (4.18814 + y) * y
    theta_sintheta = a / b
    if x < 0.0:
        theta_sintheta = math.pi / math.sqrt(1.0 - x * x) - theta_sintheta
    return theta_sintheta * np.cross(p0, p1)


def godot_integrate_edge(p_proj0, p_proj1, p0, p1):
    if p_proj0 @ p_proj1 < -1.0 + 0.00001:
        half = _norm(p0 + _norm(p1 - p0) * (p0 @ _norm(p0 - p1)))
        return (
            godot_integrate_edge_hill(p_proj0, half)[1]
            + godot_integrate_edge_hill(half, p_proj1)[1]
        )
    return godot_integrate_edge_hill(p_proj0, p_proj1)[1]


def godot_clip_quad_to_horizon(L):
    """area_lights_inc.glsl clip_quad_to_horizon, its sixteen cases (L: five vectors)."""
    config = sum(1 << i for i in range(4) if L[i][1] > 0.0)

    def cut(a, b):  # -L[a].y * L[b] + L[b].y * L[a], as the shader writes each case
        return -L[a][1] * L[b] + L[b][1] * L[a]

    n = 0
    if config == 1:
        n = 3
        L[1], L[2] = cut(1, 0), cut(3, 0)
    elif config == 2:
        n = 3
        L[0], L[2] = cut(0, 1), cut(2, 1)
    elif config == 3:
        n = 4
        L[2], L[3] = cut(2, 1), cut(3, 0)
    elif config == 4:
        n = 3
        L[0], L[1] = cut(3, 2), cut(1, 2)
    elif config == 6:
        n = 4
        L[0], L[3] = cut(0, 1), cut(3, 2)
    elif config == 7:
        n = 5
        L[4], L[3] = cut(3, 0), cut(3, 2)
    elif config == 8:
        n = 3
        L[0], L[1], L[2] = cut(0, 3), cut(2, 3), L[3].copy()
    elif config == 9:
        n = 4
        L[1], L[2] = cut(1, 0), cut(2, 3)
    elif config == 11:
        n = 5
        L[4] = L[3].copy()
        L[3], L[2] = cut(2, 3), cut(2, 1)
    elif config == 12:
        n = 4
        L[1], L[0] = cut(1, 2), cut(0, 3)
    elif config == 13:
        n = 5
        L[4], L[3] = L[3].copy(), L[2].copy()
        L[2], L[1] = cut(1, 2), cut(1, 0)
    elif config == 14:
        n = 5
        L[4], L[0] = cut(0, 3), cut(0, 1)
    elif config == 15:
        n = 4
    if n == 3:
        L[3] = L[0].copy()
    if n == 4:
        L[4] = L[0].copy()
    return n


def godot_area_light(p, nrm, centre, area_width, area_height, direction, props):
    """light_process_area's diffuse with ltc_evaluate(normal, eye_vec, mat3(1), points):
    nothing behind the light, get_omni_attenuation of the distance to the nearest point of
    the rectangle times that distance squared, and light_energy's pi (Godot's color x
    energy x pi, the convention of attenfit's Godot answers)."""
    if direction @ (p - centre) <= 0:
        return 0.0
    a_len, b_len = np.linalg.norm(area_width), np.linalg.norm(area_height)
    ltv = p - centre
    pos = np.array([ltv @ _norm(area_width), ltv @ _norm(area_height), ltv @ -direction])
    closest = np.array([np.clip(pos[0], -a_len / 2, a_len / 2),
                        np.clip(pos[1], -b_len / 2, b_len / 2), 0.0])  # fmt: skip
    dist = max(0.0, float(np.linalg.norm(closest - pos)))
    inv_radius = float(np.float32(1.0 / props["area_range"]))  # a float in the light buffer
    nd = (dist * inv_radius) ** 4
    raw = max(1.0 - nd, 0.0) ** 2 * max(dist, 0.0001) ** (-props["area_attenuation"])
    atten = raw * dist * dist
    hw, hh = area_width / 2, area_height / 2
    points = [
        centre - hw - hh - p,
        centre + hw - hh - p,
        centre + hw + hh - p,
        centre - hw + hh - p,
    ]
    eye = _norm(np.array([0.3, -0.2, 0.9]))  # the diffuse term does not read the view
    z = -_norm(eye - nrm * (eye @ nrm))
    x = np.cross(nrm, z)
    m_inv = np.stack([x, nrm, z])  # transpose(mat3(x, normal, z))
    L = [m_inv @ q for q in points] + [np.zeros(3)]
    n = godot_clip_quad_to_horizon(L)
    if n == 0:
        return 0.0
    Lp = [_norm(v) if np.linalg.norm(v) > 0 else v for v in L]
    I = godot_integrate_edge(Lp[0], Lp[1], L[0], L[1])
    I += godot_integrate_edge(Lp[1], Lp[2], L[1], L[2])
    I += godot_integrate_edge(Lp[2], Lp[3], L[2], L[3])
    if n >= 4:
        I += godot_integrate_edge(Lp[3], Lp[4], L[3], L[4])
    if n == 5:
        I += godot_integrate_edge(Lp[4], Lp[0], L[4], L[0])
    integral = abs(I) / (2.0 * math.pi)
    return props["light_energy"] * math.pi * integral * atten


# ----------------------------------------------------------------------------- fixtures
PANEL = SceneLight(
    "rect", math.sqrt(0.6 * 0.4 / math.pi), (0.2, -0.1, 2.0), intensity=300.0,
    normal=(0.0, 0.6, -0.8), tangent=(1.0, 0.0, 0.0), size=(0.6, 0.4),
)  # fmt: skip
TUBE = SceneLight("tube", 0.013, (0.0, 0.1, 1.5), intensity=5.8, length=1.2, axis=(0.8, 0.6, 0.0))


def _panel_frame(light):
    z = np.asarray(light.normal) / np.linalg.norm(light.normal)
    x = np.asarray(light.tangent, float)
    return x, np.cross(z, x), z  # width, height (normal x tangent), emitting normal


def _receivers(light, n, seed, spread):
    rng = np.random.default_rng(seed)
    c = np.asarray(light.position)
    p = c + rng.normal(size=(n, 3)) * spread
    if light.kind == "rect":
        z = _panel_frame(light)[2]
        s = (p - c) @ z
        p = p - np.outer(s, z) + np.outer(np.abs(s) + 1e-3, z)  # on the lit side
    nrm = rng.normal(size=(n, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return p, nrm


def _local(light, p, nrm):
    data = LightData(
        d=np.linalg.norm(p - np.asarray(light.position), axis=1), wpt=None, E_true=None,
        E_irr=None, cos_s=None, theta=None, denom=None, peak=1.0, radius=light.radius,
        range=None, spot=None, points=p, normals=nrm,
    )  # fmt: skip
    return _geometry(light, data)[0]


# ----------------------------------------------------------------------------- witnesses
def test_unreal_rect_witness_is_rect_irradiance_lambert():
    p, nrm = _receivers(PANEL, 300, 1, 0.7)
    props = {"SourceWidth": 60.0, "SourceHeight": 40.0, "AttenuationRadius": 450.0,
             "Intensity": 123.0}  # fmt: skip
    got = UnrealRectLight.render(props, _local(PANEL, p, nrm))
    _, ty, tz = _panel_frame(PANEL)
    want = [ue_rect_light(a, b, PANEL.position, tz, ty, props) for a, b in zip(p, nrm, strict=True)]
    assert np.count_nonzero(got) > 150
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12 * max(want))


def test_unreal_rect_model_is_the_witness_per_unit_radiance():
    """The area model `unreal_rect` (E / I, I = w h L) is Unreal's diffuse term: the
    transcription above with its Color / (0.5 w h) undone and no window."""
    p, nrm = _receivers(PANEL, 200, 2, 0.7)
    emitter = PANEL.emitter()
    with jax.enable_x64(True):
        got = np.asarray(area.area_irradiance(UnrealRect(), emitter, p, nrm))
    props = {"SourceWidth": 60.0, "SourceHeight": 40.0, "AttenuationRadius": 1e12,
             "Intensity": 0.5 * PANEL.intensity}  # fmt: skip  # radiance I / (w h)
    _, ty, tz = _panel_frame(PANEL)
    want = [ue_rect_light(a, b, PANEL.position, tz, ty, props) for a, b in zip(p, nrm, strict=True)]
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12 * max(want))


@pytest.mark.parametrize("length", [1.2, 0.0])
@pytest.mark.parametrize("radius", [0.0, 1.3])
def test_unreal_capsule_witness_is_its_capsule_code(length, radius):
    p, nrm = _receivers(TUBE, 300, 3, 1.0)
    props = {"SourceLength": 100 * length, "SourceRadius": radius, "AttenuationRadius": 400.0,
             "Intensity": 50.0}  # fmt: skip
    got = UnrealSourceLength.render(props, _local(TUBE, p, nrm))
    axis = np.asarray(TUBE.axis) / np.linalg.norm(TUBE.axis)
    want = [ue_capsule_light(a, b, TUBE.position, axis, props) for a, b in zip(p, nrm, strict=True)]
    assert np.count_nonzero(got) > 100
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12 * max(want))


def test_three_rect_area_light_is_ltc_evaluate():
    p, nrm = _receivers(PANEL, 300, 4, 0.7)
    props = {"width": 0.6, "height": 0.4, "intensity": 1250.0}  # nits
    got = ThreeRectAreaLight.render(props, _local(PANEL, p, nrm))
    tx, ty, _ = _panel_frame(PANEL)
    c = np.asarray(PANEL.position)
    rng = np.random.default_rng(0)
    want = [  # directDiffuse = color x diffuseColor x LTC_Evaluate: E = pi L ff
        math.pi * props["intensity"]
        * three_ltc_evaluate_diffuse(b, rng.normal(size=3), a, c, tx * 0.3, -ty * 0.2)
        for a, b in zip(p, nrm, strict=True)
    ]  # fmt: skip
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12 * max(want))


def test_godot_area_light_is_its_ltc_code():
    p, nrm = _receivers(PANEL, 400, 5, 0.7)
    props = {"area_size": [0.6, 0.4], "area_range": 3.0, "area_attenuation": 2.0,
             "light_energy": 800.0}  # fmt: skip
    got = GodotAreaLight.render(props, _local(PANEL, p, nrm))
    tx, ty, tz = _panel_frame(PANEL)
    c = np.asarray(PANEL.position)
    want = np.array(
        [
            godot_area_light(a, b, c, 0.6 * tx, 0.4 * ty, tz, props)
            for a, b in zip(p, nrm, strict=True)
        ]
    )
    clipped = sum(  # receivers whose horizon cuts the panel (Godot's clipping cases)
        1 for a, b in zip(p, nrm, strict=True) if len({np.sign(b @ (c + s - a)) for s in
        (0.3 * tx + 0.2 * ty, -0.3 * tx + 0.2 * ty, 0.3 * tx - 0.2 * ty, -0.3 * tx - 0.2 * ty)}) > 1
    )  # fmt: skip
    assert clipped > 50
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12 * want.max())


def test_godot_area_light_is_the_exact_clipped_polygon_to_its_fit():
    """Godot's diffuse is the clipped polygon (`clipped_rect`) up to Hill's fit of
    theta / sin theta (about 3e-4 per edge; more where a clipped sliver's edges cancel):
    within 1e-3 relative of the exact irradiance above 1e-3 of its peak, the window aside."""
    p, nrm = _receivers(PANEL, 500, 6, 0.7)
    props = {"area_size": [0.6, 0.4], "area_range": 1e9, "area_attenuation": 2.0,
             "light_energy": PANEL.intensity / (0.6 * 0.4)}  # fmt: skip
    got = GodotAreaLight.render(props, _local(PANEL, p, nrm))
    with jax.enable_x64(True):
        exact = np.asarray(area.area_irradiance(ClippedRect(), PANEL.emitter(), p, nrm))
    lit = exact > 1e-3 * exact.max()
    assert np.max(np.abs(got - exact)[lit] / exact[lit]) < 1e-3


def test_best_intensity_is_the_minimax_scale():
    rng = np.random.default_rng(7)
    a = rng.uniform(0.1, 2.0, 200)
    t = a * rng.uniform(0.8, 1.3, 200)
    w = t.copy()
    a[:3] = 0.0  # unlit by the engine: their error is t / w whatever the scale
    t[:3] = 0.01 * w[:3]
    c, e = best_intensity(a, t, w)
    grid = np.linspace(0.5, 2.0, 30001)
    brute = np.max(np.abs(grid[:, None] * a - t) / w, axis=1)
    assert e == pytest.approx(brute.min(), rel=1e-4)
    assert e == pytest.approx(np.max(np.abs(c * a - t) / w), rel=1e-12)


# ----------------------------------------------------------------------------- the model
def test_unreal_rect_shape_worst_case_and_cost():
    """The floor under a square panel at h = w/4, w, 4w, and the compiled cost."""
    from attenfit._judge import SHAPE_CONFIGS, shape_worst_case
    from attenfit._shaders import area_compiled_cost

    panels = [c for c in SHAPE_CONFIGS if c.key.startswith("panel")]
    assert len(panels) == 3
    worst = {c.key: shape_worst_case(UnrealRect(), c, grid=9, seeds=1, levels=1).error
             for c in panels}  # fmt: skip
    print("unreal_rect worst case:", {k: f"{100 * v:.3g}%" for k, v in worst.items()})
    # never exact (its acos fit is 1.3% low on a short edge); near the panel the floor far
    # to its side sees it at the horizon, where the sphere's wrap stands in for the clipping
    assert 0.1 < worst["panel_quarter"] < 1.0
    assert 0.01 < worst["panel_one"] < 0.1
    assert 0.005 < worst["panel_four"] < 0.03
    cost = area_compiled_cost(UnrealRect())
    print("unreal_rect compiled cost:", cost.cost)
    assert cost.cost > 10


def test_unreal_rect_shader_form_and_gradients():
    from _frame_forms import form_and_model

    from attenfit._truth import model_inputs

    p, nrm = _receivers(PANEL, 300, 8, 0.7)
    form, ref = form_and_model(UnrealRect(), PANEL.emitter(), p, nrm)
    assert np.max(np.abs(form - ref)) < 1e-6 * PANEL.intensity / (0.6 * 0.4)
    for x64 in (False, True):
        with jax.enable_x64(x64):
            dt = jax.numpy.float64 if x64 else jax.numpy.float32
            x = [
                jax.numpy.asarray(v, dt)
                for v in model_inputs(UnrealRect(), PANEL.emitter(), p, nrm)
            ]
            g = jax.grad(lambda z, x=x: jax.numpy.sum(UnrealRect()(*x[:2], z, *x[3:])))(x[2])
            assert np.all(np.isfinite(np.asarray(g)))


# ----------------------------------------------------------------------------- scenes
def _judged(ans, c):
    from attenfit._scenes._light_fits import light_data

    scene = ans.imported.scene
    truth = scene.ground_truth()[c.light]
    x = light_data(scene, truth)
    keep = x.E_true > c.range["threshold"] if c.range and c.range.get("range") else x.d > -1
    return scene.lights[c.light], x.points[keep], x.normals[keep], x.E_true[keep], x.denom[keep]


def _rerender(light, props, p, nrm):
    """What the engine draws with `props`, through the transcriptions above."""
    c = np.asarray(light.position, float)
    nrm = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
    kind = props.get("light_type")
    if light.kind == "rect":
        tx, ty, tz = _panel_frame(light)
        w, h = light.size
        if kind == "RectLight":
            return np.array(
                [ue_rect_light(a, b, c, tz, ty, props) for a, b in zip(p, nrm, strict=True)]
            )
        if kind == "RectAreaLight":
            rng = np.random.default_rng(0)
            return np.array([
                math.pi * props["intensity"]
                * three_ltc_evaluate_diffuse(b, rng.normal(size=3), a, c, tx * w / 2, -ty * h / 2)
                for a, b in zip(p, nrm, strict=True)
            ])  # fmt: skip
        assert kind == "AreaLight3D"
        return np.array(
            [
                godot_area_light(a, b, c, w * tx, h * ty, tz, props)
                for a, b in zip(p, nrm, strict=True)
            ]
        )
    axis = np.asarray(light.axis, float) / np.linalg.norm(light.axis)
    assert kind == "PointLight"
    return np.array([ue_capsule_light(a, b, c, axis, props) for a, b in zip(p, nrm, strict=True)])


@pytest.fixture(scope="module")
def example_answers():
    from attenfit._scenes._answer import answer_scene

    out = {}
    for name in ("panel", "batten"):
        scene = Scene.load(EXAMPLES / f"{name}.toml")
        for engine in ("unreal", "threejs", "godot", "filament"):
            out[name, engine] = answer_scene(scene, engine)
    return out


@pytest.mark.parametrize(
    ("name", "engine", "light_type"),
    [
        ("panel", "unreal", "RectLight"),
        ("panel", "godot", "AreaLight3D"),
        ("batten", "unreal", "PointLight"),
    ],
)
def test_example_answered_with_the_engines_own_light(example_answers, name, engine, light_type):
    ans = example_answers[name, engine]
    (c,) = ans.choices
    assert c.properties["light_type"] == light_type
    light, p, nrm, E_true, denom = _judged(ans, c)
    rendered = float(np.max(np.abs(_rerender(light, c.properties, p, nrm) - E_true) / denom))
    assert c.engine_error == pytest.approx(rendered, rel=1e-6, abs=1e-12)
    assert (c.status == "pass") == (rendered <= ans.imported.scene.tolerance)
    assert any(light_type in n for n in c.engine_notes)


def test_threejs_panel_takes_the_closer_of_its_area_light_and_stand_in(example_answers):
    """three.js's own RectAreaLight (identity LTC) renders the panel about 22% off at best;
    the spot stand-in of the joint engine search (`_engine_search`) renders it closer, and
    `area_verdict` keeps the closer of the two."""
    (c,) = example_answers["panel", "threejs"].choices
    assert "light_type" not in c.properties
    note = next(n for n in c.engine_notes if "RectAreaLight renders" in n)
    native = float(note.split("renders ")[1].split("%")[0]) / 100
    assert c.engine_error <= native


@pytest.mark.parametrize("engine", ["threejs", "godot", "filament"])
def test_tube_point_light_gets_the_broadside_intensity(example_answers, engine):
    """Issue 29 (b): the tube's point light took the file's end-on intensity and rendered
    98% dark; now its intensity is the one the engine renders closest, re-judged here
    through the engine's punctual code (tests/_engine_code.py)."""
    from _engine_code import RENDER

    ans = example_answers["batten", engine]
    (c,) = ans.choices
    assert "light_type" not in c.properties
    light, p, nrm, E_true, denom = _judged(ans, c)
    prop = {"threejs": "intensity", "godot": "light_energy", "filament": "intensityCandela"}
    intensity = c.properties[prop[engine]]
    assert intensity > 20 * light.intensity  # the side's broadside factor 2 l / (pi r) = 59
    to_l = np.asarray(light.position)[None, :] - p
    d = np.linalg.norm(to_l, axis=1)
    nl = np.sum(nrm / np.linalg.norm(nrm, axis=1, keepdims=True) * to_l / d[:, None], axis=1)
    E = intensity * np.array(
        [RENDER[engine](c.properties, a, 1.0, b, False) for a, b in zip(d, nl, strict=True)]
    )
    rendered = float(np.max(np.abs(E - E_true) / denom))
    assert c.engine_error == pytest.approx(rendered, rel=1e-6)
    assert rendered < 0.6  # an isotropic point cannot follow the tube's sin(psi): about 50%


# ----------------------------------------------------------------------------- write-back
@pytest.mark.parametrize("engine", ["unreal", "godot"])
def test_write_back_writes_the_area_light(tmp_path, engine):
    pxr = pytest.importorskip("pxr")
    from attenfit._errors import AttenfitError
    from attenfit._scenes._answer import answer_file
    from attenfit._scenes._writeback import write_back

    room = EXAMPLES / "blender" / "room.usda"
    ans = answer_file(room, side=room.parent / "room.side.toml", engine=engine, samples=256)
    strip = [c for c in ans.choices if c.name.endswith("Strip")]
    assert len(strip) == 1 and "light_type" in strip[0].properties
    out = tmp_path / "copy.usda"
    write_back(ans.imported, ans.choices, out)
    stage = pxr.Usd.Stage.Open(str(out))
    prim = next(p for p in stage.Traverse() if p.GetTypeName() == "RectLight")
    props = strip[0].properties
    for k, v in props.items():
        got = prim.GetAttribute(f"attenfit:{engine}:{k}").Get()
        assert (
            (list(got) if isinstance(v, list) else got) == pytest.approx(v)
            if not isinstance(v, str)
            else got == v
        )
    before = out.read_bytes()
    with pytest.raises(AttenfitError, match="exists"):
        write_back(ans.imported, ans.choices, out)  # never replaced without --force
    assert out.read_bytes() == before
    write_back(ans.imported, ans.choices, out, force=True)
    assert not list(tmp_path.glob("*.tmp*"))  # written atomically: no partial file left


def test_a_passing_engine_area_light_is_the_answer_not_a_shader_of_its_own(example_answers):
    """Godot's AreaLight3D renders the panel within tolerance: the headline and the table
    name that light, and no area model (a shader of its own) is offered beside it."""
    ans = example_answers["panel", "godot"]
    (c,) = ans.choices
    assert c.status == "pass" and c.area is None
    assert "AreaLight3D" in ans.summary() and "area model" not in ans.summary()
    assert "AreaLight3D" in ans.to_markdown().split("| light 0 (rect) |")[1].split("\n")[0]


def test_a_failing_engine_answer_still_offers_the_area_model(example_answers):
    """Where the engine renders the panel past tolerance (Filament: a spot stand-in), the
    light's area model is offered as a shader of its own."""
    ans = example_answers["panel", "filament"]
    (c,) = ans.choices
    assert c.status == "fail" and c.engine_error > ans.imported.scene.tolerance
    assert c.area_model is not None and "a shader of its own" in ans.summary()
