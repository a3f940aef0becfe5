"""The radiance-field ops and avatars from images, from Python."""
import json

import numpy as np
import pytest
import torch

import fskin


def test_hash_encoding_gradcheck_and_matches_shapes():
    torch.manual_seed(0)
    table = fskin.hash_encoding_table(levels=3, features_per_level=2, log2_table_size=6, base_resolution=2,
                                      per_level_scale=2.0, dtype=torch.float64) * 1e4
    table.requires_grad_(True)
    x = (torch.rand(7, 3, dtype=torch.float64) * 0.8 + 0.1).requires_grad_(True)
    features = fskin.hash_encoding(x, table, levels=3, features_per_level=2, log2_table_size=6, base_resolution=2,
                                   per_level_scale=2.0)
    assert features.shape == (7, 6)

    def encode(points, rows):
        return fskin.hash_encoding(points, rows, levels=3, features_per_level=2, log2_table_size=6,
                                   base_resolution=2, per_level_scale=2.0)

    assert torch.autograd.gradcheck(encode, (x, table), eps=1e-6, atol=1e-5)
    with pytest.raises(fskin.Error, match="levels"):
        fskin.hash_encoding_table(levels=0)


def test_composite_rays_matches_the_closed_form():
    sigma = torch.full((2, 4), 2.0, dtype=torch.float64, requires_grad=True)
    rgb = torch.full((2, 4, 3), 0.5, dtype=torch.float64, requires_grad=True)
    delta = torch.full((2, 4), 0.25, dtype=torch.float64)
    background = torch.zeros(2, 3, dtype=torch.float64)
    color, opacity = fskin.composite_rays(sigma, rgb, delta, background)
    expected = 1 - torch.exp(torch.tensor(-2.0, dtype=torch.float64))  # sigma * total length = 2
    assert torch.allclose(opacity, expected.expand(2))
    assert torch.allclose(color, 0.5 * expected.expand(2, 3))
    assert torch.autograd.gradcheck(lambda s, c: fskin.composite_rays(s, c, delta, background)[0], (sigma, rgb))


def test_composite_rays_has_a_gradient_for_every_input():
    torch.manual_seed(0)
    sigma = (torch.rand(3, 5, dtype=torch.float64) * 4).requires_grad_()
    rgb = torch.rand(3, 5, 3, dtype=torch.float64, requires_grad=True)
    delta = (torch.rand(3, 5, dtype=torch.float64) * 0.2 + 0.01).requires_grad_()
    background = torch.rand(3, 3, dtype=torch.float64, requires_grad=True)

    def both(s, c, d, b):
        color, opacity = fskin.composite_rays(s, c, d, b)
        return color, opacity

    assert torch.autograd.gradcheck(both, (sigma, rgb, delta, background))


def test_build_image_dataset_takes_the_clis_options(tmp_path):
    model = str(tmp_path / "model.npz")
    fskin.humanoid(resolution=32).save(model)
    body = fskin.BodyModel.load(model)
    poses = fskin.training_poses(body, sequences=1, frames=1)
    fskin.build_image_dataset(model, poses, str(tmp_path / "images"), width=24, height=16, views=1, held_out_views=1,
                              novel_view_frames=0, supersampling=1, canonical_pose="rest", background=(0, 0, 0),
                              light=(0.0, 1.0, 0.0), ambient=0.25)
    manifest = json.loads((tmp_path / "images" / "manifest.json").read_text())
    assert manifest["background"] == [0, 0, 0]
    assert manifest["light"] == [0.0, 1.0, 0.0] and manifest["ambient"] == 0.25
    cameras = np.load(tmp_path / "images" / "train" / "cameras.npz")
    assert int(cameras["width"]) == 24 and int(cameras["height"]) == 16
    with pytest.raises(fskin.Error, match="build_image_dataset: poses"):
        fskin.build_image_dataset(model, poses[:, :3], str(tmp_path / "bad"))


