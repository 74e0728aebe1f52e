"""Mitsuba variants: which one to render with, found without ever crashing the caller.

Two variants are used. `scalar_rgb` works wherever `pip install mitsuba` does, but has no
vectorisation: the estimator loops over samples in Python (about 2.5 µs per sample).
`llvm_ad_rgb` runs millions of samples per kernel launch, but needs a working libLLVM: Dr.Jit
loads one when it is first imported, and with Debian's libLLVM 15 the first kernel aborts the
process inside LLVM's instruction selection (`LLVM ERROR: Cannot select: ... fmaximum`);
libLLVM 19 (`apt-get install -y libllvm19`) works.

So the LLVM variant is only ever tried in a child process first (`probe_llvm`). If the probe
passes, this process points `DRJIT_LIBLLVM_PATH` at the library that passed (this must happen
before Dr.Jit is imported, which reads the variable once) and uses `llvm_ad_rgb`; otherwise
it falls back to `scalar_rgb` with a one-line notice on stderr. The decision is made once per
process and cached.
"""

from __future__ import annotations

import glob
import os
import re
import subprocess
import sys
from dataclasses import dataclass

from attenfit import AttenfitError, BadValueError
from attenfit._atomic import _signals_deferred

__all__ = [
    "FALLBACK_NOTICE",
    "LLVM_ENV",
    "VARIANTS",
    "MitsubaMissingError",
    "VariantChoice",
    "llvm_candidates",
    "mitsuba_version",
    "probe_llvm",
    "require_mitsuba",
    "select_variant",
    "use_variant",
]

VARIANTS = ("auto", "scalar_rgb", "llvm_ad_rgb")
LLVM_ENV = "DRJIT_LIBLLVM_PATH"
_PROBE_TIMEOUT_S = 120.0
_MIN_LLVM_MAJOR = 16  # 15 aborts (see module docstring); 19 is known to work
#: The one line printed (after "data_gen: ") when no libLLVM works for Mitsuba's fast variant.
FALLBACK_NOTICE = (
    "Mitsuba's fast llvm_ad_rgb variant does not work on this machine (it needs libLLVM 16 or "
    "newer, e.g. apt-get install libllvm19), so it renders with scalar_rgb, which is slower."
)


class MitsubaMissingError(AttenfitError):
    """Mitsuba 3 (or Dr.Jit) cannot be imported."""


@dataclass(frozen=True)
class VariantChoice:
    """The variant chosen for this process: `name`, the libLLVM it uses (llvm only), and why."""

    name: str
    llvm_path: str | None
    reason: str


_chosen: VariantChoice | None = None
_probe_cache: dict[str | None, tuple[bool, str]] = {}


def require_mitsuba():
    """Import and return the `mitsuba` module, or raise `MitsubaMissingError` in one line."""
    try:
        # A signal in the middle of importing Dr.Jit's extension leaves it half-loaded (a
        # NameError or an abort later): deliver Ctrl-C and SIGTERM once the import is done.
        with _signals_deferred():
            import mitsuba
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise MitsubaMissingError(
            f"Mitsuba 3 is not importable ({exc}); install it with `pip install mitsuba`"
        ) from None
    return mitsuba


def mitsuba_version() -> str:
    """The installed Mitsuba version string, e.g. '3.9.1'."""
    return str(require_mitsuba().__version__)


def _llvm_major(path: str) -> int | None:
    match = re.search(r"(?:LLVM[-.]|llvm-|so\.)(\d+)", os.path.basename(path)) or re.search(
        r"llvm-(\d+)", path
    )
    return int(match.group(1)) if match else None


