"""The named area-light models: the exact sphere, the disks, and the engines' horizon terms.

Each is a final `AreaModel` (`_area`), registered by name, citing the engine file and
function it transcribes, with its shader form (`shader_form`: the engine's expression, with
the engine's clamps); the tests check each model against a transcription of that code.
Sphere-shaped models return `g * w(cos_r, r/d) / max(d, r)^2`, `w` their horizon-aware cosine (`cos_r` itself
while the sphere is wholly above the horizon for the exact one).
"""

import math
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp

from .._errors import BadValueError
from .._ir import Expr, Lets, Ref, fn
from . import _parts as parts
from ._area import AreaModel, cone_cosine, contact_distance, register_area_model, safe_sqrt
from ._family import Param
from ._forms import area_shader, illuminance

__all__ = [
    "FrostbiteDisk",
    "GodotWrap",
    "HdrpSphere",
    "MrpSphere",
    "SnyderSphere",
    "UnrealWrap",
    "VectorDisk",
]


def _sphere_frame(d, r):
    """`(sin^2 a, 1/max(d, r)^2)` of a sphere of radius r at distance d (contact inside r)."""
    m = contact_distance(d, r)
    q = r / m
    inv = 1 / m
    return q * q, inv * inv


def _sphere_or_disk(let: Lets, x: dict[str, Ref], sin2: Ref, inv_area: Expr) -> Expr:
    """Frostbite's shader: `g illuminanceSphereOrDisk(cosTheta, sinSigmaSqr) / (pi r^2)`,
    cosTheta clamped to +-0.999 (Lagarde & de Rousiers 2014, section 4.7.2.4)."""
    ct = let("cos_theta", fn("clamp", x["cos_r"], -0.999, 0.999))
    inv = let("inv_pi_r2", inv_area)
    return x["g"] * illuminance(let, ct, sin2, "") * inv


# ----------------------------------------------------------------------------- exact sphere
@register_area_model
class SnyderSphere(AreaModel):
    """The exact irradiance of a Lambertian sphere, horizon clipping included.

    A sphere seen from a receiver is a uniform cone of half-angle `a`, `sin a = r/d`: its
    irradiance is a point light's, `I cos_r / d^2`, while the sphere is wholly above the
    horizon, and Snyder's clipped cone in between (Snyder 1996, "Area light sources for
    real-time graphics", MSR-TR-96-11; Howell's catalogue B-43). Frostbite ships it as
    `illuminanceSphereOrDisk(cosTheta, sinSigmaSqr)` with `sinSigmaSqr = min(r^2/d^2, 0.9999)`
    and `cosTheta` clamped to +-0.999 (Lagarde & de Rousiers 2014, "Moving Frostbite to PBR",
    section 4.7.2.4, the sphere evaluation); Unity HDRP keeps the same form as the `#else`
    branch of `DiffuseSphereLightIrradiance` (Packages/com.unity.render-pipelines.core/
    ShaderLibrary/AreaLighting.hlsl, "Ref: Moving Frostbite to Physically Based Rendering,
    page 47 (2015, optimized)"). Evaluated in the stable form of `cone_cosine`, without the
    engine's clamps (which the shader form keeps); a receiver inside the radius is read as
    touching the sphere. Capsules: the sphere at the closest point, times `g`.
    """

    name = "snyder_sphere"
    formula = "g K(cos_r, r/d) / (pi r^2): the clipped cone (docs/ground-truth.md §2)"
    source = (
        "Snyder 1996 (MSR-TR-96-11); Frostbite 2014 section 4.7.2.4 illuminanceSphereOrDisk; "
        "Unity HDRP AreaLighting.hlsl::DiffuseSphereLightIrradiance (#else branch)"
    )
    default_free = ()
    exact = "a sphere, every receiver outside it"

    def irradiance(self, d, cos_r, cos_e, r, cos_n, g):
        s2, inv_d2 = _sphere_frame(d, r)
        return g * cone_cosine(cos_r, s2) * inv_d2

    @area_shader(
        "Frostbite 2014 section 4.7.2.4 (illuminanceSphereOrDisk, sphere evaluation)",
        engine=True,
        note="clamps cosTheta to +-0.999 and sin^2 to 0.9999 (the engine's); 1/(pi r^2) folded",
    )
    def shader_form(self, let, x, p):
        r = p["radius"]
        sin2 = let("sin_sigma_sqr", fn("min", r * r / (x["d"] * x["d"]), 0.9999))
        return _sphere_or_disk(let, x, sin2, 1.0 / (math.pi * r * r))


