"""Area-light models of a one-sided Lambertian rectangle: the forms the engines ship.

Each reads the receiver in the rectangle's frame (`RECT_INPUTS`: its centre the origin, x
along its width, z its normal, the lit side z > 0; point x, y, z, unit normal nx, ny, nz, and
the half width `hw` and half height `hh`) and returns `E / I`, `I = 4 hw hh L` the intensity
along the normal (`attenfit.RectEmitter`: `L = I / (w h)`).

* `ClippedRect`: the exact clipped polygon. Lambert's formula (Lambert 1760; Arvo 1994 eq. 2;
  Heitz et al. 2016, "Real-Time Polygonal-Light Shading with Linearly Transformed Cosines",
  eq. 11) over the rectangle clipped to the receiver's upper hemisphere, `E / L = 1/2 sum_i
  theta_i n.g_i` (`theta_i` the angle an edge subtends, `g_i` the unit normal of the plane
  through it and the receiver). For a diffuse receiver the LTC matrix is the identity and
  the engines' LTC diffuse term is this form: Unity HDRP
  `Runtime/Lighting/LightEvaluation`/`AreaLighting.hlsl` (`ClipQuadToHorizon`, then
  `PolygonIrradiance`), Godot 4.5's area lights (godotengine/godot PR #108219, LTC with the
  polygon clipped to the horizon).
* `ThreeRect`: three.js `RectAreaLight` diffuse (`src/renderers/shaders/ShaderChunk/
  lights_physical_pars_fragment.glsl.js`, `LTC_Evaluate` with `mat3(1.0)`): the unclipped
  edges' vector form factor with a rational fit of `theta / sin(theta) / 2 pi`
  (`LTC_EdgeVectorFormFactor`), and the horizon through the sphere of the same vector form
  factor (`LTC_ClippedSphereFormFactor`, `max((l^2 + f.z) / (l + 1), 0)`; Hill 2016,
  "Real-Time Area Lighting: a Journey from Research to Production", p. 102).
* `FrostbiteRect`: the representative points of Frostbite (Lagarde & de Rousiers 2014,
  "Moving Frostbite to PBR", §4.7.3, the rectangle light's illuminance listing): the
  rectangle's solid angle (`rectangleSolidAngle`) times the mean of the clamped cosines to its
  four corners and its centre.

* `MrpRect`: Drobot's most representative point (Drobot 2014, "Physically Based Area Lights",
  GPU Pro 5, §1.4, the area diffuse approximation algorithm after eqs. 1.13-1.14): the ray
  along the receiver's normal meets the light's plane at `p'` (a normal that misses the
  plane is first tipped toward it, Drobot's Figure 1.5; the tip here is attenfit's,
  `_SKEW`), the receiver's foot on the plane is `p_p`, the halfway vector of the unit
  vectors toward `p'` and `p_p` meets the plane at `p_d`, taken to the rectangle's closest
  point; the irradiance is the rectangle's solid angle times the clamped cosine toward it,
  `E = Omega L max(0, n.l_d)`, the form Lagarde & de Rousiers 2014 (§4.7, rectangular area
  lights) give for Drobot's approximation, with Frostbite's `rectangleSolidAngle`.
  (Drobot's own weight, `A cos(theta_o) / r^2` at `p_d`, eq. 1.13, exceeds 2 pi near the
  panel.)

The point-light model of a rectangle is `PointLight(family)` with `AREA_INPUTS`
(`attenfit.area_inputs` reads a rectangle as a one-sided disk, `g = max(0, cos_e)`).

Each formula is written once, for two back ends (`Jax`, `Ir`), so that the JAX model and the
shader form are the same arithmetic; the JAX back end adds the guards (a `where` on every
division that can meet 0) so values and gradients stay finite.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import jax.numpy as jnp

from .._ir import Expr, Lets, Ref, fn
from ._area import RECT_INPUTS, AreaModel, register_area_model, safe_sqrt
from ._forms import area_form

__all__ = [
    "FRAME_FORM_INPUTS",
    "FRAME_INPUT_TEXT",
    "ClippedRect",
    "FrameModel",
    "FrostbiteRect",
    "Ir",
    "Jax",
    "MrpRect",
    "RectModel",
    "ThreeRect",
    "frame_cross",
    "frame_dot",
    "rect_solid_angle",
    "solid_angle_cosines",
]

#: The per-receiver inputs of a rectangle's or a tube's shader form (its size: parameters).
FRAME_FORM_INPUTS = ("x", "y", "z", "nx", "ny", "nz")
#: What each input of a rectangle's or a tube's models is, and its unit (`input_text`):
#: the receiver in the light's frame, no `d` among them.
FRAME_INPUT_TEXT: dict[str, str] = {
    "x": "the receiver's x in the light's frame (its centre the origin; x: a rectangle's width, a tube's axis); length",
    "y": "the receiver's y in the light's frame (a rectangle's height axis); length",
    "z": "the receiver's z in the light's frame (a rectangle's normal: lit where z > 0); length",
    "nx": "the receiver's unit normal in the light's frame, x; 1",
    "ny": "the receiver's unit normal in the light's frame, y; 1",
    "nz": "the receiver's unit normal in the light's frame, z; 1",
    "hw": "the rectangle's half width; length",
    "hh": "the rectangle's half height; length",
    "hl": "the tube's half length; length",
    "r": "the tube's radius (across its axis); length",
}


# ----------------------------------------------------------------------------- back ends
class Jax:
    """The JAX back end: guarded operations on arrays."""

    @staticmethod
    def let(name: str, e: Any) -> Any:
        return e

    sqrt = staticmethod(safe_sqrt)
    abs = staticmethod(jnp.abs)
    select = staticmethod(jnp.where)
    max = staticmethod(jnp.maximum)
    min = staticmethod(jnp.minimum)

    @staticmethod
    def atan2(y: Any, x: Any) -> Any:
        """atan2, 0 at (0, 0) with a finite gradient there."""
        zero = (x == 0) & (y == 0)
        return jnp.arctan2(y, jnp.where(zero, jnp.ones_like(x), x))

    @staticmethod
    def acos(x: Any) -> Any:
        """acos as `atan2(sqrt(1 - x^2), x)`: the same values, finite gradients at +-1."""
        c = jnp.clip(x, -1, 1)
        return jnp.arctan2(safe_sqrt((1 - c) * (1 + c)), c)

    @staticmethod
    def ge(a: Any, b: Any) -> Any:
        return a >= b

    @staticmethod
    def nonzero(x: Any) -> Any:
        """`x` where it is not 0, else 1 (a denominator's guard)."""
        return jnp.where(x != 0, x, jnp.ones_like(x))


class Ir:
    """The shader back end: expressions of `attenfit._ir`, shared values as named temporaries."""

    def __init__(self, let: Lets):
        self._let = let

    def let(self, name: str, e: Expr) -> Ref:
        return self._let(name, e)

    @staticmethod
    def sqrt(x: Expr) -> Expr:
        return fn("sqrt", x)

    @staticmethod
    def abs(x: Expr) -> Expr:
        return fn("abs", x)

    @staticmethod
    def atan2(y: Expr, x: Expr) -> Expr:
        return fn("atan2", y, x)

    @staticmethod
    def select(c: Expr, a: Any, b: Any) -> Expr:
        return fn("select", c, a, b)

    @staticmethod
    def max(a: Any, b: Any) -> Expr:
        return fn("max", a, b)

    @staticmethod
    def min(a: Any, b: Any) -> Expr:
        return fn("min", a, b)

    @staticmethod
    def acos(x: Expr) -> Expr:
        return fn("acos", x)

    @staticmethod
    def ge(a: Any, b: Any) -> Expr:
        return fn("ge", a, b)

    @staticmethod
    def nonzero(x: Expr) -> Expr:
        return x  # a shader divides unguarded


Vec = tuple[Any, Any, Any]


def frame_dot(a: Vec, b: Vec) -> Any:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def frame_cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _scale(a: Vec, s: Any) -> Vec:
    return (a[0] * s, a[1] * s, a[2] * s)


def _let3(bk: Any, name: str, v: Vec) -> Vec:
    return tuple(bk.let(f"{name}_{c}", e) for c, e in zip("xyz", v, strict=True))  # type: ignore[return-value]


def _unit(bk: Any, v: Vec, name: str) -> Vec:
    inv = bk.let(f"{name}_inv", 1.0 / bk.nonzero(bk.sqrt(frame_dot(v, v))))
    return _let3(bk, name, _scale(v, inv))


def corners(hw: Any, hh: Any, p: Vec, order: tuple[tuple[int, int], ...]) -> list[Vec]:
    """The corners `(sx hw, sy hh, 0)` minus the receiver `p`, in `order` of signs."""
    return [(sx * hw - p[0], sy * hh - p[1], -p[2]) for sx, sy in order]


# ----------------------------------------------------------------------------- the exact form
#: Clockwise seen from the lit side: Lambert's sum is then positive for a receiver facing it.
_CLOCKWISE = ((-1, -1), (-1, 1), (1, 1), (1, -1))


def _edge_term(bk: Any, a: Vec, b: Vec, n: Vec, tag: str) -> Any:
    """`theta n.(a x b) / |a x b|`, `theta = atan2(|a x b|, a.b)` the angle the segment a b
    subtends (0 for a segment of no length)."""
    c = _let3(bk, f"{tag}c", frame_cross(a, b))
    cn = bk.let(f"{tag}cn", bk.sqrt(frame_dot(c, c)))
    theta = bk.atan2(cn, frame_dot(a, b))
    return bk.select(cn > 0.0, theta * frame_dot(n, c) / bk.nonzero(cn), 0.0)


def clipped_polygon(bk: Any, v: list[Vec], n: Vec) -> Any:
    """`E / L` of the polygon with vertices `v` (relative to the receiver, clockwise seen from
    it) clipped to the receiver's upper hemisphere `n.a >= 0` (Sutherland-Hodgman: each edge's
    part above the horizon, and the horizon's chord from where the boundary leaves it to
    where it comes back; a convex polygon crosses it at most twice)."""
    k = len(v)
    h = [bk.let(f"h{i}", frame_dot(n, v[i])) for i in range(k)]
    total: Any = 0.0
    exit_pt: Vec = (0.0, 0.0, 0.0)
    entry_pt: Vec = (0.0, 0.0, 0.0)
    for i in range(k):
        j = (i + 1) % k
        a, b, ha, hb = v[i], v[j], h[i], h[j]
        a_in, b_in = bk.ge(ha, 0.0), bk.ge(hb, 0.0)
        cross = bk.select(a_in, bk.select(b_in, 0.0, 1.0), bk.select(b_in, 1.0, 0.0))
        t = bk.let(f"t{i}", ha / bk.select(cross > 0.5, ha - hb, 1.0))
        q = _let3(bk, f"q{i}", (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]),
                                a[2] + t * (b[2] - a[2])))  # fmt: skip
        a2 = tuple(bk.select(a_in, a[c], q[c]) for c in range(3))
        b2 = tuple(bk.select(b_in, b[c], q[c]) for c in range(3))
        term = _edge_term(bk, a2, b2, n, f"e{i}")  # type: ignore[arg-type]
        total = total + bk.select(bk.ge(bk.max(ha, hb), 0.0), term, 0.0)
        leaves = bk.select(a_in, bk.select(b_in, 0.0, 1.0), 0.0)
        comes = bk.select(a_in, 0.0, bk.select(b_in, 1.0, 0.0))
        exit_pt = tuple(exit_pt[c] + leaves * q[c] for c in range(3))  # type: ignore[assignment]
        entry_pt = tuple(entry_pt[c] + comes * q[c] for c in range(3))  # type: ignore[assignment]
    chord = _edge_term(bk, _let3(bk, "hx", exit_pt), _let3(bk, "hy", entry_pt), n, "ch")
    return 0.5 * (total + chord)


