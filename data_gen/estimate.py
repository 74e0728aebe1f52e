"""Irradiance at receivers by Monte Carlo with Mitsuba 3's own light sampling and ray tracing.

For a receiver at p with unit normal n, E(p, n) = int L(omega) max(0, n . omega) d omega
(docs/architecture.md, Conventions). Each of the `spp` samples combines two directions by multiple
importance sampling with the balance heuristic (Veach 1997, ch. 9; the same pairing as
Mitsuba's `direct` and `path` integrators, `src/integrators/direct.cpp`):

* light sampling: `Scene.sample_emitter_direction(ref, u, test_visibility=True)` (Mitsuba 3,
  `src/render/scene.cpp`) picks a point on a light (a sphere samples the cone it subtends,
  `src/shapes/sphere.cpp`; a disk or cylinder samples its area), traces a shadow ray against
  every shape and returns omega, the solid-angle pdf p_L and weight = L / p_L (0 if blocked
  or facing away). Contribution: L cos / (p_L + cos / pi).
* cosine sampling: omega from `warp.square_to_cosine_hemisphere` about n, traced with
  `Scene.ray_intersect`; if it first hits a light, that light's `eval` gives L and
  `Scene.pdf_emitter_direction` gives p_L. Contribution: L cos / (p_L + cos / pi).

Both contributions are at most pi L, so the variance is bounded everywhere. Light sampling
alone (value = weight * cos) is what `strategy="auto"` uses for sphere lights: cone sampling
is bounded too (value <= L * solid angle) and nearly exact far away, where MIS would add
the cosine samples' hit-or-miss noise (16x the standard error of a facing sphere at 3 r).
For a disk or a capsule's tube (area sampling) light sampling alone has values
~ h / dist^3 with a heavy tail next to the surface: at h = 0.01 r, 2048 samples gave
0.31 +- 0.06 for an exact 1.90 (the sample variance misses the rare huge values), where MIS
with 1M samples gives 1.8959 +- 0.0019; so `auto` uses MIS there.

The light's geometry, occluders such as a plane under the light and the receiver's horizon
are all handled by Mitsuba's sampling and ray tracing, not by attenfit's formulas; only the
cosine max(0, n . omega) is ours, and it is the definition of irradiance.

The uniform numbers u (four per sample) come from numpy (`SeedSequence([seed, receiver
index, component])`, float32), so a receiver's estimate depends only on the seed and its
global index: chunked and whole runs agree, and `scalar_rgb` and `llvm_ad_rgb` see identical
samples (they agree to float32 rounding). Sums are taken in float64.

Rays. Shadow rays are spawned from the sampled point on the light towards the receiver
(Mitsuba's `Interaction::spawn_ray_to` at the light), cosine rays start at the receiver
itself (or just above the occluding plane for receivers on it): Mitsuba's spawn offset,
`(1 + max|p|) * 1500 * 2^-24` along the receiver's normal, moved receivers near a light
behind or beside it (`data_gen.clearance`, docs/mitsuba.md).

Uncertainty. The standard error is the Monte Carlo one, sd(values)/sqrt(N), combined in
quadrature with bounds b on float32 biases that averaging does not remove, each as
b/sqrt(3) (the standard deviation of a uniform error in [-b, b]), only where they are real:

* 2^-20 |E| for float32 arithmetic in the sampling routines;
* near a sphere light (and a capsule's ends), E (2^-13 r / gap)^2 for Mitsuba's cone
  sampler (`_cone_bias`). The sampled cone's float32 solid angle, which biased far spheres
  (-2.2e-3 relative at 300 r, +7.3% at 1000 r, facing), is corrected per sample instead
  (`_cone_factor`); with MIS forced on spheres, where it is not, 2 pi L 2^-23 per sphere;

and B / (N (k + 1)) with B the largest value one sample can take there and k the non-zero
samples (`_sample_bound`): a light showing a sliver above the horizon is hit by few samples,
whose variance misses what they did not see. Median |z| over a few hundred random receivers
is then 0.65-0.72 (0.674 for exact standard errors; docs/mitsuba.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
from jaxtyping import Float

from attenfit import BadTypeError, BadValueError

from .clearance import check_clearance, ray_origins
from .scenes import (
    LIGHT_TYPES,
    DiskLight,
    Light,
    Plane,
    RectLight,
    SphereLight,
    light_spheres,
    scene_components,
)
from .variants import select_variant, use_variant

__all__ = [
    "DEFAULT_LANES",
    "MAX_SPP",
    "STRATEGIES",
    "Estimate",
    "estimate_detail",
    "estimate_irradiance",
]

DEFAULT_LANES = 1 << 20  # samples per LLVM kernel launch (about 100 MB of temporaries)
MAX_SPP = 1 << 24
STRATEGIES = ("auto", "mis", "emitter")
_FLOOR_REL = 2.0**-20
_CONE_COS_ERR = 2.0**-23
_POLE_REL = 2.0**-13  # the cone sampler's pole scramble, relative to r, with margin (see below)

Progress = Callable[[int, int], None]


class Estimate(NamedTuple):
    """Per-receiver results: `E`, `stderr` (combined), `mc_stderr`, `bias_bound`, `variant`."""

    E: np.ndarray
    stderr: np.ndarray
    mc_stderr: np.ndarray
    bias_bound: np.ndarray
    variant: str


def _check_receivers(points, normals) -> tuple[np.ndarray, np.ndarray]:
    p = np.asarray(points, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise BadValueError(f"points must have shape (n, 3), got {p.shape}")
    if n.shape != p.shape:
        raise BadValueError(f"normals must have the shape of points {p.shape}, got {n.shape}")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(n))):
        raise BadValueError("points and normals must be finite")
    lengths = np.linalg.norm(n, axis=1)
    bad = np.flatnonzero(np.abs(lengths - 1.0) > 1e-6)
    if bad.size:
        raise BadValueError(
            f"normals must be unit vectors; normals[{bad[0]}] has length {lengths[bad[0]]:.9g}"
        )
    return p, n


def _check_args(lights, points, normals, spp, seed, first_index):
    if isinstance(lights, LIGHT_TYPES):
        lights = [lights]
    elif not isinstance(lights, Sequence):
        raise BadTypeError(f"lights must be a list of lights, got {type(lights).__name__}")
    lights = list(lights)
    p, n = _check_receivers(points, normals)
    if isinstance(spp, bool) or not isinstance(spp, int | np.integer) or not 2 <= spp <= MAX_SPP:
        raise BadValueError(f"spp must be an integer in [2, {MAX_SPP}], got {spp!r}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise BadValueError(f"seed must be a non-negative integer, got {seed!r}")
    if not isinstance(first_index, int | np.integer) or first_index < 0:
        raise BadValueError(f"first_index must be a non-negative integer, got {first_index!r}")
    bad = [i for i, light in enumerate(lights) if not isinstance(light, LIGHT_TYPES)]
    if bad:
        raise BadTypeError(
            f"lights[{bad[0]}] must be a SphereLight, DiskLight, CapsuleLight, RectLight or TubeLight, "
            f"got {type(lights[bad[0]]).__name__}"
        )
    if lights:
        check_clearance(lights, p)
    return lights, p, n, int(spp), int(seed), int(first_index)


def _uniforms(seed: int, index: int, component: int, spp: int) -> np.ndarray:
    """(spp, 4) float32 uniforms: columns 0-1 for the light sample, 2-3 for the cosine one."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, index, component]))
    return rng.random((spp, 4), dtype=np.float32)