# ----------------------------------------------------------------------------- disks
@register_area_model
class FrostbiteDisk(AreaModel):
    """Frostbite's disk: the sphere's clipped cone with the disk's angle, times `max(0, cos_e)`.

    Lagarde & de Rousiers 2014, section 4.7.2.4 (disk evaluation):
    `sinSigmaSqr = r^2 / (r^2 + max(r^2, sqrDist))`, `sqrDist` the squared distance to the
    centre, and `illuminanceSphereOrDisk(dot(N, L), sinSigmaSqr) * saturate(dot(planeNormal,
    -L))` ("to better match ground truth"). It is Howell's B-13 (a coaxial receiver, any tilt)
    for d >= r; the `max(r^2, .)` ("do not let the surface penetrate the light") makes it up
    to 97% low below that, and off the axis it is an approximation (docs/ground-truth.md
    §3.7). `g` replaces `saturate(cos_e)` when given (a two-sided disk).
    """

    name = "frostbite_disk"
    formula = "g K(cos_r, sin s) / (pi r^2), sin^2 s = r^2/(r^2 + max(r^2, d^2))"
    source = "Frostbite 2014 section 4.7.2.4 (disk evaluation of illuminanceSphereOrDisk)"
    default_free = ()
    light = "disk"
    exact = "coaxial receivers at d >= r, any tilt"

    def irradiance(self, d, cos_r, cos_e, r, cos_n, g):
        h = parts.stable_hypot(r, contact_distance(d, r))
        q = r / h
        inv = 1 / h
        return g * cone_cosine(cos_r, q * q) * (inv * inv)

    @area_shader(
        "Frostbite 2014 section 4.7.2.4 (illuminanceSphereOrDisk, disk evaluation)",
        engine=True,
        note="g stands for saturate(dot(planeNormal, -L)); cosTheta clamped to +-0.999",
    )
    def shader_form(self, let, x, p):
        r2 = let("r2", p["radius"] * p["radius"])
        sin2 = let("sin_sigma_sqr", r2 / (r2 + fn("max", r2, x["d"] * x["d"])))
        return _sphere_or_disk(let, x, sin2, 1.0 / (math.pi * r2))


#: Where 4 s^2 r^2 / (d^2 + r^2)^2 exceeds this, S is formed as a product (near the rim).
_RIM = 0.75