def test_image_dataset_training_and_evaluation(tmp_path):
    model = str(tmp_path / "model.npz")
    fskin.humanoid(resolution=40).save(model)
    body = fskin.BodyModel.load(model)
    poses = fskin.training_poses(body, sequences=1, frames=2)
    held_out = fskin.ood_poses(body, count=1)
    summary = fskin.build_image_dataset(model, poses, str(tmp_path / "images"), held_out_poses=held_out, size=32,
                                        views=2, held_out_views=1, novel_view_frames=1)
    assert "train 4" in summary
    result = fskin.train_avatar(str(tmp_path / "images"), str(tmp_path / "run"), steps=30, rays_per_step=512)
    assert result["last_step"] == 30
    scores = fskin.evaluate_avatar(str(tmp_path / "run"), split="train")
    assert scores["images"] == 4 and scores["mean_psnr"] > 10
    fitted = fskin.evaluate_avatar(str(tmp_path / "run"), split="train", max_images=1, fit_poses=2)
    assert fitted["pose_fitting_steps"] == 2 and scores["pose_fitting_steps"] == 0
    # A render of a training image's pose and camera, through the bindings.
    split_dir = tmp_path / "images" / "train"
    cam = np.load(split_dir / "cameras.npz")
    bones = np.load(split_dir / "poses.npz")["bone_transforms"]
    rgb, opacity = fskin.render_avatar(str(tmp_path / "run"), torch.from_numpy(bones[0]),
                                       torch.from_numpy(cam["intrinsic"][0]), torch.from_numpy(cam["extrinsic"][0]),
                                       32, 32)
    assert rgb.shape == (32, 32, 3) and opacity.shape == (32, 32)
    assert 0.0 < float(opacity.max()) <= 1.0
    # 30 steps leave no surface to export yet (the export of a trained avatar: tests/radiance/avatar_test.cpp).
    with pytest.raises(fskin.Error, match="is the avatar trained"):
        fskin.export_avatar(str(tmp_path / "run"), str(tmp_path / "avatar.glb"), bones=torch.from_numpy(bones))
    # Every avatar option through settings and a config file, as `fskin avatar train --set / --config`.
    config = tmp_path / "avatar.json"
    config.write_text(json.dumps({"model": {"field": {"network": {"hidden_dim": 16}}}}))
    fskin.train_avatar(str(tmp_path / "images"), str(tmp_path / "run2"), steps=2, rays_per_step=64,
                       settings=["model.occupancy_grid.every=7", "losses.opacity.weight=0.2",
                                 "model.skinning.type=learned", "model.field.appearance.dim=4"], config=str(config))
    recorded = json.loads((tmp_path / "run2" / "avatar.json").read_text())
    assert recorded["model"]["occupancy_grid"]["every"] == 7
    assert recorded["model"]["skinning"]["type"] == "learned"
    assert recorded["model"]["field"]["appearance"]["dim"] == 4
    assert fskin.evaluate_avatar(str(tmp_path / "run2"), split="train", max_images=1)["images"] == 1
    assert recorded["model"]["field"]["network"]["hidden_dim"] == 16
    assert recorded["losses"]["opacity"]["weight"] == 0.2
    with pytest.raises(fskin.Error, match="model.occupancy_grid.evry: unknown key"):
        fskin.train_avatar(str(tmp_path / "images"), str(tmp_path / "run3"), steps=1,
                           settings=["model.occupancy_grid.evry=7"])
    # Noisy poses, refined while training (`fskin data perturb-poses`, `--refine-poses`, `fskin avatar poses`).
    assert "2 poses perturbed" in fskin.perturb_poses(str(tmp_path / "images"), str(tmp_path / "noisy"), degrees=5.0)
    noisy = np.load(tmp_path / "noisy" / "train" / "poses.npz")
    assert not np.allclose(noisy["bone_transforms"], noisy["bone_transforms_exact"])
    fskin.train_avatar(str(tmp_path / "noisy"), str(tmp_path / "run4"), steps=3, rays_per_step=64,
                       settings=["pose_refinement.enabled=true", "pose_refinement.learning_rate=0.01"])
    refined = fskin.refined_poses(str(tmp_path / "run4"))
    assert refined["given"].shape == refined["refined"].shape == refined["exact"].shape == (2, body.num_joints, 4, 4)
    assert not torch.equal(refined["given"], refined["refined"])
    assert "against the exact poses" in refined["summary"]
    with pytest.raises(fskin.Error, match="does not refine poses"):
        fskin.refined_poses(str(tmp_path / "run2"))


