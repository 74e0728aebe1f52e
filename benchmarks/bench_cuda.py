"""Every family's exported CUDA function timed on a GPU (where one is lent), against
`inverse_square` in the same run.

The functions are `attenfit export NAME --lang cuda` (the shader form, parameters baked in
as float32 literals), each called `REPS` times per thread over `N` distances log-spaced from
1e-3 to 1e3 (a dependent chain: each call's distance moves by the last result, so the
compiler can neither hoist nor drop a call). nvcc `-O3` for the GPU's own architecture;
CUDA events time the median of `ROUNDS` launches. Where nvcc or a GPU is missing, it says
so and stops: the compiled instruction counts of docs/shaders.md need no GPU.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

import attenfit as af
from attenfit.export import export

N = 1 << 24
REPS = 64
ROUNDS = 7

_KERNEL = """
__global__ void k_{name}(const float* d, float* out, int n) {{
    int i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i >= n) return;
    float x = d[i], acc = 0.0f;
    for (int k = 0; k < {reps}; ++k) {{ float f = attenfit_{name}(x); acc += f; x += 1e-30f * f; }}
    out[i] = acc;
}}
"""

_MAIN = """
#include <cstdio>
#include <cmath>
#include <algorithm>
#include <vector>
int main() {{
    const int n = {n};
    std::vector<float> h(n);
    for (int i = 0; i < n; ++i) h[i] = 1e-3f * powf(1e6f, (float)i / n);
    float *d, *out; cudaMalloc(&d, n * 4); cudaMalloc(&out, n * 4);
    cudaMemcpy(d, h.data(), n * 4, cudaMemcpyHostToDevice);
    cudaEvent_t a, b; cudaEventCreate(&a); cudaEventCreate(&b);
    {calls}
    return 0;
}}
"""

_CALL = """
    {{ std::vector<float> ms;
      for (int r = 0; r < {rounds} + 1; ++r) {{
        cudaEventRecord(a); k_{name}<<<(n + 255) / 256, 256>>>(d, out, n); cudaEventRecord(b);
        cudaEventSynchronize(b); float t; cudaEventElapsedTime(&t, a, b); if (r) ms.push_back(t); }}
      std::sort(ms.begin(), ms.end());
      printf("{name} %.6f\\n", ms[ms.size() / 2]); }}
"""


def source(names: list[str]) -> str:
    """One CUDA program timing each family's exported function."""
    parts = [export(name, "cuda") for name in names]
    parts += [_KERNEL.format(name=name, reps=REPS) for name in names]
    calls = "".join(_CALL.format(name=name, rounds=ROUNDS) for name in names)
    return "\n".join(parts) + _MAIN.format(n=N, calls=calls)


def main() -> None:
    names = af.list_families()
    nvcc = shutil.which("nvcc")
    if nvcc is None or shutil.which("nvidia-smi") is None:
        print("no nvcc or no GPU here: skipped (docs/shaders.md has the compiled counts)")
        return
    gpu = subprocess.run(
        ["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True, text=True
    ).stdout.strip()
    with tempfile.TemporaryDirectory() as tmp:
        cu = Path(tmp) / "families.cu"
        cu.write_text(source(names), encoding="utf-8")
        exe = Path(tmp) / "families"
        subprocess.run([nvcc, "-O3", "-arch=native", str(cu), "-o", str(exe)], check=True)
        out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    ms = {line.split()[0]: float(line.split()[1]) for line in out.splitlines()}
    base = ms["inverse_square"]
    print(f"{gpu}: {N} threads x {REPS} calls, median of {ROUNDS} launches (CUDA events)")
    print("  family              ms   G calls/s  x inverse_square")
    for name in names:
        rate = N * REPS / (ms[name] * 1e-3) / 1e9
        print(f"  {name:18s} {ms[name]:6.3f} {rate:10.1f} {ms[name] / base:10.2f}")


if __name__ == "__main__":
    main()