@register_area_model
class VectorDisk(AreaModel):
    """The exact irradiance of a one-sided disk above the horizon, and a sphere cap below it.

    While the whole disk is above the receiver's horizon (`d cos_r >= r sqrt(1 - cos_n^2)`),
    `E` is Gershun's vector irradiance, linear in the normal (docs/ground-truth.md §3.5):
    `E/I = [Q cos_n + 2 z (d cos_r - z cos_n)] / (S (S + a))`, `z = d cos_e`, `s^2 = d^2 - z^2`,
    `a = d^2 + r^2`, `S = sqrt(a^2 - 4 s^2 r^2)`, `Q = S + z^2 + r^2 - s^2` (Howell B-12/B-14
    and the perpendicular element as special cases). Where the horizon cuts the disk, `clip`
    says what stands in for the exact contour integral: "cap" (default) the sphere cap with
    the same vector form factor `F` (`sin^2 = |F|`, axis `F/|F|`), evaluated by the clipped
    cone: Hill & Heitz 2016, "Real-Time Area Lighting: a Journey from Research to
    Production" (slide 102), as Unity HDRP shades polygon lights (AreaLighting.hlsl,
    `DiffuseSphereLightIrradiance(sqrt(dot(F, F)), F.z / |F|)`); "clamp": `max(0, n.F)`.
    Zero behind the disk and with the disk wholly below the horizon.
    """

    clip: str = eqx.field(static=True, default="cap")

    name = "vector_disk"
    formula = (
        "[Q cos_n + 2 z (d cos_r - z cos_n)] / (S (S + a)) above the horizon; a sphere cap "
        "of the same vector form factor (clip = cap) or max(0, .) (clip = clamp) below"
    )
    source = (
        "Howell B-12/B-14; Gershun's light vector (docs/ground-truth.md §3.5); Hill & Heitz "
        "2016 slide 102 and Unity HDRP AreaLighting.hlsl (the cap of the vector form factor)"
    )
    default_free = ()
    light = "disk"
    exact = "a one-sided disk wholly above the receiver's horizon"
    clips: ClassVar[tuple[str, ...]] = ("cap", "clamp")

    def __check_init__(self):
        if self.clip not in self.clips:
            raise BadValueError(
                f"vector_disk: clip must be one of {list(self.clips)}, got {self.clip!r}"
            )

    def irradiance(self, d, cos_r, cos_e, r, cos_n, g):
        lam = parts.stable_hypot(d, r)
        inv = 1 / lam
        dt, rt = d * inv, r * inv  # lengths over sqrt(d^2 + r^2): nothing overflows
        zt = dt * cos_e
        st2 = dt * dt * ((1 - cos_e) * (1 + cos_e))
        four = 4 * st2 * rt * rt
        rim = four > _RIM
        st = safe_sqrt(st2)
        s_rim = jnp.sqrt(zt * zt + (st - rt) ** 2) * jnp.sqrt(zt * zt + (st + rt) ** 2)
        s_far = jnp.sqrt(1 - jnp.where(rim, jnp.zeros_like(four), four))
        S = jnp.where(rim, s_rim, s_far)
        q0 = zt * zt + rt * rt - st2
        low = q0 < 0
        Q = jnp.where(low, 4 * st2 * zt * zt / jnp.where(low, S - q0, jnp.ones_like(S)), S + q0)
        num = Q * cos_n + 2 * zt * dt * (cos_r - cos_e * cos_n)
        den = S * (S + 1)
        den = jnp.where(den > 0, den, jnp.ones_like(den))
        e_vec = jnp.maximum(num / den, 0) * (inv * inv)
        w = safe_sqrt((1 - cos_n) * (1 + cos_n))
        above = d * cos_r >= r * w
        below = d * cos_r <= -r * w
        if self.clip == "clamp":
            e_clip = e_vec
        else:
            f_len = parts.stable_hypot(jnp.abs(Q), jnp.abs(2 * zt * st))  # |F| den / rt^2
            f_safe = jnp.where(f_len > 0, f_len, jnp.ones_like(f_len))
            sin2 = jnp.minimum(rt * rt * f_len / den, 1)
            cos_w = jnp.clip(num / f_safe, -1, 1)
            e_clip = cone_cosine(cos_w, sin2) * (f_len / den) * (inv * inv)
        lit = (cos_e > 0) & ~below
        return jnp.where(lit, jnp.where(above, e_vec, e_clip), jnp.zeros_like(d))

    @area_shader(
        "Howell B-12/B-14 (the vector irradiance of a disk); the clipped case as Hill & "
        "Heitz 2016 slide 102 and Unity HDRP AreaLighting.hlsl (a sphere cap of the same "
        "form factor, evaluated by Frostbite's illuminanceSphereOrDisk)",
        engine=False,
        note="unguarded: no rescaling by sqrt(d^2 + r^2), no product form near the rim",
    )
    def shader_form(self, let: Lets, x: dict[str, Ref], p: dict[str, Ref]) -> Expr:
        """`irradiance` without its guards."""
        d, cr, ce, cn, radius = x["d"], x["cos_r"], x["cos_e"], x["cos_n"], p["radius"]
        r2 = let("r2", radius * radius)
        z = let("z", d * ce)
        s2 = let("s2", d * d - z * z)
        a = let("a", d * d + r2)
        big_s = let("big_s", fn("sqrt", fn("max", a * a - 4.0 * s2 * r2, 0.0)))
        q = let("q", big_s + z * z + r2 - s2)
        num = let("num", q * cn + 2.0 * z * (d * cr - z * cn))
        den = let("den", big_s * (big_s + a))
        e_vec = let("e_vec", fn("max", num, 0.0) / den)
        if self.clip == "clamp":  # max(0, n.F) where the horizon cuts it too
            e_clip: Expr = e_vec
        else:
            f_len = let("f_len", fn("sqrt", q * q + 4.0 * z * z * s2))  # |F| den / r^2
            sin2 = let("cap_sin2", fn("min", r2 * f_len / den, 0.9999))
            cos_w = let("cap_cos", fn("clamp", num / f_len, -0.999, 0.999))
            e_clip = illuminance(let, cos_w, sin2, "cap_") * (f_len / (math.pi * sin2 * den))
        w = let("w", fn("sqrt", fn("max", 1.0 - cn * cn, 0.0)))
        above = fn("ge", d * cr, radius * w)
        lit = fn("select", ce > 0.0, fn("select", above, e_vec, e_clip), 0.0)
        return fn("select", d * cr > -radius * w, lit, 0.0)