def _frame(x: dict[str, Any]) -> tuple[Vec, Vec]:
    return (x["x"], x["y"], x["z"]), (x["nx"], x["ny"], x["nz"])


def _clipped_rect(bk: Any, x: dict[str, Any], hw: Any, hh: Any) -> Any:
    p, n = _frame(x)
    e = clipped_polygon(bk, corners(hw, hh, p, _CLOCKWISE), n)
    return bk.select(x["z"] > 0.0, bk.max(e, 0.0), 0.0) / (4.0 * hw * hh)


# ----------------------------------------------------------------------------- three.js
#: three.js's corners, `rectCoords[0..3]` (`lightPos + halfWidth - halfHeight`, ...), in this
#: frame: counter-clockwise seen from the lit side ("assumes ccw winding order").
_THREE_ORDER = ((1, 1), (-1, 1), (-1, -1), (1, -1))


def _three_edge(bk: Any, v1: Vec, v2: Vec, tag: str) -> Vec:
    """three.js `LTC_EdgeVectorFormFactor(v1, v2)` (unit vectors)."""
    xx = bk.let(f"{tag}x", frame_dot(v1, v2))
    y = bk.abs(xx)
    a = 0.8543985 + (0.4965155 + 0.0145206 * y) * y
    b = 3.4175940 + (4.1616724 + y) * y
    v = bk.let(f"{tag}v", a / b)
    inv = 1.0 / bk.sqrt(bk.max(1.0 - xx * xx, 1e-7))
    ts = bk.let(f"{tag}ts", bk.select(xx > 0.0, v, 0.5 * inv - v))
    return _scale(frame_cross(v1, v2), ts)