def test_import_capture_reads_a_peoplesnapshot_folder(tmp_path):
    """A capture made from an fskin image dataset (images, .npy masks, one camera, SMPL-style
    thetas): the imported dataset trains-ready and holds every frame."""
    model = str(tmp_path / "model.npz")
    fskin.humanoid(resolution=32).save(model)
    body = fskin.BodyModel.load(model)
    poses = fskin.training_poses(body, sequences=1, frames=3)
    fskin.build_image_dataset(model, poses, str(tmp_path / "images"), size=24, views=1, held_out_views=1,
                              novel_view_frames=0, monocular=True, supersampling=1)
    capture = tmp_path / "capture"
    (capture / "images").mkdir(parents=True)
    (capture / "masks").mkdir()
    split = tmp_path / "images" / "train"
    for i in range(3):
        (capture / "images" / f"image_{i:04d}.png").write_bytes((split / "images" / f"image_{i:04d}.png").read_bytes())
        np.save(capture / "masks" / f"mask_{i:04d}.npy", np.ones((24, 24), dtype=bool))
    (capture / "cameras.npz").write_bytes((split / "cameras.npz").read_bytes())
    np.savez(capture / "poses.npz", thetas=poses.reshape(3, -1).numpy(), transl=np.zeros((3, 3), np.float32),
             betas=np.zeros(10, np.float32))
    summary = fskin.import_capture(str(capture), model, str(tmp_path / "imported"), train="0:2", novel_pose="2:")
    assert "train 2" in summary and "novel_pose 1" in summary
    manifest = json.loads((tmp_path / "imported" / "manifest.json").read_text())
    assert manifest["splits"] == ["train", "novel_pose"] and manifest["capture_layout"].startswith("PeopleSnapshot")
    with pytest.raises(fskin.Error, match="--train"):
        fskin.import_capture(str(capture), model, str(tmp_path / "bad"), train="2:1")


