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
    native = fskin.FastSnarfDeformer(compat.skinning_grid(), compat.box, start_bones=list(range(body.num_joints)),
                                     length_unit=fskin.character_size(body.v_template) / 1.7, tolerance=1e-4,
                                     divergence=1.0)  # the options' dvg
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
    assert compat.lbs_voxel_final.shape == (1, body.num_joints) + tuple(compat.box.shape)  # the reference's layout
    assert torch.equal(compat.skinning_grid(), grid)
    assert torch.allclose(grid.sum(-1), torch.ones(grid.shape[:-1]), atol=1e-5)
    verts, _, tfs = body.forward(torch.zeros(1, body.num_joints, 3))
    _, others = compat.forward(verts, {}, tfs)
    assert others["valid_ids"].any(-1).float().mean() > 0.99


def posed_humanoid():
    body = fskin.humanoid(resolution=48)
    pose = torch.zeros(1, body.num_joints, 3)
    pose[0, 18, 2] = -1.0
    pose[0, 1, 0] = 0.5
    verts, _, tfs = body.forward(pose)
    return body, verts, tfs


def test_the_reference_surface_precompute_offset_scale_and_j_inv():
    body, verts, tfs = posed_humanoid()
    deformer = ForwardDeformer(options(res=32), smpl_like_server(body))
    d, h, w = deformer.box.shape
    assert deformer.lbs_voxel_final.shape == (1, body.num_joints, d, h, w)
    assert deformer.offset.shape == (1, 1, 3) and deformer.scale.shape == (1, 1, 3)
    normalised = (body.v_template + deformer.offset[0]) * deformer.scale[0]
    assert normalised.abs().max() <= 1.0 + 1e-5  # the template inside the grid's [-1, 1]
    voxel_d, voxel_J = deformer.precompute(tfs)
    assert voxel_d.shape == (1, 3, d, h, w) and voxel_J.shape == (1, 12, d, h, w)
    assert deformer.voxel_d is voxel_d and deformer.voxel_J is voxel_J
    # voxel_d: the voxel centres through the forward skinning; voxel_J: the blended transforms.
    centres = deformer.box.voxel_centres().reshape(1, -1, 3)
    skinned = deformer.forward_skinning(centres, {}, tfs)
    assert torch.allclose(voxel_d.flatten(2).transpose(1, 2), skinned, atol=1e-4)
    transform = voxel_J.flatten(2).transpose(1, 2).reshape(1, -1, 3, 4)
    assert torch.allclose((transform[..., :3] @ centres[..., None])[..., 0] + transform[..., 3], skinned, atol=1e-4)
    # J_inv: the inverse Jacobian of the forward skinning at each valid root (finite differences).
    xc, others = deformer.forward(verts[:, :200], {}, tfs, eval_mode=True)
    assert "J_inv" in others
    j_inv = others["J_inv"]
    assert j_inv.shape == (1, 200, 9, 3, 3)
    valid = others["valid_ids"]
    point, start = [int(i) for i in valid[0].nonzero()[0]]
    x = xc[0, point, start].double()
    eps = 1e-3
    columns = []
    for k in range(3):
        step = torch.zeros(3, dtype=torch.float64)
        step[k] = eps
        plus = deformer.forward_skinning((x + step).float()[None, None], {}, tfs)[0, 0].double()
        minus = deformer.forward_skinning((x - step).float()[None, None], {}, tfs)[0, 0].double()
        columns.append((plus - minus) / (2 * eps))
    jacobian = torch.stack(columns, dim=1)
    assert torch.allclose(j_inv[0, point, start].double() @ jacobian, torch.eye(3, dtype=torch.float64), atol=2e-2)


def test_forward_skinning_takes_the_searchs_shapes_and_mask():
    body, verts, tfs = posed_humanoid()
    deformer = ForwardDeformer(options(res=32), smpl_like_server(body))
    xc, others = deformer.forward(verts, {}, tfs, eval_mode=True)
    xd = deformer.forward_skinning(xc, {}, tfs, mask=others["valid_ids"])  # [B, N, I, 3] as InstantAvatar passes
    assert xd.shape == xc.shape
    ok = others["valid_ids"]
    assert (xd - verts[:, :, None]).norm(dim=-1)[ok].max() < 1e-3
    flat = deformer.forward_skinning(xc.flatten(1, 2), {}, tfs, mask=ok.flatten(1, 2))  # the reference's call
    assert torch.allclose(flat, xd.flatten(1, 2))


def test_instant_avatars_construction_and_calls():
    body, verts, tfs = posed_humanoid()
    deformer = ForwardDeformer({"version": 1})  # InstantAvatar: ForwardDeformer(opt), then switch_to_explicit
    deformer.switch_to_explicit(resolution=32, smpl_verts=body.v_template[None], smpl_weights=body.weights[None],
                                use_smpl=True)
    assert deformer.lbs_voxel_final.shape == (1, 24, 8, 32, 32)
    assert deformer.grid_denorm.shape == (1, 8 * 32 * 32, 3)
    assert torch.allclose(deformer.denormalize(deformer.normalize(verts)), verts, atol=1e-5)
    assert deformer.precompute(tfs) is not None  # stored too: InstantAvatar's get_bbox_deformed reads it
    voxel = deformer.voxel_d[0].reshape(3, -1)
    low, high = voxel.min(dim=1).values, voxel.max(dim=1).values
    assert bool((verts[0] >= low).all() and (verts[0] <= high).all())
    xc, others = deformer.forward(verts, None, tfs, eval_mode=False)
    assert xc.shape == (1, body.num_vertices, 13, 3)  # InstantAvatar's 13 start bones
    mask = others["valid_ids"]
    xd = deformer.forward_skinning(xc.detach(), None, tfs, mask=mask)  # version 1: the masked points
    assert xd.shape == (int(mask.sum()), 3)
    assert others["J_inv"][mask].shape == (int(mask.sum()), 3, 3)


def test_an_option_fskin_ignores_and_a_box_too_small_are_warned_about():
    import warnings
    body = fskin.humanoid(resolution=40)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ForwardDeformer(options(align_corners=False), smpl_like_server(body))
    text = " ".join(str(w.message) for w in caught)
    assert "align_corners=False" in text
    animal = fskin.quadruped(resolution=60)  # long along z: outside the reference's z_ratio-squeezed box
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ForwardDeformer(options(res=32), smpl_like_server(animal))
    assert any("outside the reference voxel box" in str(w.message) for w in caught)


def test_the_compat_deformer_deep_copies_and_pickles():
    import copy
    import pickle
    body, verts, tfs = posed_humanoid()
    deformer = ForwardDeformer(options(res=16), smpl_like_server(body))
    for clone in (copy.deepcopy(deformer), pickle.loads(pickle.dumps(deformer))):
        a, _ = deformer.forward(verts[:, :50], {}, tfs, eval_mode=True)
        b, _ = clone.forward(verts[:, :50], {}, tfs, eval_mode=True)
        assert torch.equal(a, b)