def _three_rect(bk: Any, x: dict[str, Any], hw: Any, hh: Any) -> Any:
    p, n = _frame(x)
    v = [_unit(bk, c, f"c{i}") for i, c in enumerate(corners(hw, hh, p, _THREE_ORDER))]
    f: Vec = (0.0, 0.0, 0.0)
    for i in range(4):
        f = tuple(a + b for a, b in zip(f, _three_edge(bk, v[i], v[(i + 1) % 4], f"w{i}"), strict=True))  # type: ignore[assignment]  # fmt: skip
    f = _let3(bk, "f", f)
    l = bk.let("l", bk.sqrt(frame_dot(f, f)))
    # three.js's basis (T1, T2 = -N x T1, N) is left-handed: its f.z is -n.f in this frame
    ff = bk.max((l * l - frame_dot(f, n)) / (l + 1.0), 0.0)
    return bk.select(bk.ge(x["z"], 0.0), math.pi * ff, 0.0) / (4.0 * hw * hh)


# ----------------------------------------------------------------------------- Frostbite
def rect_solid_angle(bk: Any, q: list[Vec]) -> Any:
    """Frostbite's `rectangleSolidAngle(worldPos, p0..p3)` (Lagarde & de Rousiers 2014
    §4.7.3), `q` the corners relative to the receiver: `sum_i acos(-n_i.n_(i+1)) - 2 pi`,
    `n_i` the unit normal of the plane through the receiver and the edge `q_i q_(i+1)`."""
    nrm = [_unit(bk, frame_cross(q[i], q[(i + 1) % 4]), f"sn{i}") for i in range(4)]
    g = [bk.acos(-frame_dot(nrm[i], nrm[(i + 1) % 4])) for i in range(4)]
    return bk.let("omega", g[0] + g[1] + g[2] + g[3] - 2.0 * math.pi)


