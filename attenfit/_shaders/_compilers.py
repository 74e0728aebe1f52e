"""What a curve costs as compiled by real compilers, each number labelled with its compiler.

* **SPIR-V**: the GLSL function, called from a fragment shader whose only work is the curve,
  compiled by `glslangValidator -V`, optimised by `spirv-opt -O` (everything is inlined into
  `main`) and listed by `spirv-dis`. The instructions of `main`, less those of the same
  shader returning `d` itself, by class: arithmetic (add, multiply, divide, negate,
  compare, min, max, clamp, fma), extended (sqrt, inversesqrt, pow, exp, log, trig: the
  special-function unit's work), select (OpSelect, OpPhi), branch.
* **SASS**: the CUDA function called from a kernel `o[i] = f(d[i])`, compiled by NVRTC to
  PTX for `compute_89` with `--use_fast_math` (division, sqrt and pow by the
  special-function unit, as shader compilers do), by `ptxas -O3` to an sm_89 cubin, listed
  by `nvdisasm` (or `cuobjdump -sass`). The kernel's instructions less those of the kernel
  `o[i] = d[i]`, with MUFU (rcp, rsq, sqrt, lg2, ex2, sin, cos) counted apart.
* **estimate**: without either compiler, the traced-operation model of `_cost`
  (`SHADER_WEIGHTS`), labelled as an estimate.

Results are cached on disk by the exact compiled text and the compilers' versions, in
attenfit's cache (`attenfit._cache`, entries of kind `compiled`).
"""

from __future__ import annotations

import concurrent.futures
import ctypes
import dataclasses
import functools
import importlib.util
import json
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .. import _cache
from .._errors import AttenfitError

__all__ = ["Compiled", "CompilerError", "compilers", "sass_counts", "spirv_counts"]

_TIMEOUT = 60  # seconds per compiler call
SASS_ARCH = "sm_89"


class CompilerError(AttenfitError):
    """A compiler refused the generated code (a bug in attenfit: the message has its output)."""


