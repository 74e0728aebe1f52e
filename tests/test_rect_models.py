"""The rectangle's area models against the engines' code transcribed here, the exact
irradiance (`attenfit.RectEmitter`, itself checked against polygon quadrature and Mitsuba) and
a brute-force quadrature; their shader forms, exports and the point-light model of a
rectangle."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _frame_forms import form_and_model

import attenfit as af
from attenfit import area
from attenfit._curves import ClippedRect, FrostbiteRect, MrpRect, ThreeRect
from attenfit._shaders import area_compiled_cost
from attenfit._shaders._area_export import area_source
from attenfit._truth import model_inputs

W, H = 0.6, 0.4
C = np.array([0.1, -0.2, 2.0])
M = np.array([0.0, 0.0, -1.0])  # a ceiling panel, lighting downward
T = np.array([1.0, 0.0, 0.0])
PANEL = af.RectEmitter(C, M, T, W, H, intensity=2.0)
MODELS = [ClippedRect(), ThreeRect(), FrostbiteRect(), MrpRect()]


def _receivers(n: int, seed: int, spread: float = 0.6, facing: bool = False):
    """Random receivers in front of the panel; normals random (or toward its centre)."""
    rng = np.random.default_rng(seed)
    p = C + rng.normal(size=(n, 3)) * spread
    p[:, 2] = C[2] - np.abs(p[:, 2] - C[2]) - 1e-3  # below the panel: its lit side
    nrm = C - p if facing else rng.normal(size=(n, 3))
    return p, nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


def _world_frame():
    """The panel's frame in the world: tangent, bitangent (normal x tangent), normal."""
    return T, np.cross(M, T), M


# ----------------------------------------------------------------------------- transcriptions
def three_ltc_evaluate_diffuse(n, v, p, light_pos, half_width, half_height):
    """three.js `src/renderers/shaders/ShaderChunk/lights_physical_pars_fragment.glsl.js`
    (r160+): `LTC_Evaluate(N, V, P, mat3(1.0), rectCoords)` with `LTC_EdgeVectorFormFactor`
    and `LTC_ClippedSphereFormFactor`, and the corners `RE_Direct_RectArea_Physical` builds,
    line by line in float64. The light shines along its local -z (`halfWidth x halfHeight`
    points away from the lit side)."""
    rect = [
        light_pos + half_width - half_height,
        light_pos - half_width - half_height,
        light_pos - half_width + half_height,
        light_pos + half_width + half_height,
    ]
    v1, v2 = rect[1] - rect[0], rect[3] - rect[0]
    light_normal = np.cross(v1, v2)
    if np.dot(light_normal, p - rect[0]) < 0.0:
        return 0.0
    t1 = v - n * np.dot(v, n)
    t1 = t1 / np.linalg.norm(t1)
    t2 = -np.cross(n, t1)
    mat = np.stack([t1, t2, n])  # transpose(mat3(T1, T2, N)): rows T1, T2, N
    coords = [mat @ (c - p) for c in rect]
    coords = [c / np.linalg.norm(c) for c in coords]

    def edge(a, b):
        x = np.dot(a, b)
        y = abs(x)
        aa = 0.8543985 + (0.4965155 + 0.0145206 * y) * y
        bb = 3.4175940 + (4.1616724 + y) * y
        vv = aa / bb
        ts = vv if x > 0.0 else 0.5 / math.sqrt(max(1.0 - x * x, 1e-7)) - vv
        return np.cross(a, b) * ts

    f = sum(edge(coords[i], coords[(i + 1) % 4]) for i in range(4))
    length = np.linalg.norm(f)
    return max((length * length + f[2]) / (length + 1.0), 0.0)