def solid_angle_cosines(bk: Any, q: list[Vec], centre: Vec, n: Vec) -> Any:
    """Frostbite's `rectangleSolidAngle(worldPos, p0..p3)` times `0.2` times the sum of
    `saturate(dot(normalize(p_i - worldPos), N))` over the corners and the centre
    (Lagarde & de Rousiers 2014 §4.7.3): `q` the corners and `centre` relative to the receiver."""
    omega = rect_solid_angle(bk, q)
    cos_sum: Any = 0.0
    for i, c in enumerate([*q, centre]):
        u = _unit(bk, c, f"u{i}")
        cos_sum = cos_sum + bk.min(bk.max(frame_dot(u, n), 0.0), 1.0)
    return omega * 0.2 * cos_sum


#: Frostbite's p0..p3: `lightLeft * -halfWidth + lightUp * halfHeight`, ... (left = x, up = y).
_FROSTBITE_ORDER = ((-1, 1), (-1, -1), (1, -1), (1, 1))


def _frostbite_rect(bk: Any, x: dict[str, Any], hw: Any, hh: Any) -> Any:
    p, n = _frame(x)
    q = corners(hw, hh, p, _FROSTBITE_ORDER)
    e = solid_angle_cosines(bk, q, (-p[0], -p[1], -p[2]), n)
    return bk.select(x["z"] > 0.0, e, 0.0) / (4.0 * hw * hh)