def llvm_candidates() -> list[str]:
    """libLLVM shared libraries worth probing, newest major version first.

    `DRJIT_LIBLLVM_PATH`, when set, is the only candidate (the user chose). Otherwise the usual
    Debian/Ubuntu locations of libLLVM >= 16 (`/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1`,
    `/usr/lib/llvm-19/lib/libLLVM.so`, ...).
    """
    if os.environ.get(LLVM_ENV):
        return [os.environ[LLVM_ENV]]
    patterns = [
        "/usr/lib/*-linux-gnu/libLLVM.so.*",
        "/usr/lib/*-linux-gnu/libLLVM-*.so*",
        "/usr/lib/llvm-*/lib/libLLVM*.so*",
        "/usr/lib64/libLLVM*.so*",
    ]
    found: dict[int, str] = {}
    for pattern in patterns:
        for path in sorted(glob.glob(pattern)):
            major = _llvm_major(path)
            if major is not None and major >= _MIN_LLVM_MAJOR and os.path.isfile(path):
                found.setdefault(major, os.path.realpath(path))
    return [found[m] for m in sorted(found, reverse=True)]


_PROBE_CODE = r"""
import sys
import drjit as dr
import mitsuba as mi
import numpy as np
mi.set_variant("llvm_ad_rgb")
L = 1.0 / 3.141592653589793
light = {"type": "area", "radiance": {"type": "uniform", "value": L}}
scene = mi.load_dict({
    "type": "scene",
    "sphere": {"type": "sphere", "center": [0, 0, 0], "radius": 1.0, "emitter": light},
    "disk": {"type": "disk", "to_world": mi.ScalarTransform4f().translate([0, 0, 5]), "emitter": light},
})
n = 4096
ref = dr.zeros(mi.Interaction3f, n)
ref.p = mi.Point3f(0.0, 0.0, -3.0)
ref.n = mi.Normal3f(0.0, 0.0, 1.0)
rng = mi.PCG32(n)
# the operations data_gen.estimate uses: light sampling with shadow rays, cosine sampling,
# ray tracing, emitter evaluation and pdfs through dispatch, max / select
ds, w = scene.sample_emitter_direction(ref, mi.Point2f(rng.next_float32(), rng.next_float32()), True)
cos = dr.maximum(dr.dot(ds.d, ref.n), 0.0)
a = dr.select(ds.pdf > 0, w[0] * cos * ds.pdf / (ds.pdf + cos / dr.pi), 0.0)
d = mi.Frame3f(ref.n).to_world(
    mi.warp.square_to_cosine_hemisphere(mi.Point2f(rng.next_float32(), rng.next_float32()))
)
si = scene.ray_intersect(ref.spawn_ray(d))
hit = si.is_valid()
pl = scene.pdf_emitter_direction(ref, mi.DirectionSample3f(scene, si=si, ref=ref), hit)
b = dr.select(hit, si.emitter(scene).eval(si, hit)[0] * d.z / (pl + d.z / dr.pi), 0.0)
E = float(np.mean(np.array(a + b, dtype=np.float64)))
# exact: the sphere alone is 1/9 (the disk faces +z, away from the receiver)
ok = abs(E * 9.0 - 1.0) < 0.05
print("probe", "ok" if ok else f"wrong value {E!r} (expected 1/9)")
sys.exit(0 if ok else 3)
"""


def probe_llvm(path: str | None, *, timeout: float = _PROBE_TIMEOUT_S) -> tuple[bool, str]:
    """Try `llvm_ad_rgb` with libLLVM at `path` (None: Dr.Jit's own search) in a child process.

    The child runs the estimator's Mitsuba operations (light and cosine sampling, ray
    tracing, emitter evaluation; only Mitsuba is imported, so it takes about a second) on a
    sphere light and checks the value (1/9 at distance 3); a crash, a hang, an import error
    or a wrong value all
    return `(False, reason)`. Returns `(True, "ok")` on success. Results are cached.
    """
    key = path
    if key in _probe_cache:
        return _probe_cache[key]
    env = dict(os.environ)
    if path is None:
        env.pop(LLVM_ENV, None)
    else:
        env[LLVM_ENV] = path
    try:
        proc = subprocess.run(
            [sys.executable, "-c", _PROBE_CODE],
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )
    except subprocess.TimeoutExpired:
        result = (False, f"probe timed out after {timeout:g} s")
    except OSError as exc:
        result = (False, f"probe could not start: {exc}")
    else:
        if proc.returncode == 0:
            result = (True, "ok")
        else:
            lines = [ln.strip() for ln in (proc.stdout + proc.stderr).splitlines() if ln.strip()]
            first = next((ln for ln in lines if "LLVM ERROR" in ln or "Error" in ln), None)
            detail = first or (lines[-1] if lines else "no output")
            how = (
                f"killed by signal {-proc.returncode}"
                if proc.returncode < 0
                else f"exit {proc.returncode}"
            )
            result = (False, f"probe {how}: {detail[:160]}")
    _probe_cache[key] = result
    return result