def _cone_factor(points, ds_p, pdf, spheres) -> np.ndarray:
    """Per light sample: the exact solid angle of the sampled sphere over Mitsuba's float32 one.

    Mitsuba's cone sampling (`src/shapes/sphere.cpp`, `Sphere::sample_direction`) weighs a
    sample by 1 / pdf = Omega_32 = 2 pi (1 - cos_theta_max) with cos_theta_max =
    sqrt(1 - (r/D)^2) in float32, which cancels far away (+7% at 1000 r). Multiplying by
    Omega / Omega_32 = Omega * pdf * K (K emitting spheres, picked uniformly by
    `Scene::sample_emitter`), with Omega = 2 pi s^2 / (1 + sqrt(1 - s^2)), s = r / D, in
    float64, removes that bias: beyond sin^2 theta_max = 6.85e-4 (D > 38.2 r) Mitsuba draws
    the directions from the exact cone (its small-angle branch) and only the weight is off.
    `points` and `ds_p` are (N, 3) receivers and sampled points, `pdf` (N,).
    """
    p = np.asarray(points, dtype=np.float64)
    x = np.asarray(ds_p, dtype=np.float64)
    centres = np.array([c for c, _ in spheres], dtype=np.float64)
    radii = np.array([r for _, r in spheres], dtype=np.float64)
    # the sampled sphere: the one whose surface the sampled point lies on
    off = np.abs(np.linalg.norm(x[:, None, :] - centres[None], axis=2) - radii[None])
    k = np.argmin(off, axis=1)
    D = np.linalg.norm(p - centres[k], axis=1)
    s2 = np.minimum((radii[k] / D) ** 2, 1.0)
    omega = 2.0 * math.pi * s2 / (1.0 + np.sqrt(1.0 - s2))
    return omega * np.asarray(pdf, dtype=np.float64) * len(spheres)


