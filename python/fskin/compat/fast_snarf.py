"""The reference Fast-SNARF `ForwardDeformer` interface on fskin's kernels.

Code written against Fast-SNARF (lib/model/fast_snarf.py) switches with one
import line:

    # from lib.model.fast_snarf import ForwardDeformer
    from fskin.compat.fast_snarf import ForwardDeformer

It runs on the CPU (and on CUDA where fskin is built with it), for any number
of bones, with no compilation at import time. docs/python.md maps every option
and output. What differs: the deformer finds roots for the whole batch in one
call, so `precompute` has nothing to return; `others` holds 'result' and
'valid_ids' but not Broyden's 'J_inv' (the implicit gradient is attached to
`xc` by fskin itself); grids use align_corners=True; only the preset skinning
modes are provided: 'voxel' and 'mlp' (learned weights) raise
NotImplementedError (fskin's own trainer learns them).
"""
import torch

from .. import FastSnarfDeformer, VoxelBox, character_size, diffuse_weights_to_grid

# The reference implementation's 9 start bones (SMPL: pelvis, hips, knees,
# shoulders, elbows); for any other skeleton every bone starts a search.
SMPL_INIT_BONES = [0, 1, 2, 4, 5, 16, 17, 18, 19]


def _option(opt, name, default):
    if isinstance(opt, dict):
        return opt.get(name, default)
    return getattr(opt, name, default)


def _nearest_vertex_weights(points, verts, weights, chunk=65536):
    """Skinning weights of the nearest template vertex (the reference's 'preset')."""
    out = []
    for start in range(0, points.shape[0], chunk):
        nearest = torch.cdist(points[start:start + chunk], verts).argmin(1)
        out.append(weights[nearest])
    return torch.cat(out)


class ForwardDeformer(torch.nn.Module):
    """Fast-SNARF's deformer: opt has res, z_ratio, global_scale, skinning_mode
    ('preset': nearest-vertex weights, 'preset_smooth': fskin's diffusion of them), cvg, n_iters;
    smpl_server has verts_c [1, V, 3] and weights_c [1, V, J]."""

    def __init__(self, opt, smpl_server=None):
        super().__init__()
        if smpl_server is None:
            raise ValueError("fskin.compat.fast_snarf.ForwardDeformer needs smpl_server (verts_c, weights_c)")
        self.opt = opt
        verts = smpl_server.verts_c[0].detach().float().cpu()
        weights = smpl_server.weights_c[0].detach().float().cpu()
        self.num_bones = weights.shape[-1]
        self.init_bones = SMPL_INIT_BONES if self.num_bones == 24 else list(range(self.num_bones))
        res = int(_option(opt, "res", 64))
        z_ratio = int(_option(opt, "z_ratio", 4))
        self.box = VoxelBox.around(verts, (res // z_ratio, res, res), float(_option(opt, "global_scale", 1.2)),
                                   float(z_ratio))
        self.mode = _option(opt, "skinning_mode", "preset")
        self.cvg = float(_option(opt, "cvg", 1e-4))
        self.n_iters = int(_option(opt, "n_iters", 10))
        self.length_unit = character_size(verts) / 1.7
        d, h, w = self.box.shape
        if self.mode == "preset":
            centres = self.box.voxel_centres().reshape(-1, 3)
            grid = _nearest_vertex_weights(centres, verts, weights).reshape(d, h, w, self.num_bones)
            self.register_buffer("lbs_voxel_final", grid.contiguous())
        elif self.mode == "preset_smooth":  # fskin's diffusion: nearest vertex, smoothed off the surface
            self.register_buffer("lbs_voxel_final", diffuse_weights_to_grid(verts, weights, self.box).contiguous())
        else:
            raise NotImplementedError(
                f"skinning_mode '{self.mode}': fskin.compat.fast_snarf provides 'preset' and 'preset_smooth'; "
                "learned skinning ('voxel', 'mlp') is fskin's trainer's job")

    def _deformer(self, device, dtype):
        return FastSnarfDeformer(self.lbs_voxel_final.to(device=device, dtype=dtype), self.box, start_bones=self.init_bones,
                                 max_iterations=self.n_iters, length_unit=self.length_unit, tolerance=self.cvg)

    def precompute(self, tfs=None, recompute_skinning=True):
        """fskin precomputes inside forward (one fused search per call): nothing to do."""
        return None

    def forward(self, xd, cond, tfs, mask=None, eval_mode=False):
        """xd [B, N, 3], tfs [B, J, 4, 4] -> xc [B, N, I, 3], {'result', 'valid_ids'}."""
        deformer = self._deformer(xd.device, xd.dtype)
        xc, valid = deformer.forward(xd, tfs.to(xd.dtype))
        if mask is not None:
            valid = valid & mask.expand_as(valid)
        return xc, {"result": xc.detach(), "valid_ids": valid}

    def forward_skinning(self, xc, cond, tfs, mask=None):
        """Canonical points [B, N, 3] -> deformed points [B, N, 3] (LBS with the grid's weights)."""
        return self._deformer(xc.device, xc.dtype).deform(xc, tfs.to(xc.dtype))

    def query_weights(self, xc, cond=None, mask=None):
        """Skinning weights at canonical points [B, N, 3] -> [B, N, J]."""
        return self._deformer(xc.device, xc.dtype).weights(xc)