def frostbite_rect_illuminance(
    world_pos, world_normal, light_pos, left, up, width, height, plane_n
):
    """Lagarde & de Rousiers 2014, "Moving Frostbite to PBR" §4.7.3: `rectangleSolidAngle`
    and the rectangle light's illuminance listing, line by line in float64."""

    def normalize(x):
        return x / np.linalg.norm(x)

    def solid_angle(p0, p1, p2, p3):
        v = [q - world_pos for q in (p0, p1, p2, p3)]
        nn = [normalize(np.cross(v[i], v[(i + 1) % 4])) for i in range(4)]
        g = [math.acos(np.clip(np.dot(-nn[i], nn[(i + 1) % 4]), -1, 1)) for i in range(4)]
        return sum(g) - 2 * math.pi

    if not np.dot(world_pos - light_pos, plane_n) > 0:
        return 0.0
    hw, hh = width * 0.5, height * 0.5
    p0 = light_pos + left * -hw + up * hh
    p1 = light_pos + left * -hw + up * -hh
    p2 = light_pos + left * hw + up * -hh
    p3 = light_pos + left * hw + up * hh
    sa = solid_angle(p0, p1, p2, p3)

    def sat(x):
        return min(max(x, 0.0), 1.0)

    cos = [sat(np.dot(normalize(q - world_pos), world_normal)) for q in (p0, p1, p2, p3, light_pos)]
    return sa * 0.2 * sum(cos)


def _triangle_solid_angle(a, b, c):
    """Van Oosterom & Strackee 1983: the solid angle of the triangle with vertices a, b, c
    seen from the origin, `2 atan2(|a.(b x c)|, abc + (a.b) c + (a.c) b + (b.c) a)`."""
    la, lb, lc = (np.linalg.norm(v) for v in (a, b, c))
    num = abs(np.dot(a, np.cross(b, c)))
    den = la * lb * lc + np.dot(a, b) * lc + np.dot(a, c) * lb + np.dot(b, c) * la
    return 2 * math.atan2(num, den)


def drobot_mrp_illuminance(p, n, c, m, tx, ty, w, h):
    """E / L of Drobot 2014 ("Physically Based Area Lights", GPU Pro 5, §1.4, the area
    diffuse approximation algorithm) in world coordinates, as Lagarde & de Rousiers 2014
    (§4.7, rectangular lights) write it, `E = Omega L <n.l>`, `l` toward the most
    representative point. The rectangle's solid angle here by Van Oosterom & Strackee
    (two triangles), not Frostbite's `rectangleSolidAngle`. A normal that misses the light's
    plane is tipped toward it: its part along the plane, with -1/2 along `m` (attenfit's
    choice; Drobot leaves the tip open)."""
    height = float(np.dot(p - c, m))
    if not height > 0:
        return 0.0
    s = n if np.dot(n, m) < 0 else (n - np.dot(n, m) * m) - 0.5 * m
    s = s / np.linalg.norm(s)
    p1 = p + s * (height / -np.dot(s, m))  # p': the normal's ray meets the plane
    pp = p - height * m  # p_p: the receiver's foot on the plane
    half = (p1 - p) / np.linalg.norm(p1 - p) + (pp - p) / np.linalg.norm(pp - p)
    pd = p + half * (height / -np.dot(half, m))  # p_d: the halfway vector meets the plane
    u = np.clip(np.dot(pd - c, tx), -w / 2, w / 2)  # the closest point of the rectangle
    v = np.clip(np.dot(pd - c, ty), -h / 2, h / 2)
    l = c + u * tx + v * ty - p
    cos = max(float(np.dot(n, l / np.linalg.norm(l))), 0.0)
    k = [
        c + sx * w / 2 * tx + sy * h / 2 * ty - p for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))
    ]
    omega = _triangle_solid_angle(k[0], k[1], k[2]) + _triangle_solid_angle(k[0], k[2], k[3])
    return omega * cos


