"""The external tools the export tests validate with (glslangValidator, spirv-val, naga, cc)."""

import re
import shutil
import subprocess
from pathlib import Path

import pytest


def need(tool: str) -> str:
    """The path of `tool`, or skip the test, saying the validation did not run."""
    path = shutil.which(tool)
    if path is None:
        pytest.skip(f"{tool} is not installed: this validation did not run")
    return path


def run(cmd: list[str], cwd: Path) -> None:
    """Run `cmd` in `cwd`; fail with its output when it fails."""
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
    assert proc.returncode == 0, f"{' '.join(cmd)}:\n{proc.stdout}\n{proc.stderr}"


def check_hlsl(tmp_path: Path, name: str, functions: str, calls: str) -> None:
    """Compile `functions` and a fragment shader returning `calls` (a float expression) to
    SPIR-V with glslangValidator, and validate it with spirv-val where installed."""
    tool = need("glslangValidator")
    src = functions + f"float4 main(float v : TEXCOORD0) : SV_Target {{ return ({calls}).xxxx; }}\n"
    (tmp_path / f"{name}.hlsl").write_text(src)
    run(
        [tool, "-D", "-V", "-S", "frag", "-e", "main", "-o", f"{name}.spv", f"{name}.hlsl"],
        tmp_path,
    )
    if shutil.which("spirv-val"):
        run(["spirv-val", f"{name}.spv"], tmp_path)


def check_wgsl(tmp_path: Path, tool: str, name: str, functions: str, calls: str) -> None:
    """Validate `functions` and a fragment shader returning `calls` with naga or tint; each
    uniform buffer gets its own binding (one module holds several)."""
    path = need(tool)
    src = functions + (
        "@fragment fn main(@location(0) v: f32) -> @location(0) vec4<f32> "
        f"{{ return vec4<f32>({calls}); }}\n"
    )
    counter = iter(range(1000))
    src = re.sub(r"@binding\(0\)", lambda m: f"@binding({next(counter)})", src)
    (tmp_path / f"{name}.wgsl").write_text(src)
    file = f"{name}.wgsl"
    run([path, file] if tool == "naga" else [path, "--format", "wgsl", file], tmp_path)