def _values_scalar(mi, scene, p, n, u, clip, strategy: str, origin, spheres) -> np.ndarray:
    """One receiver, Python calls per sample (the scalar variant has no vectorisation)."""
    ref = mi.Interaction3f()
    ref.p = mi.Point3f(*p.tolist())
    ref.n = mi.Normal3f(*n.tolist())
    frame = mi.Frame3f(ref.n)
    n0, n1, n2 = n.tolist()
    (q0, q1, q2), (a0, a1, a2) = clip if clip is not None else ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    mis = strategy == "mis"
    sample, pdf = scene.sample_emitter_direction, scene.pdf_emitter_direction
    Point2f, cosine = mi.Point2f, mi.warp.square_to_cosine_hemisphere
    at_light = mi.Interaction3f()
    start = mi.Point3f(*origin.tolist())
    inv_pi = 1.0 / math.pi
    out = np.empty(len(u), dtype=np.float64)
    cone = bool(spheres) and not mis
    xs = np.zeros((len(u), 3)) if cone else None
    pdfs = np.zeros(len(u)) if cone else None
    for k, (u0, u1, u2, u3) in enumerate(u.tolist()):
        # light sampling: weight = L / pdf, 0 if facing away; the shadow ray is spawned from
        # the light (`_shadow_ray`), not from the receiver
        ds, weight = sample(ref, Point2f(u0, u1), False)
        d = ds.d
        cos = n0 * d[0] + n1 * d[1] + n2 * d[2]
        x = ds.p
        if clip is not None and cos > 0.0:
            if (x[0] - q0) * a0 + (x[1] - q1) * a1 + (x[2] - q2) * a2 > 0.0:
                cos = 0.0
        value = 0.0
        if cos > 0.0 and ds.pdf > 0.0 and weight[0] > 0.0:
            at_light.p, at_light.n = x, ds.n
            if not scene.ray_test(at_light.spawn_ray_to(ref.p)):
                value = weight[0] * cos
                if mis:
                    value *= ds.pdf / (ds.pdf + cos * inv_pi)
                elif cone:
                    xs[k] = (x[0], x[1], x[2])
                    pdfs[k] = ds.pdf
        if mis:
            # cosine-weighted direction: the light's radiance where the ray first hits
            d = frame.to_world(cosine(Point2f(u2, u3)))
            si = scene.ray_intersect(mi.Ray3f(start, d))
            em = si.emitter(scene) if si.is_valid() else None
            if em is not None:
                x = si.p
                if clip is None or (x[0] - q0) * a0 + (x[1] - q1) * a1 + (x[2] - q2) * a2 <= 0.0:
                    cos_b = n0 * d[0] + n1 * d[1] + n2 * d[2]
                    p_light = pdf(ref, mi.DirectionSample3f(scene, si, ref))
                    value += em.eval(si)[0] * cos_b / (p_light + cos_b * inv_pi)
        out[k] = value
    if cone:
        lit = pdfs > 0.0
        out[lit] *= _cone_factor(np.broadcast_to(p, xs.shape)[lit], xs[lit], pdfs[lit], spheres)
    return out