def lambert_quadrature(p, n, k: int = 400):
    """E / L of the panel at p (normal n) by the midpoint rule over the rectangle: the
    integrand cos_r cos_e / d^2, cos_r clamped at 0 (the horizon), independent of any
    polygon formula."""
    tx, ty, m = _world_frame()
    u = (np.arange(k) + 0.5) / k
    su, sv = np.meshgrid((u - 0.5) * W, (u - 0.5) * H, indexing="ij")
    q = C + su[..., None] * tx + sv[..., None] * ty
    dv = q - p
    d2 = np.sum(dv * dv, -1)
    cos_r = np.maximum(dv @ n, 0) / np.sqrt(d2)
    cos_e = np.maximum(-(dv @ m), 0) / np.sqrt(d2)
    return float(np.sum(cos_r * cos_e / d2) * (W * H / k**2))


# ----------------------------------------------------------------------------- the exact form
def test_clipped_rect_is_the_exact_irradiance():
    with jax.enable_x64(True):
        p, n = _receivers(3000, 1)
        exact = np.asarray(af.irradiance(PANEL, p, n))
        got = np.asarray(area.area_irradiance(ClippedRect(), PANEL, p, n))
    scale = np.asarray(af.irradiance(PANEL, p, (C - p) / np.linalg.norm(C - p, axis=1)[:, None]))
    assert (exact > 0).mean() > 0.4 and ((exact > 0) & (exact < 0.3 * scale)).sum() > 100
    np.testing.assert_allclose(got, exact, rtol=1e-9, atol=1e-12 * scale.max())


@pytest.mark.parametrize(
    ("p", "n"),
    [
        ([0.1, -0.2, 1.5], [0.0, 0.0, 1.0]),  # under the centre, facing it
        ([0.5, 0.1, 1.7], [-0.8, 0.0, 0.6]),  # tilted: the horizon cuts the panel
        ([1.0, -0.4, 1.9], [0.0, 0.6, 0.8]),  # off to the side, cut
    ],
)
def test_clipped_rect_matches_brute_force_quadrature(p, n):
    p, n = np.asarray(p), np.asarray(n) / np.linalg.norm(n)
    with jax.enable_x64(True):
        got = float(area.area_irradiance(ClippedRect(), PANEL, p[None], n[None])[0])
    want = lambert_quadrature(p, n) * float(PANEL.intensity) / (W * H)  # L = I / (w h)
    assert got == pytest.approx(want, rel=2e-4)  # the midpoint rule at 400^2 with a kink


def test_behind_the_panel_every_model_gives_zero():
    p = C + np.array([[0.0, 0.0, 0.3], [0.2, 0.1, 0.01]])  # above a downward panel
    n = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    for m in MODELS:
        assert np.all(np.asarray(area.area_irradiance(m, PANEL, p, n)) == 0), m.name


# ----------------------------------------------------------------------------- engines
def test_three_rect_is_threejs_ltc_evaluate():
    rng = np.random.default_rng(3)
    p, n = _receivers(200, 4)
    tx, ty, _ = _world_frame()
    # three.js's light: local x along the width, local y = -bitangent, so that it shines
    # along its local -z = our normal M
    half_width, half_height = tx * W / 2, -ty * H / 2
    with jax.enable_x64(True):
        got = np.asarray(area.area_irradiance(ThreeRect(), PANEL, p, n))
    for i in range(len(p)):
        view = rng.normal(size=3)  # any view direction: the diffuse term does not read it
        ff = three_ltc_evaluate_diffuse(n[i], view, p[i], C, half_width, half_height)
        want = math.pi * ff * float(PANEL.intensity) / (W * H)  # E = pi L ff
        assert got[i] == pytest.approx(want, rel=1e-9, abs=1e-12), i


def test_frostbite_rect_is_its_listing():
    p, n = _receivers(200, 5)
    tx, ty, m = _world_frame()
    with jax.enable_x64(True):
        got = np.asarray(area.area_irradiance(FrostbiteRect(), PANEL, p, n))
    for i in range(len(p)):
        e = frostbite_rect_illuminance(p[i], n[i], C, tx, ty, W, H, m)
        want = e * float(PANEL.intensity) / (W * H)
        assert got[i] == pytest.approx(want, rel=1e-9, abs=1e-12), i


