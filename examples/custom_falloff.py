"""Your own falloff: a `Family` subclass, registered, fitted, and compared in a report.

Two ways to bring a curve of your own to attenfit:

1. **A `Family` subclass** registered with `attenfit.register_family`: it then works
   everywhere a built-in family does (fits, `fit_many`, reports, cost, shader export). The
   example is a Gaussian-softened inverse square,

       f(d) = (1 - exp(-d^2/r^2)) / d^2,

   finite at the light (f(0) = 1/r^2, like the true disk), smooth, and 1/d^2 far away (the
   Gaussian term dies faster than any power). It is evaluated as
   -expm1(-x)/x / r^2 with x = d^2/r^2 (no cancellation for small x, no 0/0 at d = 0).
2. **A plain JAX function** `fn(d, params)` with a dict of start values: the `(fn, params)`
   form of `attenfit.fit`, for a quick try before writing a class. The example is
   1/(d^2 + a d + b), fitted to the exact disk, which should find a = 0 and b = r^2.

The family is fitted to the exact attenuation of a sphere and a disk light (`facing_sweep`),
then compared with a few built-in families in a report (`attenfit.report.build_report`),
written to `report/` inside the output folder.

Run: python examples/custom_falloff.py [--out DIR] [--force]
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import ClassVar

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
from jaxtyping import Array, ArrayLike, Float  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _example  # noqa: E402

import attenfit  # noqa: E402
from attenfit.report import build_report  # noqa: E402

NAME = "custom_falloff"
RADIUS = 0.1  # m
COMPARE = ("inverse_square", "yuksel", "yuksel_adhoc", "disk_facing", "madams_sphere")


# ----------------------------------------------------------------------------- 1. a Family
def _register():
    """Define and register the family (once per process; `get_family` finds it after)."""
    try:
        return attenfit.get_family("gaussian_softened")
    except KeyError:
        pass

    @attenfit.register_family
    class GaussianSoftened(attenfit.Family):
        """Gaussian-softened inverse square, f = (1 - exp(-d^2/r^2))/d^2 (an example).

        r (m) sets where the softening acts; f(0) = 1/r^2; f d^2 -> 1 as d/r -> inf.
        Evaluated as -expm1(-x)/(x r^2), x = d^2/r^2, with a safe x at 0 (double where),
        so values and gradients are finite everywhere.
        """

        r: Float[ArrayLike, "*batch"] = 0.1

        name: ClassVar[str] = "gaussian_softened"
        formula: ClassVar[str] = "(1 - exp(-d^2/r^2))/d^2  [= -expm1(-x)/(x r^2), x = d^2/r^2]"
        source: ClassVar[str] = "attenfit examples/custom_falloff.py (a user's own curve)"
        default_free: ClassVar[tuple[str, ...]] = ("r",)
        shader_form = attenfit.no_shader_form
        length_params: ClassVar[tuple[str, ...]] = ("r",)
        tends_to_inverse_square: ClassVar[bool] = True
        scale_covariant: ClassVar[bool] = True

        def __call__(self, d: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
            d = jnp.asarray(d)
            dtype = d.dtype if jnp.issubdtype(d.dtype, jnp.floating) else jnp.result_type(float)
            d = jnp.maximum(d.astype(dtype), 0)  # negative distances read as 0
            r = jnp.asarray(self.r).astype(dtype)
            x = (d / r) ** 2
            small = x < 1e-8
            x_safe = jnp.where(small, 1, x)  # double where: no 0/0 in value or gradient
            g = jnp.where(small, 1 - x / 2, -jnp.expm1(-x_safe) / x_safe)
            far = jnp.isinf(d)
            return jnp.where(far, 0, g / (r * r)).astype(dtype)

    return GaussianSoftened


# ----------------------------------------------------------------------------- 2. (fn, params)
def rational(d, p):
    """A user's quick try as a plain JAX function: 1/(d^2 + a d + b)."""
    return 1.0 / (d * d + p["a"] * d + p["b"])