def _values_llvm(mi, scene, p, n, u, clip, strategy: str, origins, spheres) -> np.ndarray:
    """Many lanes at once: p, n, u, `origins` (of cosine rays) are (lanes, 3), (lanes, 3),
    (lanes, 4), (lanes, 3) float32 arrays."""
    import drjit as dr

    ref = dr.zeros(mi.Interaction3f, len(u))
    ref.p = mi.Point3f(p[:, 0], p[:, 1], p[:, 2])
    ref.n = mi.Normal3f(n[:, 0], n[:, 1], n[:, 2])
    if clip is not None:
        q, axis = mi.Point3f(*clip[0]), mi.Vector3f(*clip[1])
    ds, weight = scene.sample_emitter_direction(ref, mi.Point2f(u[:, 0], u[:, 1]), False)
    cos = dr.maximum(dr.dot(ds.d, ref.n), 0.0)
    active = (ds.pdf > 0.0) & (cos > 0.0) & (weight[0] > 0.0)
    # the shadow ray from the light's surface to the receiver (`_shadow_ray`)
    at_light = dr.zeros(mi.Interaction3f, len(u))
    at_light.p, at_light.n = ds.p, ds.n
    active &= ~scene.ray_test(at_light.spawn_ray_to(ref.p), active)
    value = weight[0] * cos
    if strategy == "mis":
        value *= ds.pdf / (ds.pdf + cos / dr.pi)
    value = dr.select(active, value, 0.0)
    if clip is not None:
        value = dr.select(dr.dot(ds.p - q, axis) > 0.0, 0.0, value)
    if len(spheres) == 1 and strategy != "mis":  # the usual case, inside the kernel
        centre, r = spheres[0]
        D = dr.norm(ref.p - mi.Point3f(*centre))
        s2 = dr.minimum(dr.square(r / D), 1.0)
        omega = 2.0 * dr.pi * s2 / (1.0 + dr.sqrt(1.0 - s2))  # no cancellation (float32 is
        return np.asarray((value * omega * ds.pdf).numpy(), dtype=np.float64)  # fine here)
    if spheres and strategy != "mis":
        out = np.asarray(value.numpy(), dtype=np.float64)
        lit = out > 0.0
        x = np.asarray(ds.p.numpy(), dtype=np.float64).reshape(-1, 3)
        if x.shape[0] != len(u):
            x = x.T
        pdf = np.asarray(ds.pdf.numpy(), dtype=np.float64)
        out[lit] *= _cone_factor(p[lit], x[lit], pdf[lit], spheres)
        return out
    if strategy == "mis":
        d = mi.Frame3f(ref.n).to_world(
            mi.warp.square_to_cosine_hemisphere(mi.Point2f(u[:, 2], u[:, 3]))
        )
        o = mi.Point3f(origins[:, 0], origins[:, 1], origins[:, 2])
        si = scene.ray_intersect(mi.Ray3f(o, d))
        hit = si.is_valid()
        p_light = scene.pdf_emitter_direction(ref, mi.DirectionSample3f(scene, si=si, ref=ref), hit)
        cos_b = dr.maximum(dr.dot(d, ref.n), 0.0)
        radiance = si.emitter(scene).eval(si, hit)[0]
        extra = dr.select(hit & (cos_b > 0.0), radiance * cos_b / (p_light + cos_b / dr.pi), 0.0)
        if clip is not None:
            extra = dr.select(dr.dot(si.p - q, axis) > 0.0, 0.0, extra)
        value += extra
    return np.asarray(value.numpy(), dtype=np.float64)