# ----------------------------------------------------------------------------- horizon wraps
@register_area_model
class UnrealWrap(AreaModel):
    """Unreal's horizon wrap of N.L for sphere lights, over the sphere's 1/d^2.

    Unreal Engine `Engine/Shaders/Private/CapsuleLight.ush::SphereHorizonCosWrap(NoL,
    SinAlphaSqr)` (described here, not copied: Epic's code is under its EULA): where `N.L`
    is below `sin a` it is replaced by the Hermite spline with value 0 and slope 0 at
    `-sin a` and value `sin a` and slope 1 at `sin a`, which is the quadratic
    `(N.L + sin a)^2 / (4 sin a)` (0 below `-sin a`); the engine's comment calls it fairly
    accurate for `sin a < 0.8`. `SinAlphaSqr = saturate(r^2 / d^2)`. The engine's falloff is
    `1/(d^2 + 1 cm^2)`; here `1/max(d, r)^2`, the sphere's exact facing curve, so that only
    the angular term is compared. `k` scales the wrap's half-width `sin a` (1: the engine's).
    """

    k: Param = 1.0

    name = "unreal_wrap"
    formula = "g w / max(d, r)^2; w = cos_r above k sin a, (cos_r + k sin a)^2 / (4 k sin a) down to -k sin a, 0 below; sin a = r/d"
    source = "Unreal Engine CapsuleLight.ush::SphereHorizonCosWrap (Hermite spline); described, not copied"
    default_free = ("k",)
    exact = "a sphere wholly above the horizon (k = 1)"

    def irradiance(self, d, cos_r, cos_e, r, cos_n, g):
        (k,) = parts.promote(d, self.k)[1:]
        s2, inv_d2 = _sphere_frame(d, r)
        s = k * safe_sqrt(s2)
        s_safe = jnp.where(s > 0, s, jnp.ones_like(s))
        wrapped = (cos_r + s) ** 2 / (4 * s_safe)
        w = jnp.where(cos_r >= s, cos_r, jnp.where(cos_r > -s, wrapped, jnp.zeros_like(cos_r)))
        return g * w * inv_d2

    @area_shader(
        "Unreal Engine CapsuleLight.ush::SphereHorizonCosWrap; described, not copied",
        engine=True,
        note="the sphere's 1/max(d, r)^2 for the engine's 1/(d^2 + 1 cm^2)",
    )
    def shader_form(self, let, x, p):
        inv = let("inv_d", 1.0 / fn("max", x["d"], p["radius"]))
        s2 = fn("saturate", p["radius"] * p["radius"] * inv * inv)
        s = let("sin_a", p["k"] * fn("sqrt", s2))
        c = let("nol", fn("max", x["cos_r"], -s))
        w = fn("select", x["cos_r"] < s, (c + s) * (c + s) / (4.0 * s), x["cos_r"])
        return x["g"] * w * inv * inv


