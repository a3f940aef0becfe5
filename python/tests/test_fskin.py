"""The Python module against the library and the CLI it wraps."""
import json
import math
import os
import subprocess

import numpy as np
import pytest
import torch

import fskin

CLI = os.environ.get("FSKIN_CLI", "fskin")


def read_binary_ply_vertices(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    count = int(header.split("element vertex ")[1].split("\n")[0])
    vertex_props = header.split("element vertex")[1].split("element face")[0].count("property")
    assert "property float x" in header
    stride = 4 * 3 + (vertex_props - 3)  # float xyz, then uchar colours if any
    rows = np.frombuffer(data[end:end + count * stride], dtype=np.uint8).reshape(count, stride)
    return rows[:, :12].copy().view(np.float32).reshape(count, 3)


def test_version_and_errors_are_fskins():
    assert fskin.__version__.count(".") == 2
    assert issubclass(fskin.Error, RuntimeError)
    with pytest.raises(fskin.Error, match="missing.npz"):
        fskin.BodyModel.load("/nonexistent/missing.npz")


def test_body_model_poses_like_the_cli(tmp_path):
    body = fskin.humanoid(resolution=40)
    model = tmp_path / "model.npz"
    body.save(str(model))
    torch.manual_seed(0)
    pose = torch.randn(1, body.num_joints, 3) * 0.3
    trans = torch.tensor([[0.1, -0.2, 0.3]])
    # The same pose through the CLI: a pose file, `fskin pose`, the PLY it writes.
    poses = tmp_path / "pose.npz"
    np.savez(poses, poses=pose.numpy(), trans=trans.numpy())
    out = tmp_path / "posed.ply"
    subprocess.run([CLI, "pose", "--model", str(model), "--pose", str(poses), "--out", str(out)], check=True,
                   capture_output=True)
    vertices, joints, bones = fskin.BodyModel.load(str(model)).forward(pose, trans=trans)
    assert vertices.shape == (1, body.num_vertices, 3)
    assert joints.shape == (1, body.num_joints, 3)
    assert bones.shape == (1, body.num_joints, 4, 4)
    np.testing.assert_allclose(vertices[0].numpy(), read_binary_ply_vertices(out), atol=1e-5)
    assert body.joint_names[0] == "pelvis" and body.parents[0] == -1


def test_body_model_gradients_reach_the_callers_graph():
    body = fskin.quadruped(resolution=60)
    pose = torch.zeros(2, body.num_joints, 3, requires_grad=True)
    vertices, _, _ = body.forward(pose)
    vertices[:, :, 1].sum().backward()
    assert pose.grad is not None and pose.grad.abs().sum() > 0


def chain(dtype=torch.float64):
    """A 2-bone chain along +x, bones [-1, 0] and [0, 1], with smooth weights on a voxel grid."""
    points = torch.tensor([[-1.2, -0.4, -0.4], [1.2, 0.4, 0.4]], dtype=dtype)
    box = fskin.VoxelBox.fit(points, 24)
    centres = box.voxel_centres().to(dtype)
    w1 = torch.sigmoid(centres[..., 0] * 8)
    grid = torch.stack([1 - w1, w1], -1).contiguous()
    return grid, box


def bend(angle, dtype=torch.float64):
    """Bone 0 fixed, bone 1 turned by `angle` about z through the origin."""
    c, s = math.cos(angle), math.sin(angle)
    b1 = torch.tensor([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=dtype)
    return torch.stack([torch.eye(4, dtype=dtype), b1]).unsqueeze(0)


def canonical_points(n, dtype=torch.float64):
    g = torch.Generator().manual_seed(3)
    x = torch.rand(n, generator=g, dtype=dtype) * 1.8 - 0.9
    yz = (torch.rand(n, 2, generator=g, dtype=dtype) - 0.5) * 0.3
    return torch.cat([x[:, None], yz], 1).unsqueeze(0)


def test_deformer_finds_the_canonical_points_again():
    grid, box = chain()
    deformer = fskin.FastSnarfDeformer(grid, box)
    bones = bend(0.9)
    xc = canonical_points(500)
    xd = deformer.deform(xc, bones)
    roots, valid = deformer.forward(xd, bones)
    assert roots.shape == (1, 500, 2, 3) and valid.shape == (1, 500, 2)
    error = ((roots - xc.unsqueeze(2)).norm(dim=-1) + (~valid) * 1e9).min(-1).values
    assert (error < 1e-5).double().mean() > 0.99


def test_deformer_gradcheck_float64():
    grid, box = chain()
    bones = bend(0.6)
    for exact in (True, False):
        deformer = fskin.FastSnarfDeformer(grid, box, exact_gradient=exact, tolerance=1e-12)
        xd = deformer.deform(canonical_points(6), bones).detach()
        _, valid = deformer.forward(xd, bones)
        assert valid.any(-1).all()  # every point has its root
        mask = valid.unsqueeze(-1).double()

        def roots_of_points(x):
            return deformer.forward(x, bones)[0] * mask

        def roots_of_bones(b):
            return deformer.forward(xd, b)[0] * mask

        x = xd.clone().requires_grad_(True)
        b = bones.clone().requires_grad_(True)
        if exact:  # the exact implicit gradient (SNARF eq. 14) is the true derivative
            assert torch.autograd.gradcheck(roots_of_points, (x,), eps=1e-6, atol=1e-5)
            assert torch.autograd.gradcheck(roots_of_bones, (b,), eps=1e-6, atol=1e-5)
        else:  # Broyden's inverse Jacobian (Fast-SNARF eq. 17): close to the true derivative, not equal
            analytic = torch.autograd.functional.jacobian(roots_of_points, x)
            numeric = torch.zeros_like(analytic)
            eps = 1e-6
            for i in range(x.numel()):
                step = torch.zeros_like(x).view(-1)
                step[i] = eps
                step = step.view_as(x)
                numeric.view(-1, x.numel())[:, i] = (
                    (roots_of_points(x.detach() + step) - roots_of_points(x.detach() - step)) / (2 * eps)).view(-1)
            relative = (analytic - numeric).norm() / numeric.norm()
            assert relative < 0.05, relative


def test_roots_gradcheck_with_respect_to_a_learned_grid_float64():
    grid, box = chain()
    bones = bend(0.6)
    deformer = fskin.FastSnarfDeformer(grid, box, exact_gradient=True, tolerance=1e-12)
    xd = deformer.deform(canonical_points(4), bones).detach()
    _, valid = deformer.forward(xd, bones)
    assert valid.any(-1).all()
    mask = valid.unsqueeze(-1).double()
    # A few smooth modes of the grid (the full grid has thousands of entries).
    centres = box.voxel_centres().double()
    modes = torch.stack([torch.sin(centres[..., 0] * k) for k in (1.0, 2.0, 3.0)], -1)  # [D, H, W, 3]

    def roots_of_grid(a):
        deformer.grid_weights = grid * torch.exp(modes @ a)  # [D, H, W, 2], >= 0, with a's graph
        return deformer.forward(xd, bones)[0] * mask

    a = (torch.randn(3, 2, dtype=torch.float64) * 0.01).requires_grad_(True)
    assert torch.autograd.gradcheck(roots_of_grid, (a,), eps=1e-6, atol=1e-5)
    deformer.grid_weights = grid  # a fixed grid again: no graph, no gradient
    assert not deformer.forward(xd, bones)[0].requires_grad
    negative = grid.clone()
    negative[1, 2, 3, 1] = -0.5
    with pytest.raises(fskin.Error, match=r"weights must be >= 0.*-0.5 at voxel \(d, h, w\) = \(1, 2, 3\), bone 1"):
        deformer.grid_weights = negative
    with pytest.raises(fskin.Error, match="weights must be >= 0"):
        fskin.FastSnarfDeformer(negative, box)


def test_grid_skinning_gradcheck_float64():
    grid, box = chain()
    xc = canonical_points(5)
    bones = bend(0.4)

    def skinned(g, x, b):
        deformer = fskin.FastSnarfDeformer(g, box)
        return deformer.deform(x, b)

    g = grid.clone().requires_grad_(True)
    x = xc.clone().requires_grad_(True)
    b = bones.clone().requires_grad_(True)
    assert torch.autograd.gradcheck(lambda x_, b_: skinned(grid, x_, b_), (x, b), eps=1e-6, atol=1e-6)
    out = skinned(g, xc, bones).square().sum()
    out.backward()
    assert g.grad is not None and g.grad.abs().sum() > 0


def test_bad_input_raises_fskin_error_with_the_message():
    grid, box = chain()
    deformer = fskin.FastSnarfDeformer(grid, box)
    with pytest.raises(fskin.Error, match="bones"):
        deformer.forward(torch.zeros(1, 10, 3, dtype=torch.float64), torch.eye(4, dtype=torch.float64).expand(1, 3, 4, 4))
    with pytest.raises(fskin.Error, match="finite"):
        deformer.forward(torch.full((1, 2, 3), float("nan"), dtype=torch.float64), bend(0.1))
    with pytest.raises(fskin.Error, match="start_bones"):
        fskin.FastSnarfDeformer(grid, box, start_bones="nine")
    with pytest.raises(fskin.Error, match="length_unit"):
        fskin.FastSnarfDeformer(grid, box, length_unit=-1.0)


def test_character_size_and_box_follow_the_character():
    body = fskin.quadruped(length=3.0, resolution=60)
    size = fskin.character_size(body.v_template)
    assert abs(size - 3.0) < 0.1
    box = fskin.VoxelBox.fit(body.v_template, 32)
    assert max(box.shape) == 32
    assert bool(box.contains(body.v_template).all())


def test_training_evaluation_and_inference_from_python_match_the_cli(tmp_path):
    # The CLI runs the BLAS kernels this process runs (it would switch from SSE3 ones), so both
    # round alike.
    env = dict(os.environ)
    if fskin.openblas_core() is not None:
        env["OPENBLAS_CORETYPE"] = fskin.openblas_core()
    run = lambda *args: subprocess.run([CLI, *args], check=True, capture_output=True, env=env)
    model, poses, data = tmp_path / "model.npz", tmp_path / "poses.npz", tmp_path / "data"
    run("character", "--out", str(model), "--resolution", "40")
    run("poses", "train", "--model", str(model), "--out", str(poses), "--sequences", "2", "--frames", "6")
    run("data", "build", "--model", str(model), "--poses", str(poses), "--out", str(data), "--points", "4000",
        "--quiet")
    tiny = ["frames_per_batch=2", "surface_points=500", "uniform_points=250", "occupancy_hidden_dim=32",
            "occupancy_hidden_layers=3", "skinning_hidden_dim=16", "skinning_hidden_layers=2",
            "grid_resolution=16", "validate_every=0", "checkpoint_every=50"]
    result = fskin.train(str(data), str(tmp_path / "run"), steps=100, settings=tiny)
    assert result["last_step"] == 100 and result["method"] == "fast-snarf"
    assert result["last_loss"] < result["first_loss"]
    # The same run through the CLI gives the same losses (same seed, same defaults).
    run("--threads", str(torch.get_num_threads()), "train", "--data", str(data), "--out", str(tmp_path / "cli_run"),
        "--steps", "100", "--quiet", *[a for s in tiny for a in ("--set", s)])
    lines = [json.loads(l) for l in open(tmp_path / "cli_run" / "log.jsonl")]
    py_lines = [json.loads(l) for l in open(tmp_path / "run" / "log.jsonl")]
    assert len(lines) == len(py_lines) == 100
    assert abs(lines[-1]["bce"] - py_lines[-1]["bce"]) < 1e-4 * max(1.0, abs(lines[-1]["bce"]))
    # Python and the CLI report the same IoU on the same run and split.
    scores = fskin.evaluate(str(tmp_path / "cli_run"), "val")
    run("eval", str(tmp_path / "cli_run"), "--split", "val", "--quiet")
    cli_scores = json.load(open(tmp_path / "cli_run" / "eval-val.json"))
    assert scores["step"] == 100 and len(scores["frames"]) == cli_scores["frames"] > 0
    assert abs(scores["mean_iou_surf"] - cli_scores["mean_iou_surf"]) < 1e-9
    assert abs(scores["mean_iou_bbox"] - cli_scores["mean_iou_bbox"]) < 1e-9
    with pytest.raises(fskin.Error, match="test-sideways"):
        fskin.evaluate(str(tmp_path / "cli_run"), "test-sideways")
    with pytest.raises(fskin.Error, match="no_such_key"):
        fskin.train(str(data), str(tmp_path / "bad"), steps=1, settings=["no_such_key=1"])

    # The trained run for inference: the canonical mesh `fskin mesh` writes, re-posing,
    # occupancy and the rigged glTF.
    trained = fskin.Run(str(tmp_path / "cli_run"))
    assert trained.method == "fast-snarf" and trained.step == 100 and trained.device == "cpu"
    assert len(trained.joint_names) == len(trained.parents) == trained.canonical_joints.shape[0]
    vertices, faces = trained.mesh(resolution=32, initial=8)
    run("mesh", str(tmp_path / "cli_run"), "--canonical", "--resolution", "32", "--initial", "8", "--quiet",
        "--out", str(tmp_path / "canonical.ply"))
    cli_vertices = read_binary_ply_vertices(tmp_path / "canonical.ply")
    assert vertices.shape[0] == cli_vertices.shape[0] > 0 and faces.shape[1] == 3
    assert np.allclose(vertices.numpy(), cli_vertices, atol=1e-6)
    pose_array = torch.from_numpy(np.load(str(poses))["poses"][:2]).float()
    bones = trained.bone_transforms(pose_array)
    assert bones.shape == (2, len(trained.parents), 4, 4)
    moved = trained.repose(vertices, faces, bones)
    assert moved.shape == (2, vertices.shape[0], 3) and torch.isfinite(moved).all()
    # The re-posed surface is the learned surface in that pose: its vertices lie on the zero level
    # set, unlike the same points pushed a tenth of the body's size outwards from its centre.
    surface = trained.occupancy(moved[:1], bones[:1], pose_array[:1]).abs()
    centre = moved[0].mean(0)
    outward = moved[:1] + 0.1 * fskin.character_size(moved[0]) * torch.nn.functional.normalize(moved[:1] - centre, dim=-1)
    away = trained.occupancy(outward, bones[:1], pose_array[:1]).abs()
    assert surface.median() < 0.25 * away.median(), (surface.median(), away.median())
    posed_vertices, _ = trained.mesh(pose=pose_array[0], resolution=32, initial=8)
    assert posed_vertices.shape[0] > 0
    # `fskin animate RUN --poses` from Python: the same workflow, the same files.
    summary = trained.animate(pose_array, str(tmp_path / "animated"), mode="repose", resolution=32, initial=8)
    assert summary["mode"] == "repose" and summary["step"] == 100 and summary["canonical_vertices"] > 0
    assert open(tmp_path / "animated" / "animation.glb", "rb").read(4) == b"glTF"
    assert (tmp_path / "animated" / "frame_0001.ply").exists() and (tmp_path / "animated" / "meshing.json").exists()
    summary = trained.animate(pose_array, str(tmp_path / "per_pose"), resolution=32, initial=8)
    assert summary["mode"] == "per-pose" and len(summary["frames"]) == 2  # the default for fast-snarf
    with pytest.raises(fskin.Error, match="mode must be"):
        trained.animate(pose_array, str(tmp_path / "bad"), mode="sideways")
    trained.export_gltf(str(tmp_path / "avatar.glb"), bones=bones, resolution=32, initial=8)
    assert open(tmp_path / "avatar.glb", "rb").read(4) == b"glTF"
    # ... and back, as `fskin import` reads it: the skeleton and the animation's frames.
    imported, clips, notes = fskin.import_character(str(tmp_path / "avatar.glb"))
    assert imported.num_joints == len(trained.joint_names) and imported.num_vertices > 0
    assert len(clips) == 1 and clips[0]["poses"].shape == (bones.shape[0], imported.num_joints, 3)
    with pytest.raises(fskin.Error, match="avatar.stl"):
        fskin.import_character(str(tmp_path / "avatar.stl"))
    with pytest.raises(fskin.Error, match=".glb or .gltf"):
        trained.export_gltf(str(tmp_path / "avatar.stl"))
    with pytest.raises(fskin.Error, match="no config.json"):
        fskin.Run(str(tmp_path))
    if not torch.cuda.is_available():
        with pytest.raises(fskin.Error, match="device cuda"):
            fskin.Run(str(tmp_path / "cli_run"), device="cuda")


def test_snarf_deformer_roots_gradients_and_learning():
    torch.manual_seed(0)
    extent = torch.tensor([[-1.2, -0.4, -0.4], [1.2, 0.4, 0.4]])
    deformer = fskin.SnarfDeformer(2, extent, hidden_dim=32, hidden_layers=2)
    bones = bend(0.7, torch.float32)
    xc = canonical_points(300, torch.float32)
    xd = deformer.deform(xc, bones).detach()
    roots, valid = deformer.forward(xd, bones)
    error = ((roots - xc.unsqueeze(2)).norm(dim=-1) + (~valid) * 1e9).min(-1).values
    assert (error < 1e-4).float().mean() > 0.95
    # The implicit gradient reaches the MLP: one optimiser step changes the roots.
    params = list(deformer.parameters())
    optimizer = torch.optim.Adam(params, lr=1e-2)
    loss = (roots * valid.unsqueeze(-1)).square().sum()
    loss.backward()
    assert sum(float(p.grad.abs().sum()) for p in params if p.grad is not None) > 0
    optimizer.step()
    moved, _ = deformer.forward(xd, bones)
    assert (moved - roots).detach().abs().max() > 0
    # float64 gradcheck of the exact implicit gradient w.r.t. the posed points,
    # on a deformer converged tightly (the same seed: the same initial MLP).
    torch.manual_seed(0)
    tight = fskin.SnarfDeformer(2, extent, hidden_dim=32, hidden_layers=2, tolerance=1e-12)
    tight.to("float64")
    b64 = bones.double()
    x64 = tight.deform(canonical_points(5), b64).detach()
    _, valid64 = tight.forward(x64, b64)
    assert valid64.any(-1).all()
    mask = valid64.unsqueeze(-1).double()
    assert torch.autograd.gradcheck(lambda x: tight.forward(x, b64)[0] * mask, (x64.clone().requires_grad_(True),),
                                    eps=1e-6, atol=1e-5)
    with pytest.raises(fskin.Error, match="dtype"):
        tight.to("float16")


def _random_pin(dtype):
    torch.manual_seed(11)
    pin = fskin.Pin(num_layers=7, embedding_dim=6, space_hidden_dim=12, map_hidden_dim=8, first_omega=10.0,
                    hidden_omega=10.0)
    with torch.no_grad():  # away from the identity it starts as
        for p in pin.parameters():
            p.copy_(torch.randn_like(p) * 0.3)
    pin.to(dtype)
    return pin


def test_pin_gradcheck_and_inverse_float64():
    pin = _random_pin("float64")
    x = (torch.rand(2, 5, 3, dtype=torch.float64) * 2 - 1).requires_grad_(True)
    z = torch.randn(2, 6, dtype=torch.float64).requires_grad_(True)
    assert torch.autograd.gradcheck(pin.forward, (x, z), eps=1e-6, atol=1e-5)
    assert torch.autograd.gradcheck(pin.inverse, (x, z), eps=1e-6, atol=1e-5)
    back = pin.inverse(pin.forward(x, z), z)
    assert (back - x).abs().max() < 1e-9
    pin.forward(x, z).square().sum().backward()
    assert all(p.grad is not None for p in pin.parameters())
    assert sum(float(p.grad.abs().sum()) for p in pin.parameters()) > 0


def test_pin_fused_kernel_matches_the_module():
    pin = _random_pin("float32")
    x = torch.rand(3, 101, 3) * 2 - 1
    z = torch.randn(3, 6)
    for inverse in (False, True):
        expected = (pin.inverse if inverse else pin.forward)(x, z)
        assert (pin.fused(x, z, inverse) - expected).abs().max() < 1e-4
    with pytest.raises(fskin.Error, match="float32"):
        pin.fused(x.double(), z.double())


def _free_port():
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_train_runs_as_ranks_launched_like_torchrun(tmp_path):
    # fskin.train in processes started the way torchrun starts ranks (RANK, WORLD_SIZE, LOCAL_RANK,
    # MASTER_ADDR, MASTER_PORT): two ranks take the steps one process takes on the same global batch,
    # and rank 0 alone writes the run.
    run = lambda *args: subprocess.run([CLI, *args], check=True, capture_output=True)
    model, poses, data = tmp_path / "model.npz", tmp_path / "poses.npz", tmp_path / "data"
    run("character", "--out", str(model), "--resolution", "40")
    run("poses", "train", "--model", str(model), "--out", str(poses), "--sequences", "2", "--frames", "4")
    run("data", "build", "--model", str(model), "--poses", str(poses), "--out", str(data), "--points", "3000",
        "--quiet")
    script = ("import json, sys, torch, fskin\n"
              "torch.set_num_threads(1)\n"
              "r = fskin.train(sys.argv[1], sys.argv[2], steps=10, settings=sys.argv[3:], progress=False)\n"
              "print(json.dumps({'last_loss': r['last_loss']}))\n")
    settings = ["frames_per_batch=4", "surface_points=300", "uniform_points=100", "occupancy_hidden_dim=32",
                "occupancy_hidden_layers=3", "skinning_hidden_dim=16", "skinning_hidden_layers=2",
                "grid_resolution=16"]
    env = {k: v for k, v in os.environ.items() if k not in ("RANK", "WORLD_SIZE", "LOCAL_RANK")}
    if fskin.openblas_core() is not None:
        env["OPENBLAS_CORETYPE"] = fskin.openblas_core()
    command = lambda out: ["/usr/bin/python3", "-c", script, str(data), str(out), *settings]
    one = subprocess.run(command(tmp_path / "one"), check=True, capture_output=True, env=env, text=True)
    port = str(_free_port())
    ranks = [subprocess.Popen(command(tmp_path / "two"), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env=dict(env, RANK=str(r), WORLD_SIZE="2", LOCAL_RANK=str(r), MASTER_ADDR="127.0.0.1",
                                       MASTER_PORT=port, FSKIN_RANK_TIMEOUT_S="120"))
             for r in range(2)]
    outputs = [p.communicate(timeout=300) for p in ranks]
    assert all(p.returncode == 0 for p in ranks), outputs
    single = json.loads(one.stdout.strip().splitlines()[-1])["last_loss"]
    for out, _ in outputs:
        assert abs(json.loads(out.strip().splitlines()[-1])["last_loss"] - single) < 1e-5 * max(1.0, abs(single))
    lines = [json.loads(line) for line in open(tmp_path / "two" / "log.jsonl")]
    assert len(lines) == 10 and all(line["ranks"] == 2 for line in lines)
    assert (tmp_path / "two" / "config.json").exists() and any(
        name.startswith("checkpoint") for name in os.listdir(tmp_path / "two"))


def test_voxel_box_refuses_a_grid_no_machine_holds():
    with pytest.raises(fskin.Error, match="longest_voxels"):
        fskin.VoxelBox.fit(torch.rand(10, 3), 100000)


def test_import_uses_every_core_unless_the_environment_says_otherwise():
    cores = len(os.sched_getaffinity(0))
    probe = "import fskin, torch; print(torch.get_num_threads())"
    environment = {k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"}
    out = subprocess.run(["/usr/bin/python3", "-c", probe], env=environment, capture_output=True, text=True, check=True)
    assert int(out.stdout.split()[-1]) >= cores  # never fewer threads than cores (torch may choose more)
    environment["OMP_NUM_THREADS"] = "1"
    out = subprocess.run(["/usr/bin/python3", "-c", probe], env=environment, capture_output=True, text=True, check=True)
    assert int(out.stdout.split()[-1]) == 1


@pytest.mark.parametrize("start_bones, message", [
    (9.0, "9.0 is not 'all', an int"),
    (True, "True is not 'all', an int"),
    ([0, 1.5], r"holds 1.5, not a bone index"),
    ("x", "'x' is not 'all'"),
])
def test_start_bones_of_the_wrong_kind_are_named(start_bones, message):
    grid = torch.full((4, 4, 4, 2), 0.5)
    box = fskin.VoxelBox.fit(torch.rand(10, 3), 4)
    with pytest.raises(fskin.Error, match=message):
        fskin.FastSnarfDeformer(grid, box, start_bones=start_bones)


def test_write_mesh_refuses_tensors_it_would_have_to_mangle(tmp_path):
    vertices = torch.rand(4, 3)
    faces = torch.tensor([[0, 1, 2], [0, 2, 3]])
    with pytest.raises(fskin.Error, match="vertices must be real floating point"):
        fskin.write_mesh(str(tmp_path / "m.ply"), vertices.to(torch.complex64), faces)
    with pytest.raises(fskin.Error, match="faces must be integer vertex indices"):
        fskin.write_mesh(str(tmp_path / "m.ply"), vertices, faces.float())
    fskin.write_mesh(str(tmp_path / "m.ply"), vertices.double(), faces.int())
    assert fskin.read_mesh(str(tmp_path / "m.ply"))[0].shape == (4, 3)


def test_half_precision_and_autocast_get_fskin_answers():
    body = fskin.humanoid(resolution=32)
    grid = torch.full((4, 4, 4, body.num_joints), 1.0 / body.num_joints)
    deformer = fskin.FastSnarfDeformer(grid, fskin.VoxelBox.fit(body.v_template, 4))
    _, _, bones = body.forward(torch.zeros(1, body.num_joints, 3))
    x = body.v_template.float()[None, :20]
    with pytest.raises(fskin.Error, match="points must be float32 or float64.*Half"):
        deformer.forward(x.half(), bones)
    with pytest.raises(fskin.Error, match="points must be float32 or float64.*Half"):
        deformer.deform(x.half(), bones)
    roots, valid = deformer.forward(x, bones)
    with torch.autocast("cpu", dtype=torch.bfloat16):  # the search keeps its inputs' precision
        roots_autocast, valid_autocast = deformer.forward(x, bones)
        posed = deformer.deform(x, bones)
    assert roots_autocast.dtype == torch.float32 and posed.dtype == torch.float32
    assert torch.equal(valid, valid_autocast)
    assert torch.allclose(roots, roots_autocast)


def test_body_model_voxel_box_and_deformer_pickle_and_deep_copy():
    import copy
    import pickle

    body = fskin.humanoid(resolution=32)
    clone = pickle.loads(pickle.dumps(body))
    pose = torch.randn(1, body.num_joints, 3) * 0.3
    for a, b in zip(body.forward(pose), clone.forward(pose)):
        assert torch.equal(a, b)
    assert clone.joint_names == body.joint_names and clone.parents == body.parents

    box = fskin.VoxelBox.fit(body.v_template, 16)
    box_copy = copy.deepcopy(box)
    assert box_copy.shape == box.shape and repr(box_copy) == repr(box)
    assert torch.equal(box_copy.voxel_centres(), box.voxel_centres())

    grid = fskin.diffuse_weights_to_grid(body.v_template, body.weights, box)
    deformer = fskin.FastSnarfDeformer(grid, box, start_bones=3, max_iterations=12)
    _, _, bones = body.forward(pose)
    x = body.forward(pose)[0][:, :50].float()
    roots, valid = deformer.forward(x, bones)
    for restored in (pickle.loads(pickle.dumps(deformer)), copy.deepcopy(deformer)):
        again, valid_again = restored.forward(x, bones)
        assert torch.equal(valid, valid_again) and torch.equal(roots, again)


def test_body_model_forward_keeps_float64_and_its_gradients():
    body = fskin.humanoid(resolution=32)
    pose = (torch.randn(1, body.num_joints, 3, dtype=torch.float64) * 0.2).requires_grad_()
    trans = torch.randn(1, 3, dtype=torch.float64, requires_grad=True)
    vertices, joints, bones = body.forward(pose, trans=trans)
    assert vertices.dtype == joints.dtype == bones.dtype == torch.float64
    single = body.forward(pose.detach().float(), trans=trans.detach().float())[0]
    assert single.dtype == torch.float32 and torch.allclose(single.double(), vertices, atol=1e-5)
    few = torch.arange(0, body.num_vertices, 997)
    assert torch.autograd.gradcheck(lambda p, t: body.forward(p, trans=t)[0][:, few], (pose, trans))


def test_the_fast_snarf_deformer_takes_a_divergence_threshold_above_its_tolerance():
    body = fskin.humanoid(resolution=40)
    box = fskin.VoxelBox.fit(body.v_template, 16)
    grid = fskin.diffuse_weights_to_grid(body.v_template, body.weights, box)
    with pytest.raises(fskin.Error, match="divergence"):
        fskin.FastSnarfDeformer(grid, box, tolerance=1e-3, divergence=1e-4)
    pose = torch.zeros(1, body.num_joints, 3)
    pose[0, 1:, 2] = 0.4  # every joint bent: most starts begin far from their root
    verts, _, bones = body.forward(pose)
    strict = fskin.FastSnarfDeformer(grid, box, divergence=1e-3)  # drops candidates that start far away
    loose = fskin.FastSnarfDeformer(grid, box)
    assert strict.forward(verts, bones)[1].sum() < loose.forward(verts, bones)[1].sum()


def test_the_fast_snarf_deformer_is_a_torch_module():
    import copy
    import io
    body = fskin.humanoid(resolution=40)
    box = fskin.VoxelBox.fit(body.v_template, 16)
    grid = fskin.diffuse_weights_to_grid(body.v_template, body.weights, box)
    deformer = fskin.FastSnarfDeformer(grid, box, start_bones=4)
    assert isinstance(deformer, torch.nn.Module)
    assert list(deformer.state_dict()) == ["grid_weights"] and "start_bones=4" in repr(deformer)
    verts, _, bones = body.forward(torch.zeros(1, body.num_joints, 3))
    roots, valid = deformer(verts, bones)  # callable: forward
    # .double() moves the grid, and the search follows it.
    roots64, valid64 = deformer.double()(verts.double(), bones.double())
    assert deformer.grid_weights.dtype == torch.float64 and roots64.dtype == torch.float64
    assert torch.equal(valid64, valid)
    buffer = io.BytesIO()
    torch.save(deformer, buffer)
    buffer.seek(0)
    loaded = torch.load(buffer)
    assert torch.equal(loaded(verts.double(), bones.double())[0], roots64)
    clone = copy.deepcopy(deformer)
    assert torch.equal(clone(verts.double(), bones.double())[0], roots64)
    clone.load_state_dict({"grid_weights": torch.zeros_like(deformer.grid_weights) + 1.0 / body.num_joints})
    assert not torch.equal(clone.weights(verts.double())[0], deformer.weights(verts.double())[0])
    # A parameter grid is a parameter, and the roots' gradient reaches it.
    learned = fskin.FastSnarfDeformer(torch.nn.Parameter(grid.double()), box, start_bones=4)
    assert [name for name, _ in learned.named_parameters()] == ["grid_weights"]
    roots, valid = learned(verts.double(), bones.double())
    (roots * valid[..., None]).sum().backward()
    assert learned.grid_weights.grad is not None and learned.grid_weights.grad.abs().sum() > 0


def test_the_snarf_deformer_is_a_torch_module_whose_parameters_are_the_searchs():
    import copy
    import io
    torch.manual_seed(0)
    extent = canonical_points(50, torch.float32)[0]
    deformer = fskin.SnarfDeformer(2, extent, hidden_dim=16, hidden_layers=2)
    assert isinstance(deformer, torch.nn.Module) and "hidden_dim=16" in repr(deformer)
    # The module's parameters are the C++ MLP's tensors themselves.
    assert all(a is b for a, b in zip(deformer.parameters(), deformer._native.parameters()))
    bones = bend(0.7, torch.float32)
    xd = deformer.deform(canonical_points(40, torch.float32), bones).detach()
    roots, valid = deformer(xd, bones)
    (roots * valid.unsqueeze(-1)).square().sum().backward()
    assert all(p.grad is not None for p in deformer.parameters())  # the search's own tensors
    # state_dict / load_state_dict reach the search: another deformer's state gives its weights.
    torch.manual_seed(1)
    other = fskin.SnarfDeformer(2, extent, hidden_dim=16, hidden_layers=2)
    clone = copy.deepcopy(deformer)
    assert torch.equal(clone(xd, bones)[0], roots)
    assert not torch.allclose(clone.weights(xd), other.weights(xd))
    clone.load_state_dict(other.state_dict())
    assert torch.equal(clone.weights(xd), other.weights(xd))
    deformer.double()
    assert all(p.dtype == torch.float64 for p in deformer.parameters())
    assert deformer.forward(xd.double(), bones.double())[0].dtype == torch.float64
    buffer = io.BytesIO()
    torch.save(deformer, buffer)
    buffer.seek(0)
    loaded = torch.load(buffer)
    assert torch.equal(loaded.weights(xd.double()), deformer.weights(xd.double()))


def test_the_lowpoly_characters_come_with_their_clips():
    for kind in ("lowpoly-humanoid", "lowpoly-animal"):
        body, clips = fskin.lowpoly_character(kind, seed=1)
        assert body.num_vertices < 5000 and clips["poses"].shape[1:] == (body.num_joints, 3)
        assert clips["clip_starts"][0] == 0 and len(clips["clip_names"]) == len(clips["clip_starts"])
        vertices, _, _ = body.forward(clips["poses"][:2], trans=clips["trans"][:2])
        assert vertices.shape == (2, body.num_vertices, 3)
    with pytest.raises(fskin.Error, match="lowpoly-humanoid or lowpoly-animal"):
        fskin.lowpoly_character("dragon")


@pytest.mark.skipif(not fskin.built_with_embree(), reason="built without Embree")
def test_build_dataset_oversamples_thin_parts_in_training_frames(tmp_path):
    body, clips = fskin.lowpoly_character("lowpoly-animal")
    model = str(tmp_path / "fox.npz")
    body.save(model)
    poses = clips["poses"][:10]
    summary = fskin.build_dataset(model, poses, str(tmp_path / "data"), points=2000, thin_surface_share=0.6)
    assert summary["train"] == 8
    manifest = json.loads((tmp_path / "data" / "manifest.json").read_text())
    assert manifest["sampling"]["thin_surface_share"] == 0.6 and manifest["sampling"]["thin_faces"] > 0
    frame = fskin.Dataset(str(tmp_path / "data"), "train")[0]
    assert frame["points"].shape == (2000, 3) and frame["num_uniform"] == 1000
    with pytest.raises(fskin.Error, match="thin-surface share"):
        fskin.build_dataset(model, poses, str(tmp_path / "bad"), thin_surface_share=1.5)