def test_mrp_rect_is_drobots_representative_point():
    p, n = _receivers(300, 10)
    p = np.concatenate([p, C + np.array([[0.1, 0.0, -0.2], [0.0, 0.3, -0.05], [0.5, 0.5, -0.1]])])
    n = np.concatenate([n, [[0.0, 0.0, 1.0], [0.0, 0.6, -0.8], [-0.6, 0.0, 0.8]]])
    tx, ty, m = _world_frame()
    with jax.enable_x64(True):
        got = np.asarray(area.area_irradiance(MrpRect(), PANEL, p, n))
    assert np.sum(n @ m >= 0) > 50  # normals that miss the plane: the tip is exercised
    for i in range(len(p)):
        want = (
            drobot_mrp_illuminance(p[i], n[i], C, m, tx, ty, W, H)
            * float(PANEL.intensity)
            / (W * H)
        )
        assert got[i] == pytest.approx(want, rel=1e-9, abs=1e-12), i


def test_mrp_rect_under_the_panel_weighs_the_whole_solid_angle():
    """Right under the centre, facing it, the point is the centre: E / L = Omega, the
    rectangle's solid angle (a right pyramid's, 4 asin(a b / sqrt((a^2 + h^2)(b^2 + h^2))),
    Frostbite's `rightPyramidSolidAngle`), above the truth, which weighs each direction by
    its cosine."""
    h = 0.3
    p = (C + h * M)[None]  # below the downward panel, facing it
    n = -M[None]
    with jax.enable_x64(True):
        got = float(area.area_irradiance(MrpRect(), PANEL, p, n)[0])
        exact = float(af.irradiance(PANEL, p, n)[0])
    a, b = W / 2, H / 2
    omega = 4 * math.asin(a * b / math.sqrt((a * a + h * h) * (b * b + h * h)))
    assert got == pytest.approx(omega * float(PANEL.intensity) / (W * H), rel=1e-12)
    assert got > exact


def test_the_engines_forms_are_close_to_the_truth_where_they_should_be():
    """Facing receivers, the panel small: three.js within its rational fit (1e-3), Frostbite
    within its five points; both far from exact near the panel (their documented limits)."""
    with jax.enable_x64(True):
        p, n = _receivers(500, 6, spread=3.0, facing=True)
        far = np.linalg.norm(p - C, axis=1) > 3 * W
        exact = np.asarray(af.irradiance(PANEL, p, n))
        three = np.asarray(area.area_irradiance(ThreeRect(), PANEL, p, n))
        fb = np.asarray(area.area_irradiance(FrostbiteRect(), PANEL, p, n))
        mrp = np.asarray(area.area_irradiance(MrpRect(), PANEL, p, n))
    assert np.max(np.abs(three - exact)[far] / exact[far]) < 2e-3
    assert np.max(np.abs(fb - exact)[far] / exact[far]) < 0.05
    assert np.max(np.abs(mrp - exact)[far] / exact[far]) < 0.05


def test_the_point_light_model_of_a_rectangle_is_its_cosine_emitter():
    """`PointLight(family)` reads the rectangle as a one-sided disk: `g = max(0, cos_e)`."""
    p, n = _receivers(100, 7)
    with jax.enable_x64(True):
        got = np.asarray(area.area_irradiance(area.PointLight(), PANEL, p, n))
    dv = C - p
    d = np.linalg.norm(dv, axis=1)
    cos_e = np.maximum((p - C) @ M / d, 0)
    cos_r = np.maximum(np.sum(n * dv, 1) / d, 0)
    np.testing.assert_allclose(got, float(PANEL.intensity) * cos_e * cos_r / d**2, rtol=1e-12)