@register_area_model
class GodotWrap(AreaModel):
    """Godot 4's light-size wrap of N.L, over the sphere's 1/d^2.

    Godot `servers/rendering/renderer_rd/shaders/scene_forward_lights_inc.glsl`:
    `light_process_omni` computes `t = size / max(0.001, light_length)`,
    `size_A = max(0, 1 - 1/sqrt(1 + t*t))`, and `light_compute` shades Lambert with
    `NdotL = min(A + dot(N, L), 1)`, `cNdotL = max(NdotL, 0)`; `size` is the light's
    `LIGHT_PARAM_SIZE` (`light_storage.cpp`), read here as `k r` (k = 1: the size is the
    radius). The engine's distance term is its windowed `get_omni_attenuation`; here
    `1/max(d, r)^2`, and `t = k r / max(d, r)`, so that only the angular term is compared.
    Unlike the exact form it adds `A` to every receiver's cosine, above the horizon too.
    """

    k: Param = 1.0

    name = "godot_wrap"
    formula = "g clamp(A + cos_r, 0, 1) / max(d, r)^2, A = 1 - 1/sqrt(1 + (k r/d)^2)"
    source = "Godot 4 scene_forward_lights_inc.glsl::light_process_omni (size_A) and light_compute (NdotL = min(A + dot(N, L), 1))"
    default_free = ("k",)

    def irradiance(self, d, cos_r, cos_e, r, cos_n, g):
        (k,) = parts.promote(d, self.k)[1:]
        s2, inv_d2 = _sphere_frame(d, r)
        t2 = k * k * s2
        root = jnp.sqrt(1 + t2)
        size_a = t2 / (root * (1 + root))  # 1 - 1/sqrt(1 + t^2), without the cancellation
        return g * jnp.clip(size_a + cos_r, 0, 1) * inv_d2

    @area_shader(
        "Godot 4 scene_forward_lights_inc.glsl::light_process_omni (size_A) and light_compute",
        engine=True,
        note="t = k r / max(d, r) for size / max(0.001, light_length); 1/max(d, r)^2 for "
        "the engine's windowed falloff",
    )
    def shader_form(self, let, x, p):
        inv = let("inv_d", 1.0 / fn("max", x["d"], p["radius"]))
        t = let("t", p["k"] * p["radius"] * inv)
        size_a = let("size_a", fn("max", 1.0 - 1.0 / fn("sqrt", 1.0 + t * t), 0.0))
        ndotl = fn("max", fn("min", size_a + x["cos_r"], 1.0), 0.0)
        return x["g"] * ndotl * inv * inv


@register_area_model
class HdrpSphere(AreaModel):
    """Unity HDRP's fitted sphere irradiance: a polynomial in `sin^2 a` and `cos_r`.

    Unity `Packages/com.unity.render-pipelines.core/ShaderLibrary/AreaLighting.hlsl::
    DiffuseSphereLightIrradiance(sinSqSigma, cosOmega)` under `APPROXIMATE_SPHERE_LIGHT_NUMERICALLY`
    (the default): with `x = sinSqSigma`, `y = cosOmega`, the form factor is
    `saturate(x (y + e) (0.5 + (y - e)(a0 + a1 x + a2 x^2 + a3 x^3)))` (Mathematica's
    `NonlinearModelFit` over x in [0, 1), y in (-1, 1); "mean absolute error: 0.00476944").
    `E / I` is the form factor over `r^2`. The defaults are the engine's coefficients; a fit
    moves all five.
    """

    a0: Param = 0.5359050373687144
    a1: Param = -1.0054221851257754
    a2: Param = 1.8199061187417047
    a3: Param = -1.3172081704209504
    e: Param = 0.9245867471551246

    name = "hdrp_sphere"
    formula = "g clamp(P, 0, 1/x) / max(d, r)^2, P = (y + e)(1/2 + (y - e)(a0 + a1 x + a2 x^2 + a3 x^3)), x = r^2/d^2, y = cos_r"
    source = "Unity HDRP AreaLighting.hlsl::DiffuseSphereLightIrradiance (APPROXIMATE_SPHERE_LIGHT_NUMERICALLY)"
    default_free = ("a0", "a1", "a2", "a3", "e")
    constraints: ClassVar = dict.fromkeys(("a0", "a1", "a2", "a3", "e"), "real")

    def irradiance(self, d, cos_r, cos_e, r, cos_n, g):
        a0, a1, a2, a3, e = parts.promote(d, self.a0, self.a1, self.a2, self.a3, self.e)[1:]
        x, inv_d2 = _sphere_frame(d, r)
        y = cos_r
        p = (y + e) * (0.5 + (y - e) * (a0 + x * (a1 + x * (a2 + x * a3))))
        cap = 1 / jnp.where(x > 0, x, jnp.ones_like(x))
        return g * jnp.clip(p, 0, cap) * inv_d2

    @area_shader(
        "Unity HDRP AreaLighting.hlsl::DiffuseSphereLightIrradiance "
        "(APPROXIMATE_SPHERE_LIGHT_NUMERICALLY)",
        engine=True,
        note="sinSqSigma = min(r^2/d^2, 0.9999); the form factor over r^2",
    )
    def shader_form(self, let, x, p):
        s2 = let("x", fn("min", p["radius"] * p["radius"] / (x["d"] * x["d"]), 0.9999))
        y = x["cos_r"]
        poly = p["a0"] + s2 * (p["a1"] + s2 * (p["a2"] + s2 * p["a3"]))
        ff = fn("saturate", s2 * (y + p["e"]) * (0.5 + (y - p["e"]) * poly))
        return x["g"] * ff / (p["radius"] * p["radius"])


