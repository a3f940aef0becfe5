"""fskin.compat.fast_snarf: the reference Fast-SNARF interface, as its users call it."""
from types import SimpleNamespace

import torch

import fskin
from fskin.compat.fast_snarf import ForwardDeformer


def smpl_like_server(body):
    # What the reference code's SMPLServer exposes to the deformer.
    return SimpleNamespace(verts_c=body.v_template[None], weights_c=body.weights[None])


def options(**overrides):
    opt = dict(res=32, z_ratio=4, global_scale=1.2, skinning_mode="preset", soft_blend=20, cvg=1e-4, dvg=1,
               n_iters=10, align_corners=True, use_slow_grad=False)
    opt.update(overrides)
    return SimpleNamespace(**opt)


def test_a_reference_style_script_runs_and_finds_the_roots():
    body = fskin.humanoid(resolution=48)
    deformer = ForwardDeformer(options(), smpl_like_server(body))
    pose = torch.zeros(1, body.num_joints, 3)
    pose[0, 18, 2] = -1.0
    pose[0, 1, 0] = 0.5
    verts, _, tfs = body.forward(pose)
    deformer.precompute(tfs)
    xc, others = deformer.forward(verts, {}, tfs, eval_mode=True)
    assert xc.shape == (1, body.num_vertices, 9, 3)  # SMPL's 9 start bones
    assert others["valid_ids"].shape == (1, body.num_vertices, 9)
    assert others["valid_ids"].any(-1).float().mean() > 0.99
    # Forward skinning of the roots lands on the posed points.
    xd = deformer.forward_skinning(xc[:, :, 0], {}, tfs)
    ok = others["valid_ids"][:, :, 0]
    assert (xd - verts).norm(dim=-1)[ok].max() < 1e-3
    w = deformer.query_weights(body.v_template[None])
    assert torch.allclose(w.sum(-1), torch.ones(1, body.num_vertices), atol=1e-5)


def test_same_roots_as_the_native_deformer():
    body = fskin.quadruped(resolution=60)  # 33 bones: every bone starts a search
    compat = ForwardDeformer(options(res=24), smpl_like_server(body))
    native = fskin.FastSnarfDeformer(compat.lbs_voxel_final, compat.box, start_bones=list(range(body.num_joints)),
                                     length_unit=fskin.character_size(body.v_template) / 1.7, tolerance=1e-4)
    pose = torch.randn(1, body.num_joints, 3) * 0.2
    verts, _, tfs = body.forward(pose)
    xc_a, others = compat.forward(verts, {}, tfs)
    xc_b, valid_b = native.forward(verts, tfs)
    assert torch.equal(others["valid_ids"], valid_b)
    assert torch.equal(xc_a, xc_b)


def _fit_loss(compat, verts_c, xd, tfs):
    """Squared distance of each posed vertex's nearest valid root to its canonical vertex."""
    xc, others = compat.forward(xd, {}, tfs)
    distance = (xc - verts_c[:, :, None]).square().sum(-1) + (~others["valid_ids"]) * 1e3
    return distance.min(-1).values.clamp(max=1.0).mean()


def test_learned_skinning_modes_learn_from_the_roots():
    body = fskin.humanoid(resolution=40)
    pose = torch.zeros(1, body.num_joints, 3)
    pose[0, 1:, 2] = 0.3  # every joint bent a little
    verts, _, tfs = body.forward(pose)
    for mode in ("voxel", "mlp"):
        torch.manual_seed(0)
        opt = options(skinning_mode=mode, res=16, network={"width": 32, "depth": 2})
        compat = ForwardDeformer(opt, smpl_like_server(body))
        parameters = list(compat.parameters())
        assert parameters, mode
        optimiser = torch.optim.Adam(parameters, lr=0.05 if mode == "voxel" else 0.01)
        losses = []
        for _ in range(15):
            loss = _fit_loss(compat, body.v_template[None], verts, tfs)
            optimiser.zero_grad()
            loss.backward()
            assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in parameters), mode
            optimiser.step()
            losses.append(loss.item())
        assert losses[-1] < 0.7 * losses[0], (mode, losses)
        # eval_mode: no graph, and the grid frozen by precompute(recompute_skinning=False).
        compat.precompute(tfs, recompute_skinning=False)
        xc, _ = compat.forward(verts, {}, tfs, eval_mode=True)
        assert not xc.requires_grad


def test_hierarchical_softmax_says_it_is_not_provided():
    body = fskin.humanoid(resolution=40)
    try:
        ForwardDeformer(options(skinning_mode="mlp", softmax_mode="hierarchical"), smpl_like_server(body))
    except NotImplementedError as e:
        assert "hierarchical" in str(e)
    else:
        raise AssertionError("hierarchical softmax was accepted")


def test_preset_smooth_uses_the_diffused_grid():
    body = fskin.humanoid(resolution=40)
    compat = ForwardDeformer(options(skinning_mode="preset_smooth", res=24), smpl_like_server(body))
    grid = fskin.diffuse_weights_to_grid(body.v_template, body.weights, compat.box)
    assert torch.equal(compat.lbs_voxel_final, grid)
    assert torch.allclose(grid.sum(-1), torch.ones(grid.shape[:-1]), atol=1e-5)
    verts, _, tfs = body.forward(torch.zeros(1, body.num_joints, 3))
    _, others = compat.forward(verts, {}, tfs)
    assert others["valid_ids"].any(-1).float().mean() > 0.99
