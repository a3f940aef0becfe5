"""Learn an animatable avatar of the built-in character from Python, then re-pose it.

The whole fskin pipeline through the Python module: a character, training and
out-of-distribution poses, a dataset of posed occupancy samples, Fast-SNARF
training, evaluation on unseen poses, the canonical surface, that surface moved
into the unseen poses (one mesh, the same faces in every frame) and a rigged glTF.

    PYTHONPATH=build/python /usr/bin/python3 python/examples/train_and_repose.py OUT [--steps N] [--quick]

--quick shrinks everything (tiny networks, few poses and points) to run in seconds,
as the test suite does; the defaults are those of `make demo`.
"""
import argparse
import json
import pathlib

import torch

import fskin

QUICK_SETTINGS = ["frames_per_batch=2", "surface_points=500", "uniform_points=250", "occupancy_hidden_dim=32",
                  "occupancy_hidden_layers=3", "skinning_hidden_dim=16", "skinning_hidden_layers=2",
                  "grid_resolution=16", "checkpoint_every=50"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", type=pathlib.Path, help="output directory")
    parser.add_argument("--steps", type=int, default=1000, help="training steps")
    parser.add_argument("--quick", action="store_true", help="tiny sizes (seconds, not minutes)")
    parser.add_argument("--device", default="cpu", help="cpu, cuda or cuda:N")
    args = parser.parse_args()
    out = args.out
    out.mkdir(parents=True, exist_ok=True)

    # A character (any BodyModel: fskin.BodyModel.load reads SMPL files and fskin's imports).
    body = fskin.humanoid(resolution=40 if args.quick else 150)
    body.save(str(out / "character.npz"))
    train_poses = fskin.training_poses(body, sequences=2 if args.quick else 8, frames=6 if args.quick else 25)
    unseen_poses = fskin.ood_poses(body, count=2 if args.quick else 3, seed=7)

    # Posed occupancy samples; the unseen poses become the test_ood split.
    summary = fskin.build_dataset(str(out / "character.npz"), train_poses, str(out / "data"), ood_poses=unseen_poses,
                                  points=4000 if args.quick else 50000, progress=not args.quick)
    print("dataset:", summary)

    result = fskin.train(str(out / "data"), str(out / "run"), steps=args.steps,
                         settings=QUICK_SETTINGS if args.quick else [], progress=not args.quick, device=args.device)
    print(f"trained {result['method']}: loss {result['first_loss']:.4f} -> {result['last_loss']:.4f} "
          f"in {result['seconds']:.1f} s")
    scores = fskin.evaluate(str(out / "run"), "test-ood", write_json=True, device=args.device)
    print(f"unseen poses: IoU_bbox {scores['mean_iou_bbox']:.3f}, IoU_surf {scores['mean_iou_surf']:.3f}")

    run = fskin.Run(str(out / "run"), device=args.device)
    resolution = 32 if args.quick else 128
    vertices, faces = run.mesh(resolution=resolution, initial=8 if args.quick else 32, largest_component=True)
    fskin.write_mesh(str(out / "canonical.ply"), vertices, faces)
    bones = run.bone_transforms(unseen_poses)
    with torch.no_grad():
        frames = run.repose(vertices, faces, bones)  # [N, V, 3]: every vertex keeps its identity
    for n, frame in enumerate(frames):
        fskin.write_mesh(str(out / f"unseen_{n}.ply"), frame, faces)
    run.export_gltf(str(out / "avatar.glb"), bones=bones, resolution=resolution, initial=8 if args.quick else 32)
    (out / "summary.json").write_text(json.dumps({
        "method": result["method"], "steps": result["last_step"], "test_ood_iou_surf": scores["mean_iou_surf"],
        "canonical_vertices": int(vertices.shape[0]), "reposed_frames": int(frames.shape[0])}, indent=2) + "\n")
    print(f"wrote {out}/canonical.ply, unseen_*.ply, avatar.glb, summary.json")


if __name__ == "__main__":
    main()