# ----------------------------------------------------------------------------- contract
@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
def test_the_shader_form_is_the_model(model):
    p, n = _receivers(500, 8)
    form, ref = form_and_model(model, PANEL, p, n)
    scale = 1 / (W * H)  # the facing value's order; the form bakes its literals as float32
    assert np.max(np.abs(form - ref)) < 1e-6 * scale


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
def test_exports_and_compiled_cost(model):
    for lang in ("glsl", "hlsl", "wgsl", "c", "cuda"):
        text = area_source(model, lang, "attenfit_rect")
        assert "attenfit_rect" in text and "hw" in text and "nz" in text
    cost = area_compiled_cost(model)
    assert cost.cost > 10


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_values_and_gradients_are_finite(model, dtype):
    with jax.enable_x64(dtype == jnp.float64):
        p, n = _receivers(64, 9)
        p = np.concatenate([p, C + np.array([[0.0, 0.0, -1e-9], [W / 2, H / 2, -1e-6]])])
        n = np.concatenate([n, [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]])
        npd = np.float64 if dtype == jnp.float64 else np.float32
        x = [
            jnp.asarray(v, dtype) for v in model_inputs(model, PANEL, p.astype(npd), n.astype(npd))
        ]
        v = model(*x)
        assert v.dtype == dtype and np.all(np.isfinite(np.asarray(v)))
        assert np.all(np.asarray(v) >= 0)
        grads = jax.grad(lambda z: jnp.sum(model(*x[:2], z, *x[3:])))(x[2])
        assert np.all(np.isfinite(np.asarray(grads)))


def test_the_point_light_model_fits_a_panels_floor():
    """Fitting works on the models with parameters: the point-light model of a family."""
    with jax.enable_x64(True):
        xs = np.linspace(-1.0, 1.0, 15)
        p = np.array([[C[0] + a, C[1] + b, C[2] - 0.8] for a in xs for b in xs])
        n = np.tile([0.0, 0.0, 1.0], (len(p), 1))
        x = area.area_inputs(PANEL, p, n)
        target = np.asarray(af.irradiance(PANEL, p, n)) / float(PANEL.intensity)
        res = af.fit(area.PointLight(af.get_family("disk_facing")()), x, target)
    assert np.isfinite(res.metrics["rms_rel_error"]) and res.metrics["rms_rel_error"] < 0.2


def test_the_models_refuse_a_light_of_another_shape():
    sphere = af.SphereEmitter([0.0, 0.0, 0.0], 0.1)
    with pytest.raises(TypeError, match="RectEmitter"):
        area.area_irradiance(ClippedRect(), sphere, np.ones((1, 3)), np.ones((1, 3)))
    with pytest.raises(ValueError, match="8 inputs"):
        ClippedRect()(1.0, 1.0, 1.0, 1.0)


# ----------------------------------------------------------------------------- judged
def test_shape_worst_case_on_the_panels_floors():
    """The exact form is exact on every floor; the point-light model is worst right under
    the panel at h = w/4 (there the truth is about pi L, the model I / h^2 = 16 L: over 4x
    the truth), and the worst case bounds the error at random receivers of the floor."""
    from attenfit._judge import SHAPE_CONFIGS, receiver_error, shape_worst_case

    quarter = SHAPE_CONFIGS[0]
    assert quarter.key == "panel_quarter"
    exact = shape_worst_case(ClippedRect(), quarter, grid=9, seeds=1, levels=1)
    assert exact.error < 1e-9
    point = shape_worst_case(area.PointLight(), quarter, grid=17)
    assert point.error > 4 and point.point[:2] == (0.0, 0.0)
    rng = np.random.default_rng(0)
    pts, nrm = quarter.receivers(rng.uniform(size=(200, 2)))
    sample = np.abs(
        receiver_error(area.PointLight(), quarter.emitter(), pts, nrm, receivers="floor")
    )
    assert np.nanmax(sample) <= point.error + 1e-12
    with pytest.raises(ValueError, match="unknown configuration"):
        shape_worst_case(ClippedRect(), "ceiling")


def test_a_rect_scene_escalates_to_the_rect_and_disk_models():
    from attenfit._scenes._escalate import _models_for

    names = {m.name for m in _models_for({"rect"})}
    assert {"clipped_rect", "three_rect", "frostbite_rect", "clipped_disk"} <= names
    assert "karis_tube" not in names and "snyder_sphere" not in names
