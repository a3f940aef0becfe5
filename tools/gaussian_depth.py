#!/usr/bin/python3
"""How deep a Gaussian avatar's Gaussians lie under its canonical mesh, by the
direction the surface faces against a ring of training cameras.

Each Gaussian's height is its distance along the normal of the nearest face
(negative: below the surface), in initial spacings (sqrt(mesh area / N), N the
run's `model.gaussians.initial`); Gaussians of opacity over 0.3 on faces whose
normal is within 30 degrees of horizontal (|n_y| < 0.5) are binned by the
angle between the normal's azimuth and the nearest of the ring's camera axes
(0: facing a camera; 180 / cameras: halfway between two). The canonical
frame stands for the world's: a fair proxy where the root barely turns.

    PYTHONPATH=build/python /usr/bin/python3 tools/gaussian_depth.py RUN [--cameras 4]

RUN is a Gaussian avatar run; its Gaussians are read from the 3DGS PLY that
`fskin.export_avatar` writes into a temporary folder.
"""
import argparse
import json
import pathlib
import tempfile

import numpy as np
import torch

import fskin


def read_gaussians(ply):
    raw = pathlib.Path(ply).read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    header = raw[:end].decode().splitlines()
    count = int(next(line for line in header if line.startswith("element vertex")).split()[2])
    joint = next(i for i, line in enumerate(header) if line.startswith("element joint"))
    properties = [line.split() for line in header[:joint] if line.startswith("property")]
    kinds = {"float": "<f4", "uchar": "u1", "int": "<i4", "uint": "<u4"}
    dtype = np.dtype([(p[2], kinds[p[1]]) for p in properties])
    vertex = np.frombuffer(raw[end:end + count * dtype.itemsize], dtype=dtype)
    means = np.stack([vertex["x"], vertex["y"], vertex["z"]], 1).astype(np.float64)
    opacity = 1 / (1 + np.exp(-vertex["opacity"].astype(np.float64)))
    return means, opacity


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run")
    parser.add_argument("--cameras", type=int, default=4, help="training cameras on the ring (from azimuth 0)")
    args = parser.parse_args()
    run = pathlib.Path(args.run)
    if not (run / "gaussian_avatar.json").is_file():
        raise SystemExit(f"{run}: not a Gaussian avatar run (no gaussian_avatar.json)")
    if args.cameras < 1:
        raise SystemExit(f"--cameras {args.cameras}: need at least 1")
    with tempfile.TemporaryDirectory() as scratch:
        ply = pathlib.Path(scratch) / "gaussians.ply"
        fskin.export_avatar(str(run), str(ply))
        means, opacity = read_gaussians(ply)
    character = np.load(run / "canonical.npz")
    vertices, faces = character["vertices"].astype(np.float64), character["faces"]
    initial = json.loads((run / "gaussian_avatar.json").read_text())["model"]["gaussians"]["initial"]
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(normal, axis=1)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    spacing = np.sqrt(area.sum() / initial)
    # The nearest face by dense area-uniform samples (a fifth of a spacing apart or closer).
    rng = np.random.default_rng(0)
    samples = 400000
    face = rng.choice(len(faces), samples, p=area / area.sum())
    r1, r2 = rng.random(samples), rng.random(samples)
    s = np.sqrt(r1)
    points = a[face] * (1 - s)[:, None] + b[face] * (s * (1 - r2))[:, None] + c[face] * (s * r2)[:, None]
    target = torch.from_numpy(points).float()
    query = torch.from_numpy(means).float()
    nearest = torch.cat([torch.cdist(query[i:i + 500], target).argmin(1) for i in range(0, len(query), 500)]).numpy()
    n = normal[face[nearest]]
    height = ((means - points[nearest]) * n).sum(1) / spacing
    period = 360.0 / args.cameras
    azimuth = np.degrees(np.arctan2(n[:, 0], n[:, 2])) % period
    offset = np.minimum(azimuth, period - azimuth)
    chosen = (np.abs(n[:, 1]) < 0.5) & (opacity > 0.3)
    print(f"{len(means)} Gaussians, initial spacing {spacing:.5f}; {chosen.sum()} on near-horizontal faces, opacity > 0.3")
    print("faces turned from the nearest camera axis   Gaussians   mean height   90th percentile (spacings)")
    half = period / 2
    edges = np.linspace(0, half, 6)
    for low, high in zip(edges[:-1], edges[1:]):
        inside = chosen & (offset >= low) & (offset < high + (1e-9 if high == half else 0))
        if inside.any():
            print(f"{low:5.1f}-{high:4.1f} degrees {inside.sum():26d} {height[inside].mean():+13.3f} "
                  f"{np.percentile(height[inside], 90):+17.3f}")


if __name__ == "__main__":
    main()