def test_gaussian_avatars_train_evaluate_render_and_export(tmp_path):
    model = str(tmp_path / "model.npz")
    fskin.humanoid(resolution=40).save(model)
    body = fskin.BodyModel.load(model)
    poses = fskin.training_poses(body, sequences=1, frames=2)
    fskin.build_image_dataset(model, poses, str(tmp_path / "images"), held_out_poses=fskin.ood_poses(body, count=1),
                              size=32, views=2, held_out_views=1, novel_view_frames=1)
    run = str(tmp_path / "gaussians")
    result = fskin.train_gaussian_avatar(str(tmp_path / "images"), run, steps=20,
                                         settings=["model.gaussians.initial=500", "density.start=10",
                                                   "density.every=10"])
    assert result["last_step"] == 20 and result["gaussians"] != 500
    scores = fskin.evaluate_avatar(run, split="train")
    assert scores["images"] == 4 and scores["mean_psnr"] > 10
    split_dir = tmp_path / "images" / "train"
    cam = np.load(split_dir / "cameras.npz")
    bones = np.load(split_dir / "poses.npz")["bone_transforms"]
    rgb, alpha = fskin.render_avatar(run, torch.from_numpy(bones[0]), torch.from_numpy(cam["intrinsic"][0]),
                                     torch.from_numpy(cam["extrinsic"][0]), 32, 32)
    assert rgb.shape == (32, 32, 3) and 0.0 < float(alpha.max()) <= 1.0
    truth = fskin.read_png(str(split_dir / "images" / "image_0000.png"))
    assert truth.shape == (32, 32, 3) and truth.dtype == torch.uint8 and int(truth.max()) > 0
    with pytest.raises(fskin.Error, match="nothing.png"):
        fskin.read_png(str(tmp_path / "nothing.png"))
    fskin.write_png(str(tmp_path / "copy.png"), truth.flip(1))
    assert torch.equal(fskin.read_png(str(tmp_path / "copy.png")), truth.flip(1))
    with pytest.raises(fskin.Error, match="bad.png.*RGB uint8"):
        fskin.write_png(str(tmp_path / "bad.png"), truth.float())
    fskin.export_avatar(run, str(tmp_path / "avatar.ply"), bones=torch.from_numpy(bones))
    header = (tmp_path / "avatar.ply").read_bytes()[:200]
    assert header.startswith(b"ply\nformat binary_little_endian 1.0\n")
    # glTF with the Khronos extension: its JSON chunk names the extension and the animation's frames.
    fskin.export_avatar(run, str(tmp_path / "avatar.glb"), bones=torch.from_numpy(bones), influences=0)
    glb = (tmp_path / "avatar.glb").read_bytes()
    assert glb[:4] == b"glTF"
    document = json.loads(glb[20:20 + int.from_bytes(glb[12:16], "little")])
    assert document["extensionsUsed"] == ["KHR_gaussian_splatting"]
    assert document["meshes"][0]["primitives"][0]["mode"] == 0
    assert document["accessors"][document["animations"][0]["samplers"][0]["input"]]["count"] == len(bones)
    with pytest.raises(fskin.Error, match="avatar.obj"):
        fskin.export_avatar(run, str(tmp_path / "avatar.obj"))
    # The Gaussians baked into the character's mesh: a skinned triangle mesh with vertex colours.
    fskin.export_avatar(run, str(tmp_path / "baked.glb"), bones=torch.from_numpy(bones), mesh=True, subdivisions=1)
    glb = (tmp_path / "baked.glb").read_bytes()
    document = json.loads(glb[20:20 + int.from_bytes(glb[12:16], "little")])
    primitive = document["meshes"][0]["primitives"][0]
    assert primitive.get("mode", 4) == 4 and "COLOR_0" in primitive["attributes"]
    assert "extensionsUsed" not in document and len(document["skins"]) == 1
    with pytest.raises(fskin.Error, match="baked.ply.*glTF"):
        fskin.export_avatar(run, str(tmp_path / "baked.ply"), mesh=True)
    assert fskin.evaluate_avatar(run, split="train", max_images=1, mesh=True)["mean_psnr"] > 10
    assert fskin.evaluate_avatar(run, split="novel_pose", max_images=1, fit_poses=2)["pose_fitting_steps"] == 2
    # Noisy poses refined while training, and shading by a learned lighting of the posed normal.
    fskin.perturb_poses(str(tmp_path / "images"), str(tmp_path / "noisy"), degrees=5.0)
    refined_run = str(tmp_path / "refined")
    summary = fskin.train_gaussian_avatar(
        str(tmp_path / "noisy"), refined_run, steps=5,
        settings=["model.gaussians.initial=300", "pose_refinement.enabled=true", "pose_refinement.learning_rate=0.01",
                  "pose_refinement.first_pass_steps=5", "pose_refinement.fit_steps=5",
                  "model.shading=irradiance"])
    assert (summary["pose_pass_first_step"], summary["pose_pass_last_step"]) == (0, 5)  # then the run's 5 steps
    refined = fskin.refined_poses(refined_run)
    assert refined["given"].shape == refined["refined"].shape == (2, body.num_joints, 4, 4)
    assert not torch.equal(refined["given"], refined["refined"])
    with pytest.raises(fskin.Error, match="does not refine poses"):
        fskin.refined_poses(run)
    with pytest.raises(fskin.Error, match="unknown key"):
        fskin.train_gaussian_avatar(str(tmp_path / "images"), str(tmp_path / "bad"), steps=1,
                                    settings=["model.gaussians.colour=1"])