def truths(n: int = 200) -> dict[str, attenfit.Dataset]:
    """Exact facing sweeps of a sphere (from contact) and a disk (from 1e-3 r), to 1000 r."""
    sphere = attenfit.SphereEmitter(center=[0.0, 0.0, 0.0], radius=RADIUS)
    disk = attenfit.DiskEmitter(center=[0.0, 0.0, 0.0], normal=[0.0, 0.0, -1.0], radius=RADIUS)
    return {
        "sphere": attenfit.facing_sweep(
            sphere, 1.001 * RADIUS, 1e3 * RADIUS, n=n, dtype=jnp.float64
        ),
        "disk": attenfit.facing_sweep(disk, 1e-3 * RADIUS, 1e3 * RADIUS, n=n, dtype=jnp.float64),
    }


def main(argv: Sequence[str] | None = None) -> dict:
    p = _example.parser(NAME, __doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="fewer samples in the report (tests)")
    args = _example.parse_args(p, argv)
    family = _register()
    data = truths()

    # The registered family, fitted like any built-in one.
    fits = {}
    for light, ds in data.items():
        res = attenfit.fit_dataset(family(r=RADIUS), ds)
        fits[light] = {
            "r_fit_over_r": res.params["r"] / RADIUS,
            "max_rel_error": res.metrics["max_rel_error"],
            "converged": bool(res.converged),
        }
    print("gaussian_softened fitted to the exact lights (r = 0.1 m):")
    rows = [[k, v["r_fit_over_r"], v["max_rel_error"], v["converged"]] for k, v in fits.items()]
    print(_example.table(rows, ["light", "fitted r / r", "max rel. error", "converged"]))
    print("  (a sphere's facing attenuation is exactly 1/d^2 outside it: no softening fits best)")

    # The (fn, params) form: a plain function and a dict of start values (and constraints).
    disk = data["disk"]
    d, target = disk.distance(), disk.attenuation()
    res = attenfit.fit(
        (rational, {"a": 0.05, "b": 0.02}, {"a": "nonnegative", "b": "positive"}), d, target
    )
    fn_fit = {
        "a": res.params["a"],
        "b": res.params["b"],
        "b_over_r2": res.params["b"] / RADIUS**2,
        "max_rel_error": res.metrics["max_rel_error"],
        "converged": bool(res.converged),
    }
    print(
        f"(fn, params) 1/(d^2 + a d + b) on the disk: a = {fn_fit['a']:.3g} m, "
        f"b = {fn_fit['b_over_r2']:.6f} r^2, max rel. error {fn_fit['max_rel_error']:.2e}"
    )

    # A report comparing the new family with built-in ones: the family's own published
    # parameters (r = the light's radius) and, unless --quick, fitted, on both lights.
    names = ["gaussian_softened", *COMPARE]
    if args.quick:  # the disk only, as published: a few seconds instead of a minute
        report = build_report(
            names, emitters=["disk"], fitted=False, sweep_n=48, plane_px=24, cost=False
        )
    else:
        report = build_report(names, sweep_n=96, plane_px=48, cost=False)
    summary: dict[str, dict[str, float]] = {}
    for row in report.results:
        err = ((row.get("sweep") or {}).get("overall") or {}).get("max_abs")
        key = f"{row['config']} {row['mode']}"
        summary.setdefault(row["family"], {})[key] = None if err is None else float(err)
    columns = sorted({k for v in summary.values() for k in v})
    print("report: max relative error on the facing sweep (None: no result, see report.md)")
    print(
        _example.table(
            [[f, *(summary[f].get(c) for c in columns)] for f in names], ["family", *columns]
        )
    )

    numbers = {"fits": fits, "fn_params_fit": fn_fit, "report_max_rel_error": summary}
    with _example.output_folder(args) as tmp:
        report.write(tmp / "report", svg=False)
        _example.write_numbers(tmp, numbers)
    print(f"wrote {args.out} (report in {args.out / 'report'})")
    return numbers


if __name__ == "__main__":
    _example.run(main)