@register_area_model
class MrpSphere(AreaModel):
    """The most representative point for diffuse: the sphere's solid angle times the cosine
    of its direction nearest the normal.

    Drobot 2014 ("Physically Based Area Lights", GPU Pro 5) approximates a light's diffuse
    irradiance by `Omega L <n.l>` with `l` its most representative point, as Frostbite 2014
    section 4.7.2.5 writes it for rectangles; for a sphere, `Omega = 2 pi (1 - cos a)` and the
    direction within its cone nearest the normal makes the angle `max(theta - a, 0)`. (Karis
    2013's representative point, the closest point of the light to a ray, is the specular
    counterpart: with the normal as the ray it leaves `n.l` unchanged in sign, `n.P = n.L`,
    so it cannot see below the horizon.) Drobot's chapter itself was not readable here: the
    form follows Frostbite's description. Reaches `-sin a` exactly, but is `2/(1 + cos a)`
    times the truth facing the sphere. No parameters.
    """

    name = "mrp_sphere"
    formula = "g 2/(1 + cos a) cos(max(theta - a, 0))+ / max(d, r)^2, sin a = r/d"
    source = "Drobot 2014 (GPU Pro 5) most representative point, via Frostbite 2014 section 4.7.2.5"
    default_free = ()

    def irradiance(self, d, cos_r, cos_e, r, cos_n, g):
        s2, inv_d2 = _sphere_frame(d, r)
        ca = safe_sqrt(1 - s2)
        sin_t = safe_sqrt((1 - cos_r) * (1 + cos_r))
        nearest = jnp.where(cos_r >= ca, jnp.ones_like(cos_r), cos_r * ca + sin_t * safe_sqrt(s2))
        return g * (2 / (1 + ca)) * jnp.maximum(nearest, 0) * inv_d2

    @area_shader(
        "Drobot 2014 (GPU Pro 5) most representative point, via Frostbite 2014 section 4.7.2.5",
        engine=False,
        note="inside the radius, sin^2 a clamped to 1",
    )
    def shader_form(self, let, x, p):
        inv = let("inv_d", 1.0 / fn("max", x["d"], p["radius"]))
        s2 = let("sin2", fn("saturate", p["radius"] * p["radius"] * inv * inv))
        ca = let("cos_a", fn("sqrt", 1.0 - s2))
        c = x["cos_r"]
        side = c * ca + fn("sqrt", fn("max", 1.0 - c * c, 0.0)) * fn("sqrt", s2)
        near = fn("select", fn("ge", c, ca), 1.0, side)
        return x["g"] * (2.0 / (1.0 + ca)) * fn("max", near, 0.0) * inv * inv
