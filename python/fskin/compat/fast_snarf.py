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
`xc` by fskin itself); grids use align_corners=True. Skinning modes: 'preset'
and 'preset_smooth' (fixed grids), 'voxel' (a learned grid `lbs_voxel`
[1, J, D, H, W], softmax(soft_blend * lbs_voxel) over bones, as the reference)
and 'mlp' (an MLP `lbs_network` from canonical points to J logits evaluated at
every voxel centre, softmax(soft_blend * logits); the reference's
ImplicitNetwork options `width`, `depth` and `d_out` are read from
opt.network when given). The learned modes' gradients reach their parameters
through the roots' implicit gradient; 'hierarchical' softmax (SMPL's 24-bone
tree only) is not provided.
"""
import torch

from .. import FastSnarfDeformer, VoxelBox, character_size, diffuse_weights_to_grid, nearest_vertices

# The reference implementation's 9 start bones (SMPL: pelvis, hips, knees,
# shoulders, elbows); for any other skeleton every bone starts a search.
SMPL_INIT_BONES = [0, 1, 2, 4, 5, 16, 17, 18, 19]


def _option(opt, name, default):
    if isinstance(opt, dict):
        return opt.get(name, default)
    return getattr(opt, name, default)


def _nearest_vertex_weights(points, verts, weights):
    """Skinning weights of the nearest template vertex (the reference's 'preset'), by a k-d tree."""
    index, _ = nearest_vertices(points, verts)
    return weights[index]


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
        self.soft_blend = float(_option(opt, "soft_blend", 20))
        self.exact_gradient = bool(_option(opt, "use_slow_grad", False))
        if _option(opt, "softmax_mode", "softmax") == "hierarchical":
            raise NotImplementedError("softmax_mode 'hierarchical' (SMPL's bone tree only): use 'softmax'")
        d, h, w = self.box.shape
        if self.mode == "preset":
            centres = self.box.voxel_centres().reshape(-1, 3)
            grid = _nearest_vertex_weights(centres, verts, weights).reshape(d, h, w, self.num_bones)
            self.register_buffer("lbs_voxel_final", grid.contiguous())
        elif self.mode == "preset_smooth":  # fskin's diffusion: nearest vertex, smoothed off the surface
            self.register_buffer("lbs_voxel_final", diffuse_weights_to_grid(verts, weights, self.box).contiguous())
        elif self.mode == "voxel":
            self.lbs_voxel = torch.nn.Parameter(0.001 * torch.ones(1, self.num_bones, d, h, w))
        elif self.mode == "mlp":
            network = _option(opt, "network", {}) or {}
            self.lbs_network = _mlp(3, int(_option(network, "d_out", self.num_bones)),
                                    int(_option(network, "width", 128)), int(_option(network, "depth", 4)))
            self.register_buffer("voxel_centres", self.box.voxel_centres().reshape(-1, 3).contiguous())
        else:
            raise NotImplementedError(
                f"skinning_mode '{self.mode}': fskin.compat.fast_snarf provides 'preset', 'preset_smooth', "
                "'voxel' and 'mlp'")

    def skinning_grid(self):
        """The grid the search reads, [D, H, W, J] (fskin's layout), with the learned modes' graph."""
        if self.mode == "voxel":
            return torch.softmax(self.soft_blend * self.lbs_voxel[0], dim=0).permute(1, 2, 3, 0)
        if self.mode == "mlp":
            d, h, w = self.box.shape
            logits = self.lbs_network(self.voxel_centres)
            return torch.softmax(self.soft_blend * logits, dim=-1).reshape(d, h, w, -1)
        return self.lbs_voxel_final

    def _deformer(self, device, dtype, grid=None):
        grid = self.skinning_grid() if grid is None else grid
        return FastSnarfDeformer(grid.to(device=device, dtype=dtype), self.box, start_bones=self.init_bones,
                                 max_iterations=self.n_iters, length_unit=self.length_unit, tolerance=self.cvg,
                                 exact_gradient=self.exact_gradient)

    def precompute(self, tfs=None, recompute_skinning=True):
        """fskin precomputes inside forward (one fused search per call): nothing to return. With
        recompute_skinning=False later eval-mode calls reuse the learned grid as it is now."""
        if not recompute_skinning and self.mode in ("voxel", "mlp"):
            with torch.no_grad():
                self._eval_grid = self.skinning_grid().detach()
        return None

    def forward(self, xd, cond, tfs, mask=None, eval_mode=False):
        """xd [B, N, 3], tfs [B, J, 4, 4] -> xc [B, N, I, 3], {'result', 'valid_ids'}. Outside
        eval_mode a learned grid's gradient flows from xc to its parameters; in eval_mode xc has
        no graph (as the reference, which skips the correction)."""
        if eval_mode:
            with torch.no_grad():
                grid = getattr(self, "_eval_grid", None) if self.mode in ("voxel", "mlp") else None
                xc, valid = self._deformer(xd.device, xd.dtype, grid).forward(xd, tfs.to(xd.dtype))
        else:
            xc, valid = self._deformer(xd.device, xd.dtype).forward(xd, tfs.to(xd.dtype))
        if mask is not None:
            valid = valid & mask.expand_as(valid)
        return xc, {"result": xc.detach(), "valid_ids": valid}

    def forward_skinning(self, xc, cond, tfs, mask=None):
        """Canonical points [B, N, 3] -> deformed points [B, N, 3] (LBS with the grid's weights)."""
        return self._deformer(xc.device, xc.dtype).deform(xc, tfs.to(xc.dtype))

    def query_weights(self, xc, cond=None, mask=None):
        """Skinning weights at canonical points [B, N, 3] -> [B, N, J]."""
        return self._deformer(xc.device, xc.dtype).weights(xc)


def _mlp(d_in, d_out, width, depth):
    """A plain MLP (Softplus(beta=100) hidden activations, as the reference's ImplicitNetwork)."""
    layers, size = [], d_in
    for _ in range(depth):
        layers += [torch.nn.Linear(size, width), torch.nn.Softplus(beta=100)]
        size = width
    layers.append(torch.nn.Linear(size, d_out))
    return torch.nn.Sequential(*layers)