@dataclasses.dataclass(frozen=True)
class Compiled:
    """Instruction counts of one function from one compiler (`tool` names it, with versions)."""

    target: str  # "spirv" or "sass"
    tool: str
    total: int
    classes: Mapping[str, int]

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict."""
        return {**dataclasses.asdict(self), "classes": dict(self.classes)}


# ----------------------------------------------------------------------------- the tools
def _version(cmd: list[str], pattern: str) -> str | None:
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=_TIMEOUT)
    except (OSError, subprocess.TimeoutExpired):
        return None
    m = re.search(pattern, out.stdout + out.stderr)
    return m.group(1) if m else None


def _nvidia_files(pattern: str) -> list[Path]:
    """Files of the NVIDIA wheels (`nvidia-cuda-nvcc-cu12`, ...) matching `pattern`."""
    spec = importlib.util.find_spec("nvidia")
    if spec is None or not spec.submodule_search_locations:
        return []
    found: list[Path] = []
    for root in spec.submodule_search_locations:
        found += sorted(Path(root).glob(pattern))
    return found


def _tool(name: str) -> str | None:
    on_path = shutil.which(name)
    if on_path:
        return on_path
    hits = [p for p in _nvidia_files(f"*/bin/{name}") if os.access(p, os.X_OK)]
    return str(hits[0]) if hits else None


_TOOLS = ("glslangValidator", "spirv-opt", "spirv-dis", "ptxas", "nvdisasm", "cuobjdump")


@functools.cache
def compilers() -> dict[str, str | None]:
    """Each compiler's version, or None when it is not installed.

    Keys: glslangValidator, spirv-opt, spirv-dis (SPIR-V); nvrtc, ptxas, and nvdisasm or
    cuobjdump (SASS). Asking each tool for its version takes about a second, so the answer
    is kept in attenfit's cache under the tools' paths, sizes and modification times.
    """
    paths = {name: _tool(name) for name in _TOOLS}
    libs = [p for p in _nvidia_files("*/lib/libnvrtc.so*") if "alt" not in p.name]
    stamp = json.dumps(
        [(str(p), *_stat(p)) for p in [*paths.values(), *libs] if p is not None], sort_keys=True
    )
    cached = _cache.read("compilers", stamp)
    if cached is not None:
        try:
            return json.loads(cached)
        except ValueError:
            pass
    out: dict[str, str | None] = {}
    glslang = paths["glslangValidator"]
    out["glslangValidator"] = glslang and _version(
        [glslang, "--version"], r"Glslang Version: (\S+)"
    )
    for name in ("spirv-opt", "spirv-dis"):
        path = paths[name]
        out[name] = path and _version([path, "--version"], r"(SPIRV-Tools v\S+)")
    out["nvrtc"] = _nvrtc_version()
    for name in ("ptxas", "nvdisasm", "cuobjdump"):
        path = paths[name]
        out[name] = path and _version([path, "--version"], r"(V\d+\.\d+\.\d+)")
    _cache.write("compilers", stamp, json.dumps(out).encode())
    return out


def _stat(path: str | Path) -> tuple[int, int]:
    try:
        st = os.stat(path)
    except OSError:
        return (0, 0)
    return (st.st_size, st.st_mtime_ns)


def missing(target: str) -> str | None:
    """None if `target` ("spirv" or "sass") can be compiled here, else what is missing."""
    have = compilers()
    need = (
        ["glslangValidator", "spirv-opt", "spirv-dis"] if target == "spirv" else ["nvrtc", "ptxas"]
    )
    lacking = [n for n in need if not have.get(n)]
    if target == "sass" and not (have.get("nvdisasm") or have.get("cuobjdump")):
        lacking.append("nvdisasm or cuobjdump")
    if not lacking:
        return None
    how = (
        "Debian packages glslang-tools and spirv-tools"
        if target == "spirv"
        else "pip install 'attenfit[shader]' (NVIDIA's nvrtc, nvcc and nvdisasm wheels)"
    )
    return f"{', '.join(lacking)} not installed ({how})"


# ----------------------------------------------------------------------------- the cache
def _cached(target: str, tool: str, source: str, compile_: Any) -> Compiled:
    """The counts of `source` compiled by `tool`, from attenfit's cache (`attenfit._cache`)
    when an earlier run compiled the same text with the same compilers."""
    key = f"{target}\0{tool}\0{source}"
    blob = _cache.read("compiled", key)
    if blob is not None:
        try:
            data = json.loads(blob)
            return Compiled(target, data["tool"], int(data["total"]), dict(data["classes"]))
        except (ValueError, KeyError, TypeError):
            pass
    total, classes = compile_()
    result = Compiled(target, tool, total, classes)
    _cache.write("compiled", key, json.dumps(result.to_dict()).encode())
    return result


def _run(cmd: list[str], cwd: str) -> str:
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd, timeout=_TIMEOUT)
    except subprocess.TimeoutExpired:
        raise CompilerError(f"{Path(cmd[0]).name} took longer than {_TIMEOUT} s") from None
    if proc.returncode != 0:
        raise CompilerError(f"{' '.join(cmd)} failed:\n{proc.stdout}\n{proc.stderr}")
    return proc.stdout


def _diff(a: Mapping[str, int], b: Mapping[str, int]) -> dict[str, int]:
    return {k: a.get(k, 0) - b.get(k, 0) for k in sorted(set(a) | set(b))}


# ----------------------------------------------------------------------------- SPIR-V
_EXTENDED = {"Sqrt", "InverseSqrt", "Pow", "Exp", "Exp2", "Log", "Log2", "Sin", "Cos", "Tan",
             "Asin", "Acos", "Atan", "Atan2", "Sinh", "Cosh", "Tanh"}  # fmt: skip
_NOT_COUNTED = {"OpLabel", "OpSelectionMerge", "OpLoopMerge", "OpFunction", "OpFunctionEnd",
                "OpReturn", "OpLine", "OpNoLine", "OpNop"}  # fmt: skip


def _spirv_classes(listing: str) -> dict[str, int]:
    counts = dict.fromkeys(("arithmetic", "extended", "select", "branch", "memory"), 0)
    inside = False
    for line in listing.splitlines():
        words = line.split()
        op = next((w for w in words if w.startswith("Op")), None)
        if op == "OpFunction":
            inside = True
        if not inside or op is None or op in _NOT_COUNTED:
            if op == "OpFunctionEnd":
                inside = False
            continue
        if op == "OpExtInst":
            counts[
                "extended" if words[words.index("OpExtInst") + 3] in _EXTENDED else "arithmetic"
            ] += 1
        elif op in ("OpSelect", "OpPhi"):
            counts["select"] += 1
        elif op in ("OpBranch", "OpBranchConditional", "OpSwitch"):
            counts["branch"] += 1
        elif op in ("OpLoad", "OpStore", "OpAccessChain", "OpVariable"):
            counts["memory"] += 1
        else:
            counts["arithmetic"] += 1
    return counts


def _spirv_of(body: str, call: str, inputs: int = 1) -> dict[str, int]:
    """Counts of a fragment shader `o = call` reading `v` (`inputs` > 1: `v0`, `v1`, ...)."""
    names = ["v"] if inputs == 1 else [f"v{i}" for i in range(inputs)]
    ins = "".join(f"layout(location = {i}) in float {v};\n" for i, v in enumerate(names))
    src = (
        f"#version 450\n{ins}layout(location = 0) out float o;\n"
        f"{body}\nvoid main() {{ o = {call}; }}\n"
    )
    with tempfile.TemporaryDirectory(prefix="attenfit-spirv-") as tmp:
        Path(tmp, "f.frag").write_text(src, encoding="utf-8")
        _run([_tool("glslangValidator") or "", "-V", "-S", "frag", "-o", "f.spv", "f.frag"], tmp)
        _run([_tool("spirv-opt") or "", "-O", "f.spv", "-o", "o.spv"], tmp)
        return _spirv_classes(_run([_tool("spirv-dis") or "", "o.spv"], tmp))


def spirv_counts(glsl: str, fname: str, inputs: int = 1) -> Compiled | None:
    """SPIR-V instruction counts of the GLSL function `fname(d)` in `glsl` (None: no compiler);
    `inputs` > 1: a function of that many floats (an area model's), less the shader that
    returns the first of them."""
    if missing("spirv"):
        return None
    have = compilers()
    tool = f"glslangValidator {have['glslangValidator']} + spirv-opt -O ({have['spirv-opt']})"
    args = "v" if inputs == 1 else ", ".join(f"v{i}" for i in range(inputs))
    first = "v" if inputs == 1 else "v0"

    def run() -> tuple[int, dict[str, int]]:
        classes = _diff(_spirv_of(glsl, f"{fname}({args})", inputs), _spirv_base(first, inputs))
        classes.pop("memory", None)
        return sum(classes.values()), classes

    return _cached("spirv", tool, glsl, run)


@functools.cache
def _spirv_base(first: str, inputs: int) -> dict[str, int]:
    """The counts of the shader that returns its first input, subtracted from every count:
    one compile per process (glslangValidator takes about 0.1 s to start)."""
    return _spirv_of("", first, inputs)


def in_parallel(fn: Callable[[Any], Any], items: Sequence[Any]) -> list[Any]:
    """`[fn(x) for x in items]`, run side by side on the machine's cores: what the compilers
    cost is mostly their processes' start (glslangValidator's 0.1 s), so a scene's twenty
    families compile in about half the time on two cores. The first exception is raised."""
    items = list(items)
    workers = min(len(items), os.cpu_count() or 1)
    if workers <= 1:
        return [fn(x) for x in items]
    with concurrent.futures.ThreadPoolExecutor(workers) as pool:
        return list(pool.map(fn, items))


# ----------------------------------------------------------------------------- SASS
@functools.cache
def _nvrtc() -> Any:
    for path in [*_nvidia_files("*/lib/libnvrtc.so*"), Path("libnvrtc.so")]:
        if "alt" in path.name or "builtins" in path.name:
            continue
        try:
            return ctypes.CDLL(str(path))
        except OSError:
            continue
    return None


def _nvrtc_version() -> str | None:
    lib = _nvrtc()
    if lib is None:
        return None
    major, minor = ctypes.c_int(), ctypes.c_int()
    lib.nvrtcVersion(ctypes.byref(major), ctypes.byref(minor))
    return f"{major.value}.{minor.value}"


def _ptx(source: str) -> bytes:
    lib = _nvrtc()
    prog = ctypes.c_void_p()
    if lib.nvrtcCreateProgram(ctypes.byref(prog), source.encode(), b"f.cu", 0, None, None):
        raise CompilerError("nvrtcCreateProgram failed")
    try:
        opts = [b"--gpu-architecture=compute_89", b"--use_fast_math"]
        status = lib.nvrtcCompileProgram(prog, len(opts), (ctypes.c_char_p * len(opts))(*opts))
        if status:
            size = ctypes.c_size_t()
            lib.nvrtcGetProgramLogSize(prog, ctypes.byref(size))
            log = ctypes.create_string_buffer(size.value)
            lib.nvrtcGetProgramLog(prog, log)
            raise CompilerError(f"NVRTC failed:\n{log.value.decode(errors='replace')}")
        size = ctypes.c_size_t()
        lib.nvrtcGetPTXSize(prog, ctypes.byref(size))
        ptx = ctypes.create_string_buffer(size.value)
        lib.nvrtcGetPTX(prog, ptx)
        return ptx.value
    finally:
        lib.nvrtcDestroyProgram(ctypes.byref(prog))


_SASS_LINE = re.compile(r"/\*[0-9a-f]{4,}\*/\s+(?:@!?U?P\w+\s+)?([A-Z][A-Z0-9_.]*)")
_BRANCH = {"BRA", "BRX", "JMP", "CALL", "RET", "EXIT", "BSSY", "BSYNC", "WARPSYNC", "BREAK"}


def _sass_classes(listing: str) -> dict[str, int]:
    counts = dict.fromkeys(("alu", "mufu", "branch"), 0)
    for m in _SASS_LINE.finditer(listing):
        op = m.group(1)
        base = op.split(".")[0]
        if base == "NOP":
            continue
        key = "mufu" if base == "MUFU" else ("branch" if base in _BRANCH else "alu")
        counts[key] += 1
    return counts


def _sass_of(body: str, call: str) -> dict[str, int]:
    src = (
        f'{body}\nextern "C" __global__ void attenfit_kernel(const float* __restrict__ d, '
        "float* __restrict__ o) {\n    int i = blockIdx.x * blockDim.x + threadIdx.x;\n"
        f"    o[i] = {call};\n}}\n"
    )
    with tempfile.TemporaryDirectory(prefix="attenfit-sass-") as tmp:
        Path(tmp, "f.ptx").write_bytes(_ptx(src))
        _run([_tool("ptxas") or "", f"-arch={SASS_ARCH}", "-O3", "-o", "f.cubin", "f.ptx"], tmp)
        lister = _tool("nvdisasm")
        cmd = (
            [lister, "-c", "f.cubin"] if lister else [_tool("cuobjdump") or "", "-sass", "f.cubin"]
        )
        return _sass_classes(_run(cmd, tmp))


def sass_counts(cuda: str, fname: str) -> Compiled | None:
    """SASS instruction counts of the CUDA function `fname(d)` (None: no compiler)."""
    if missing("sass"):
        return None
    have = compilers()
    lister = (
        f"nvdisasm {have['nvdisasm']}" if have.get("nvdisasm") else f"cuobjdump {have['cuobjdump']}"
    )
    tool = f"NVRTC {have['nvrtc']} --use_fast_math + ptxas {have['ptxas']} -O3 ({SASS_ARCH}) + {lister}"

    def run() -> tuple[int, dict[str, int]]:
        classes = _diff(_sass_of(cuda, f"{fname}(d[i])"), _sass_base())
        return sum(classes.values()), classes

    return _cached("sass", tool, cuda, run)


@functools.cache
def _sass_base() -> dict[str, int]:
    """The counts of the kernel that stores its input, subtracted from every count: one
    compile per process."""
    return _sass_of("", "d[i]")


# ----------------------------------------------------------------------------- a family
def cost_method() -> str:
    """What a cost is measured with here: "spirv", else "sass", else "estimate"."""
    for target in ("spirv", "sass"):
        if missing(target) is None:
            return target
    return "estimate"


@dataclasses.dataclass(frozen=True)
class CompiledCost:
    """What one model costs as compiled, in the form that would ship (`form`; an area
    model's `area_compiled_cost`: its shader form, SPIR-V only).

    `spirv` and `sass` are the compilers' counts (None where that compiler is not
    installed); `estimate` is the traced-operation model's weighted count of the same form;
    `method` says which of them `cost` is (the first available of SPIR-V, SASS, estimate).
    """

    family: str
    form: str
    spirv: Compiled | None
    sass: Compiled | None
    estimate: float
    method: str

    @property
    def cost(self) -> float:
        """The number a ranking uses: SPIR-V instructions, SASS instructions, or the estimate."""
        if self.method == "spirv" and self.spirv is not None:
            return float(self.spirv.total)
        if self.method == "sass" and self.sass is not None:
            return float(self.sass.total)
        return float(self.estimate)

    def label(self) -> str:
        """What `cost` counts, naming the compiler."""
        if self.method == "spirv" and self.spirv is not None:
            return f"SPIR-V instructions ({self.spirv.tool})"
        if self.method == "sass" and self.sass is not None:
            return f"SASS instructions ({self.sass.tool})"
        return "estimate: weighted traced operations (no compiler installed)"

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict."""
        return {
            "family": self.family,
            "form": self.form,
            "cost": self.cost,
            "method": self.method,
            "label": self.label(),
            "spirv": None if self.spirv is None else self.spirv.to_dict(),
            "sass": None if self.sass is None else self.sass.to_dict(),
            "estimate": self.estimate,
        }