def _notice(message: str) -> None:
    print(f"data_gen: {message}", file=sys.stderr, flush=True)


def _drjit_imported() -> bool:
    return "drjit" in sys.modules


def _choose_llvm() -> tuple[VariantChoice | None, str]:
    """Find a libLLVM that passes the probe; return (choice or None, reason if none)."""
    if _drjit_imported():
        # Dr.Jit already picked its library (from the environment as it is now): probe that.
        path = os.environ.get(LLVM_ENV) or None
        ok, why = probe_llvm(path)
        if ok:
            return VariantChoice("llvm_ad_rgb", path, "probe passed"), ""
        return None, why
    reasons = []
    candidates: list[str | None] = [*llvm_candidates()]
    if not os.environ.get(LLVM_ENV):
        candidates.append(None)  # Dr.Jit's own search (may find a working conda/pip LLVM)
    for path in candidates[:4]:
        ok, why = probe_llvm(path)
        if ok:
            if path is not None:
                os.environ[LLVM_ENV] = path
            return VariantChoice("llvm_ad_rgb", path, "probe passed"), ""
        reasons.append(f"{path or 'default search'}: {why}")
    return None, "; ".join(reasons) or "no libLLVM found"


def select_variant(requested: str = "auto") -> VariantChoice:
    """Resolve `requested` ('auto', 'scalar_rgb' or 'llvm_ad_rgb') to a variant that works.

    'scalar_rgb' is always honoured. 'auto' and 'llvm_ad_rgb' use `llvm_ad_rgb` when a
    libLLVM passes `probe_llvm`, and otherwise fall back to `scalar_rgb` with a one-line
    notice on stderr (`FALLBACK_NOTICE`; why the probe failed is in the choice's `reason`,
    which goes into the dataset's provenance). Never raises for an unusable LLVM; raises
    `BadValueError` for an unknown name.
    """
    global _chosen
    if requested not in VARIANTS:
        raise BadValueError(f"variant must be one of {', '.join(VARIANTS)}, got {requested!r}")
    if requested == "scalar_rgb":
        return VariantChoice("scalar_rgb", None, "requested")
    if _chosen is not None:
        return _chosen
    choice, why = _choose_llvm()
    if choice is None:
        _notice(FALLBACK_NOTICE)
        choice = VariantChoice("scalar_rgb", None, f"fallback: {why}")
    _chosen = choice
    return choice


def use_variant(name: str):
    """Make `name` Mitsuba's active variant and return the `mitsuba` module.

    `name` must be a concrete variant ('scalar_rgb' or 'llvm_ad_rgb'); call `select_variant`
    first to resolve 'auto' safely.
    """
    if name not in VARIANTS[1:]:
        raise BadValueError(f"variant must be scalar_rgb or llvm_ad_rgb here, got {name!r}")
    mi = require_mitsuba()
    if mi.variant() != name:
        try:
            with _signals_deferred():  # loads the variant's extension (see require_mitsuba)
                mi.set_variant(name)
        except (ImportError, AttributeError) as exc:
            raise MitsubaMissingError(f"Mitsuba variant {name} is not available: {exc}") from None
    return mi
