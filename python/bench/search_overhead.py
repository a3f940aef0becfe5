"""The Fast-SNARF search called from Python against the same search in C++.

Writes one scene (a 2-bone chain's voxel grid, 200k points, a bent pose) to an
.npz, then alternates rounds: fskin_bench's BM_FastSnarfSearchFromFile on it
(C++), and fskin.FastSnarfDeformer.forward on it (Python), each the median of
its repetitions; prints the medians over rounds and their ratio.

    PYTHONPATH=build/python /usr/bin/python3 python/bench/search_overhead.py build/fskin_bench
"""
import json
import math
import os
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("GOMP_SPINCOUNT", "15000")  # what fskin_bench restarts with
import torch  # noqa: E402

import fskin  # noqa: E402

POINTS, ROUNDS, REPEATS = 200_000, 5, 7


def scene(path):
    corners = torch.tensor([[-1.2, -0.4, -0.4], [1.2, 0.4, 0.4]])
    box = fskin.VoxelBox.fit(corners, 24, 0.05)
    w1 = torch.sigmoid(box.voxel_centres()[..., 0] * 8)
    grid = torch.stack([1 - w1, w1], -1).contiguous()
    g = torch.Generator().manual_seed(0)
    x = torch.rand(POINTS, generator=g) * 1.8 - 0.9
    yz = (torch.rand(POINTS, 2, generator=g) - 0.5) * 0.3
    canonical = torch.cat([x[:, None], yz], 1)[None].contiguous()
    c, s = math.cos(0.9), math.sin(0.9)
    bones = torch.stack([torch.eye(4), torch.tensor([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])])[None]
    import numpy as np
    np.savez(path, corners=corners.numpy(), grid=grid.numpy(), canonical=canonical.numpy(), bones=bones.numpy())
    return box, grid, canonical, bones


def main():
    bench = sys.argv[1] if len(sys.argv) > 1 else "build/fskin_bench"
    torch.set_num_threads(os.cpu_count())  # as fskin_bench and the CLI
    path = os.path.join(tempfile.mkdtemp(), "scene.npz")
    box, grid, canonical, bones = scene(path)
    deformer = fskin.FastSnarfDeformer(grid, box)
    with torch.no_grad():
        posed = deformer.deform(canonical, bones)
    cpp, py = [], []
    for _ in range(ROUNDS):
        out = subprocess.run([bench, "--benchmark_filter=BM_FastSnarfSearchFromFile",
                              f"--benchmark_repetitions={REPEATS}", "--benchmark_format=json"],
                             env={**os.environ, "FSKIN_BENCH_SEARCH_INPUT": path}, check=True,
                             capture_output=True, text=True).stdout
        runs = [b for b in json.loads(out)["benchmarks"] if b.get("run_type") == "iteration"]
        cpp.append(sorted(b["real_time"] for b in runs)[len(runs) // 2])
        times = []
        with torch.no_grad():
            deformer.forward(posed, bones)  # warm-up
            for _ in range(REPEATS):
                start = time.perf_counter()
                deformer.forward(posed, bones)
                times.append(1000 * (time.perf_counter() - start))
        py.append(sorted(times)[len(times) // 2])
    cpp_ms, py_ms = sorted(cpp)[ROUNDS // 2], sorted(py)[ROUNDS // 2]
    print(f"search of {POINTS} points, {ROUNDS} rounds x {REPEATS} repetitions, {torch.get_num_threads()} threads")
    print(f"C++ (fskin_bench)  median {cpp_ms:.1f} ms  rounds {[round(v, 1) for v in cpp]}")
    print(f"Python (fskin)     median {py_ms:.1f} ms  rounds {[round(v, 1) for v in py]}")
    print(f"Python / C++ = {py_ms / cpp_ms:.3f}")


if __name__ == "__main__":
    main()