def _component_values(
    mi, variant, strategy, scene, comp, p, n, origins, spp, seed, first_index, lanes, tick
):
    """Yield (receiver, values) for every receiver of one scene component `(scene, Component)`."""
    count = len(p)
    clip, spheres = comp[1].clip, comp[1].spheres
    index = comp[0]
    if variant == "scalar_rgb":
        for i in range(count):
            u = _uniforms(seed, first_index + i, index, spp)
            yield i, _values_scalar(mi, scene, p[i], n[i], u, clip, strategy, origins[i], spheres)
            tick()
        return
    p32, n32, o32 = p.astype(np.float32), n.astype(np.float32), origins.astype(np.float32)
    per_launch = max(1, lanes // spp)
    for start in range(0, count, per_launch):
        block = range(start, min(count, start + per_launch))
        u = np.concatenate([_uniforms(seed, first_index + i, index, spp) for i in block])
        pl = np.repeat(p32[block.start : block.stop], spp, axis=0)
        nl = np.repeat(n32[block.start : block.stop], spp, axis=0)
        ol = np.repeat(o32[block.start : block.stop], spp, axis=0)
        values = np.concatenate(
            [
                _values_llvm(
                    mi,
                    scene,
                    pl[s : s + lanes],
                    nl[s : s + lanes],
                    u[s : s + lanes],
                    clip,
                    strategy,
                    ol[s : s + lanes],
                    spheres,
                )
                for s in range(0, len(u), lanes)
            ]
        )
        for k, i in enumerate(block):
            yield i, values[k * spp : (k + 1) * spp]
            tick()


def _cone_bias(c, how: str, points: np.ndarray, E_c: np.ndarray, lights) -> np.ndarray:
    """Bounds on the float32 biases of a component's sphere lights (0 for disks and tubes).

    * Light sampling (`_cone_factor` removes the cone's float32 solid angle): Mitsuba's
      sampler computes the angle alpha at the centre through cos(alpha) in float32 and then
      sin(alpha) = sqrt(1 - cos^2 alpha), whose square is off by up to 2^-23: points it
      places within r 2^-11.5 = 3.5e-4 r of the pole (the point nearest the receiver) land
      anywhere in that patch. A receiver at gap delta above the surface sees the patch's
      directions scrambled by ~(r 2^-11.5 / delta), a second-order bias in E. Measured here
      (2^21 samples, facing, 1 and 1.5 rad tilted; gap/r = 3e-4, 1e-3, 3e-3, 1e-2): +2.1e-2,
      +2.8e-2, -7.8e-2; +4.4e-3, +1.7e-3, -5.2e-3; +6.4e-4, +1.3e-4, -7.6e-4; all < 4.2e-4.
      Bound: E (2^-13 r / delta)^2, 1.4 to 2.2 times the largest measured.
    * MIS (no correction of the cone's weight): 2 pi L 2^-23 per sphere (the module docstring).
    """
    if not c.cone:
        return np.zeros(len(points))
    if how == "mis":
        L = sum(sp.radiance for lt in lights for sp in light_spheres(lt))
        return np.full(len(points), 2.0 * math.pi * L * _CONE_COS_ERR)
    ratio = np.zeros(len(points))
    for centre, r in c.spheres:
        gap = np.linalg.norm(points - np.asarray(centre), axis=1) - r
        ratio = np.maximum(ratio, (_POLE_REL * r / np.maximum(gap, 1e-300)) ** 2)
    return np.abs(E_c) * ratio


def _angle_factor(points, normals, centre, radius) -> np.ndarray:
    """The largest n . omega over directions omega into a ball (centre, radius), clipped at 0."""
    rel = np.asarray(centre) - points
    dist = np.linalg.norm(rel, axis=1)
    half = np.arcsin(np.clip(radius / np.maximum(dist, 1e-300), 0.0, 1.0))
    cos_a = np.clip(np.einsum("ij,ij->i", normals, rel) / np.maximum(dist, 1e-300), -1.0, 1.0)
    return np.clip(np.cos(np.maximum(np.arccos(cos_a) - half, 0.0)), 0.0, 1.0)


def _sample_bound(lights, points, normals) -> np.ndarray:
    """B: the largest value one sample can take at each receiver (the floor's scale, see below).

    Sphere (light sampling): L Omega c, Omega the subtended solid angle and c the largest
    cosine over the cone. Disk or capsule (MIS): each of the two terms is at most pi L and at
    most L A / d^2 (A the area, d the distance to the nearest point of the light: the light
    term is L cos cos_l A / dist^2 and the cosine term L cos / (p_L + cos / pi) <= L cos / p_L,
    p_L = dist^2 / (A cos_l)), times c over the light's bounding ball. K lights: K times the
    largest.
    """
    from attenfit._truth._clearance import surface_distance

    from .clearance import emitter_of

    bounds = []
    for light in lights:
        L = light.radiance
        if isinstance(light, SphereLight):
            dist = np.linalg.norm(points - np.asarray(light.center), axis=1)
            s2 = np.clip((light.radius / dist) ** 2, 0.0, 1.0)
            omega = 2.0 * math.pi * s2 / (1.0 + np.sqrt(1.0 - s2))
            c = _angle_factor(points, normals, light.center, light.radius)
            bounds.append(L * omega * c)
            continue
        if isinstance(light, DiskLight):
            centre, ball = np.asarray(light.center), light.radius
            area = math.pi * light.radius**2
        elif isinstance(light, RectLight):
            centre, ball = np.asarray(light.center), math.hypot(light.width, light.height) / 2
            area = light.width * light.height
        else:
            a, b = np.asarray(light.a), np.asarray(light.b)
            centre, half = (a + b) / 2, float(np.linalg.norm(b - a)) / 2
            ball = light.radius + half
            area = 4.0 * math.pi * light.radius * (light.radius + half)
        d = surface_distance(emitter_of(light), points)
        term = np.minimum(math.pi * L, L * area / np.maximum(d, 1e-300) ** 2)
        bounds.append(2.0 * term * _angle_factor(points, normals, centre, ball))
    return len(lights) * np.max(bounds, axis=0)


def _strategy(strategy: str, cone: bool) -> str:
    """The sampling used for a component: 'auto' is light sampling alone for spheres, else MIS."""
    if strategy == "auto":
        return "emitter" if cone else "mis"
    return strategy


def _estimate(
    lights: Sequence[Light],
    points: np.ndarray,
    normals: np.ndarray,
    *,
    spp: int,
    seed: int,
    variant: str,
    plane: Plane | None,
    first_index: int,
    progress: Progress | None,
    lanes: int,
    strategy: str = "auto",
) -> Estimate:
    mi = use_variant(variant)
    components = [
        (mi.load_dict(c.scene), c, _strategy(strategy, c.cone))
        for c in scene_components(mi, lights, plane)
    ]
    origins = ray_origins(lights, points, normals, plane)
    count = len(points)
    E = np.zeros(count)
    var = np.zeros(count)
    total = count * len(components)
    done = [0]

    def tick():
        done[0] += 1
        if progress is not None:
            progress(done[0], total)

    bias = np.zeros(count)
    hits = np.zeros(count)
    for comp, (scene, c, how) in enumerate(components):
        E_c = np.zeros(count)
        for i, values in _component_values(
            mi,
            variant,
            how,
            scene,
            (comp, c),
            points,
            normals,
            origins,
            spp,
            seed,
            first_index,
            lanes,
            tick,
        ):
            E_c[i] = values.mean()
            hits[i] += np.count_nonzero(values)
            var[i] += values.var(ddof=1) / spp
        E += E_c
        bias += _cone_bias(c, how, points, E_c, lights)
    bias += _FLOOR_REL * np.abs(E)
    # k non-zero samples of N (a sliver of light above the horizon, far away): the sample
    # variance misses the values it did not see; B / (N (k + 1)) joins it, one hit of the
    # largest possible value more or less, fading as hits accumulate
    var += (_sample_bound(lights, points, normals) / (spp * (hits + 1.0))) ** 2
    mc = np.sqrt(var)
    stderr = np.sqrt(var + bias**2 / 3.0)
    return Estimate(E=E, stderr=stderr, mc_stderr=mc, bias_bound=bias, variant=variant)


def estimate_detail(
    lights: Sequence[Light],
    points: Float[np.ndarray, "n 3"],
    normals: Float[np.ndarray, "n 3"],
    *,
    spp: int,
    seed: int,
    variant: str = "auto",
    plane: Plane | None = None,
    first_index: int = 0,
    progress: Progress | None = None,
    lanes: int = DEFAULT_LANES,
    strategy: str = "auto",
) -> Estimate:
    """Like `estimate_irradiance`, returning the uncertainty's parts and the variant used."""
    lights, p, n, spp, seed, first_index = _check_args(
        lights, points, normals, spp, seed, first_index
    )
    if not isinstance(lanes, int) or lanes < 1:
        raise BadValueError(f"lanes must be a positive integer, got {lanes!r}")
    if strategy not in STRATEGIES:
        raise BadValueError(f"strategy must be one of {', '.join(STRATEGIES)}, got {strategy!r}")
    chosen = select_variant(variant).name
    return _estimate(
        lights,
        p,
        n,
        spp=spp,
        seed=seed,
        variant=chosen,
        plane=plane,
        first_index=first_index,
        progress=progress,
        lanes=lanes,
        strategy=strategy,
    )


def estimate_irradiance(
    lights: Sequence[Light],
    points: Float[np.ndarray, "n 3"],
    normals: Float[np.ndarray, "n 3"],
    *,
    spp: int,
    seed: int,
    variant: str = "auto",
    plane: Plane | None = None,
    first_index: int = 0,
    progress: Progress | None = None,
    lanes: int = DEFAULT_LANES,
    strategy: str = "auto",
) -> tuple[Float[np.ndarray, " n"], Float[np.ndarray, " n"]]:
    """Irradiance (W m^-2) at receivers `points` with unit `normals`, and its standard error.

    `lights` is a list of `SphereLight`/`DiskLight` (see `data_gen.scenes`); `plane` an
    optional opaque square in the scene. `spp` samples per receiver; `seed` and the global
    receiver index `first_index + i` fix the random numbers, so the same seed and variant
    give the same numbers. `variant` is 'auto', 'scalar_rgb' or 'llvm_ad_rgb' (resolved by
    `data_gen.variants.select_variant`, falling back to scalar). `progress(done, total)` is
    called after each receiver. `strategy`: 'auto' (default) uses light sampling alone for
    sphere lights and MIS of light and cosine sampling for disks and capsule tubes; 'mis'
    and 'emitter' force one for all (see the module docstring). Receivers inside a sphere or capsule light are refused. See the module
    docstring for the estimator and what the standard error includes.
    """
    est = estimate_detail(
        lights,
        points,
        normals,
        spp=spp,
        seed=seed,
        variant=variant,
        plane=plane,
        first_index=first_index,
        progress=progress,
        lanes=lanes,
        strategy=strategy,
    )
    return est.E, est.stderr