# ----------------------------------------------------------------------------- Drobot
#: How far the normal is tipped toward the light's plane where it does not meet it: the
#: normal's part along the plane, with z = -1/2 (XLE's `RectangleDiffuseRepPoint` subtracts
#: 1/2 from n.z, which still misses the plane for n.z >= 1/2).
_SKEW = 0.5


def _mrp_rect(bk: Any, x: dict[str, Any], hw: Any, hh: Any) -> Any:
    p, n = _frame(x)
    # p': where the normal meets the plane z = 0 (skewed toward it where it does not)
    meets = n[2] < 0.0
    tip = bk.let("mrp_tip", 1.0 / bk.sqrt(n[0] * n[0] + n[1] * n[1] + _SKEW * _SKEW))
    sx = bk.let("mrp_sx", bk.select(meets, n[0], n[0] * tip))
    sy = bk.let("mrp_sy", bk.select(meets, n[1], n[1] * tip))
    sz = bk.let("mrp_sz", bk.select(meets, n[2], -_SKEW * tip))
    # p_d: the halfway of the unit vectors to p' (s) and to the foot p_p (-z) meets the plane
    t = bk.let("mrp_t", p[2] / (1.0 - sz))
    xd = bk.min(bk.max(p[0] + t * sx, -hw), hw)  # the closest point of the rectangle
    yd = bk.min(bk.max(p[1] + t * sy, -hh), hh)
    l = _unit(bk, (xd - p[0], yd - p[1], -p[2]), "mrp_l")
    cos = bk.max(frame_dot(l, n), 0.0)
    omega = rect_solid_angle(bk, corners(hw, hh, p, _FROSTBITE_ORDER))
    return bk.select(x["z"] > 0.0, omega * cos, 0.0) / (4.0 * hw * hh)


# ----------------------------------------------------------------------------- the models
class FrameModel(AreaModel):
    """An area model that reads the receiver in its light's frame (abstract): a rectangle's
    (`RectModel`) or a tube's (`_tube_models.TubeModel`). A final class gives its formula
    once for both back ends, `build(bk, x, a, b)` (`x` the receiver's point and normal by
    name, `a`, `b` the light's size in `form_sizes` order), and its shader form's citation
    (`form_source`, `form_engine`, `form_note`): `irradiance` and `shader_form` are both
    `build`, with the `Jax` and the `Ir` back ends."""

    form_inputs = FRAME_FORM_INPUTS
    input_text: ClassVar[dict[str, str]] = FRAME_INPUT_TEXT
    #: The formula for both back ends (a final class's `staticmethod`).
    build: ClassVar[Any]
    #: Where the shader form comes from, whether it is the engine's code, where it parts
    #: from the JAX form.
    form_source: ClassVar[str]
    form_engine: ClassVar[bool]
    form_note: ClassVar[str] = ""

    def irradiance(self, *x: Any) -> Any:
        receiver = dict(zip(FRAME_FORM_INPUTS, x[:6], strict=True))
        return type(self).build(Jax, receiver, *x[6:])

    def shader_form(self):
        cls = type(self)

        def make(let: Lets, x: dict[str, Ref], p: dict[str, Ref]) -> Expr:
            return cls.build(Ir(let), x, *(p[k] for k in cls.form_sizes))

        return area_form(self, make, cls.form_source, engine=cls.form_engine, note=cls.form_note)


class RectModel(FrameModel):
    """An area model of a one-sided rectangle (abstract): it reads `RECT_INPUTS`, and its
    shader form the receiver in the light's frame and the parameters `half_width`,
    `half_height`."""

    input_names = RECT_INPUTS
    inputs = len(RECT_INPUTS)
    form_sizes: ClassVar[dict[str, str]] = {"half_width": "hw", "half_height": "hh"}
    output_text: ClassVar[str] = (
        "E / I in 1/length^2 (I: the rectangle's point-equivalent intensity along its normal, "
        "I = w h L = 4 hw hh L; attenfit.RectEmitter: L = I / (w h))"
    )
    light = "rect"