def compiled_cost(family: Any, *, form: str = "shader", sass: bool = True) -> CompiledCost:
    """The `CompiledCost` of `family` (an instance) with its parameters baked in.

    `form` is "shader" (a family without a shader form is costed in its stable form, and
    `CompiledCost.form` says so) or "stable". `sass=False` skips the CUDA compilers.
    """
    from ._export import function_source

    fname = "attenfit_curve"
    glsl, used = function_source(family, "glsl", fname, form=form, header=False)
    method = cost_method()
    spirv = spirv_counts(glsl, fname)
    cuda = None
    if sass or method == "sass":
        cuda = sass_counts(
            function_source(family, "cuda", fname, form=used, header=False)[0], fname
        )
    return CompiledCost(family.name, used, spirv, cuda, _estimate(family, used), method)


#: Parameter values by constraint for `structural_cost`: none a compiler folds away (0, 1, an
#: integer exponent), so that a model costs the same whatever values it is fitted to.
_GENERIC = {"positive": 0.7313, "nonnegative": 0.5311, "unit": 0.3713, "real": 0.4217}


def generic_model(model: Any) -> Any:
    """`model` with its scalar parameters at the generic values of their constraints."""
    generic = {
        p: _GENERIC[model.constraint(p)] for p, v in model.params().items() if np.ndim(v) == 0
    }
    return model.replace(**generic) if generic else model


def structural_cost(family: Any, *, form: str = "shader", sass: bool = False) -> CompiledCost:
    """`compiled_cost` of `family`'s expression with its scalar parameters at generic values.

    The count of a family's shader, the same for every light it is fitted to (per light an
    engine reads its parameters from the light's data, it does not fold them): what ranks
    the candidates of a scene. Compiled once per family and cached, since its source text
    does not change with the fitted values.
    """
    return compiled_cost(generic_model(family), form=form, sass=sass)


def _estimate(family: Any, form: str) -> float:
    """The traced-operation model (`SHADER_WEIGHTS`) on the form."""
    from ._cost import form_cost, shader_cost

    sf = family.shader_form() if form == "shader" else None
    return shader_cost(family) if sf is None else form_cost(sf)