@register_area_model
class ClippedRect(RectModel):
    """The exact one-sided rectangle: Lambert's polygon after clipping it to the receiver's
    horizon (the module docstring); what the LTC diffuse term of HDRP and Godot 4.5 is for a
    Lambertian receiver."""

    name = "clipped_rect"
    default_free = ()
    formula = "1/2 sum_i theta_i n.g_i over the rectangle clipped to n.l >= 0, / (4 hw hh)"
    source = (
        "Lambert 1760 via Arvo 1994 eq. 2 and Heitz et al. 2016 eq. 11; Unity HDRP "
        "AreaLighting.hlsl ClipQuadToHorizon + PolygonIrradiance; Godot 4.5 area lights (PR #108219)"
    )
    exact = "everywhere in front of the rectangle"
    build = staticmethod(_clipped_rect)
    form_source = (
        "Lambert 1760 via Heitz et al. 2016 eq. 11 after clipping (HDRP ClipQuadToHorizon, "
        "PolygonIrradiance)"
    )
    form_engine = False
    form_note = "the clipping as a fixed sequence of selects; no guard at a corner (|a x b| = 0)"


@register_area_model
class ThreeRect(RectModel):
    """three.js `RectAreaLight`'s diffuse term (the module docstring): the edges' vector form
    factor by a rational fit, its horizon through the sphere of the same vector form factor."""

    name = "three_rect"
    default_free = ()
    formula = "pi max((|F|^2 + n.F) / (|F| + 1), 0) / (4 hw hh), F = sum of the edges' vector form factors"
    source = (
        "three.js lights_physical_pars_fragment.glsl.js LTC_Evaluate (mat3(1.0)), "
        "LTC_EdgeVectorFormFactor, LTC_ClippedSphereFormFactor"
    )
    exact = "nowhere (the rational fit of theta / sin theta is within about 1e-3)"
    build = staticmethod(_three_rect)
    form_source = "three.js lights_physical_pars_fragment.glsl.js LTC_Evaluate with mat3(1.0)"
    form_engine = True
    form_note = (
        "the receiver's frame is the light's (three.js rotates into (T1, T2, N) first: the same "
        "form factor)"
    )


@register_area_model
class FrostbiteRect(RectModel):
    """Frostbite's rectangle light: solid angle times the mean clamped cosine of five
    representative points, its four corners and its centre (the module docstring)."""

    name = "frostbite_rect"
    default_free = ()
    formula = "Omega (sum of max(0, n.l_i) over corners and centre) / 5 / (4 hw hh)"
    source = "Lagarde & de Rousiers 2014, Moving Frostbite to PBR, §4.7.3 (rectangleSolidAngle)"
    exact = "nowhere (exact in the limit of a small rectangle wholly above the horizon)"
    build = staticmethod(_frostbite_rect)
    form_source = "Lagarde & de Rousiers 2014 §4.7.3, the rectangle light's illuminance listing"
    form_engine = True


@register_area_model
class MrpRect(RectModel):
    """Drobot's most representative point for a rectangle's diffuse light, weighted by the
    rectangle's solid angle: `E = L Omega max(0, n.l_d)`, `l_d` toward the point `p_d` (the
    module docstring)."""

    name = "mrp_rect"
    default_free = ()
    formula = "Omega max(0, n.l_d) / (4 hw hh), l_d toward Drobot's representative point"
    source = (
        "Drobot 2014, Physically Based Area Lights (GPU Pro 5), the area diffuse approximation "
        "algorithm (eqs. 1.13-1.14); E = Omega L <n.l> as Lagarde & de Rousiers 2014 §4.7 state it"
    )
    exact = "nowhere (exact in the limit of a small rectangle wholly above the horizon)"
    build = staticmethod(_mrp_rect)
    form_source = (
        "Drobot 2014 (GPU Pro 5) area diffuse approximation; Frostbite rectangleSolidAngle"
    )
    form_engine = False
    form_note = "the skew of a normal that misses the plane is attenfit's (Drobot leaves it open)"
