"""The reference Fast-SNARF `ForwardDeformer` interface on fskin's kernels.

Code written against Fast-SNARF (lib/model/fast_snarf.py) or InstantAvatar's
copy of it (instant_avatar/deformers/fast_snarf/deformer_torch.py) switches
with one import line:

    # from lib.model.fast_snarf import ForwardDeformer
    from fskin.compat.fast_snarf import ForwardDeformer

It runs on the CPU (and on CUDA where fskin is built with it), for any number
of bones, with no compilation at import time. docs/python.md maps every option
and output. Two constructions, as the two codes make them:

- Fast-SNARF: `ForwardDeformer(opt, smpl_server)` builds the grid at once from
  smpl_server.verts_c / weights_c; `offset` and `scale` are the reference's
  [1, 1, 3] kernel normalisation (x + offset) * scale; `forward_skinning`
  returns every point, in xc's shape.
- InstantAvatar: `ForwardDeformer(opt)` then `switch_to_explicit(resolution,
  smpl_verts, smpl_weights, use_smpl=True)`; `offset` is the box centre,
  `scale` its half size, `offset_kernel` / `scale_kernel` the kernel's; and
  `forward_skinning(xc, cond, tfs, mask)` returns the masked points only [P, 3].

Both: `precompute(tfs)` returns and stores `voxel_d` [B, 3, D, H, W] (the voxel
centres deformed) and `voxel_J` [B, 12, D, H, W] (each voxel's blended
transform, row-major 3x4 [R | t]); `lbs_voxel_final` is [1, J, D, H, W];
`forward` returns (xc [B, N, I, 3], others) with others 'result', 'valid_ids'
and 'J_inv' [B, N, I, 3, 3], the inverse Jacobian of the forward skinning at
each root (computed when first read, exactly, where the reference keeps
Broyden's estimate). The implicit gradient is attached to xc by fskin itself.
Grids are sampled with align_corners=True (the reference's default);
align_corners=False is warned about and not used. cvg and dvg are the search's
convergence and divergence thresholds, as the reference's. Skinning
modes: 'preset' and 'preset_smooth' (fixed grids), 'voxel' (a learned grid
`lbs_voxel` [1, J, D, H, W], softmax(soft_blend * lbs_voxel) over bones, as the
reference) and 'mlp' (an MLP `lbs_network` from canonical points to J logits
evaluated at every voxel centre, softmax(soft_blend * logits); the reference's
ImplicitNetwork options `width`, `depth` and `d_out` are read from
opt.network when given). The learned modes' gradients reach their parameters
through the roots' implicit gradient; 'hierarchical' softmax (SMPL's 24-bone
tree only) is not provided.
"""
import warnings

import torch

from .. import FastSnarfDeformer, VoxelBox, character_size, diffuse_weights_to_grid, nearest_vertices

# The reference implementation's 9 start bones (SMPL: pelvis, hips, knees,
# shoulders, elbows) and InstantAvatar's 13; for any other skeleton every bone
# starts a search.
SMPL_INIT_BONES = [0, 1, 2, 4, 5, 16, 17, 18, 19]
INSTANT_AVATAR_INIT_BONES = [0, 1, 2, 4, 5, 10, 11, 12, 15, 16, 17, 18, 19]


def _option(opt, name, default):
    if isinstance(opt, dict):
        return opt.get(name, default)
    if hasattr(opt, "get") and not hasattr(opt, name):  # omegaconf DictConfig and other mappings
        try:
            return opt.get(name, default)
        except TypeError:
            pass
    return getattr(opt, name, default)


def _nearest_vertex_weights(points, verts, weights):
    """Skinning weights of the nearest template vertex (the reference's 'preset'), by a k-d tree."""
    index, _ = nearest_vertices(points, verts)
    return weights[index]


class _SearchResult(dict):
    """forward's `others`: 'result' and 'valid_ids' at once; 'J_inv' computed when first read."""

    def __init__(self, compute_inverse_jacobian, **items):
        super().__init__(**items)
        self._compute_inverse_jacobian = compute_inverse_jacobian

    def __missing__(self, key):
        if key != "J_inv":
            raise KeyError(key)
        value = self._compute_inverse_jacobian()
        self[key] = value
        return value

    def __contains__(self, key):
        return key == "J_inv" or super().__contains__(key)


class ForwardDeformer(torch.nn.Module):
    """Fast-SNARF's deformer: opt has res, z_ratio, global_scale, skinning_mode
    ('preset': nearest-vertex weights, 'preset_smooth': fskin's diffusion of them), cvg, n_iters;
    smpl_server has verts_c [1, V, 3] and weights_c [1, V, J]. Without smpl_server, InstantAvatar's
    construction: switch_to_explicit(...) builds the grid."""

    def __init__(self, opt, smpl_server=None, **kwargs):
        super().__init__()
        self.opt = opt
        self.soft_blend = float(_option(opt, "soft_blend", 20))
        self.global_scale = float(_option(opt, "global_scale", 1.2))
        self.exact_gradient = bool(_option(opt, "use_slow_grad", False))
        self.n_iters = int(_option(opt, "n_iters", 10))
        self.version = _option(opt, "version", 1)
        self._warned = set()
        if _option(opt, "align_corners", True) is False:
            self._warn_once("align_corners", "align_corners=False is not supported: fskin samples its grids with "
                            "align_corners=True (the reference's default)")
        dvg = _option(opt, "dvg", None)
        self.dvg = None if dvg is None else float(dvg)  # None: fskin's 0.5 x character size / 1.7 m
        if smpl_server is None:  # InstantAvatar: ForwardDeformer(opt), then switch_to_explicit(...)
            self.flavour = "instant-avatar"
            self.mode = "preset"
            self.cvg = float(_option(opt, "cvg", 1e-5))
            self.dvg = 0.1 if self.dvg is None else self.dvg  # InstantAvatar's fixed thresholds
            self.box = None
            return
        self.flavour = "fast-snarf"
        verts = smpl_server.verts_c[0].detach().float().cpu()
        weights = smpl_server.weights_c[0].detach().float().cpu()
        self.num_bones = weights.shape[-1]
        self.init_bones = SMPL_INIT_BONES if self.num_bones == 24 else list(range(self.num_bones))
        res = int(_option(opt, "res", 64))
        z_ratio = int(_option(opt, "z_ratio", 4))
        self.box = VoxelBox.around(verts, (res // z_ratio, res, res), self.global_scale, float(z_ratio))
        self._check_inside_box(verts)
        self.register_buffer("offset", torch.tensor(self.box.offset, dtype=torch.float32).view(1, 1, 3))
        self.register_buffer("scale", torch.tensor(self.box.scale, dtype=torch.float32).view(1, 1, 3))
        self.mode = _option(opt, "skinning_mode", "preset")
        self.cvg = float(_option(opt, "cvg", 1e-4))
        self.length_unit = character_size(verts) / 1.7
        if _option(opt, "softmax_mode", "softmax") == "hierarchical":
            raise NotImplementedError("softmax_mode 'hierarchical' (SMPL's bone tree only): use 'softmax'")
        d, h, w = self.box.shape
        if self.mode == "preset":
            centres = self.box.voxel_centres().reshape(-1, 3)
            grid = _nearest_vertex_weights(centres, verts, weights).reshape(d, h, w, self.num_bones)
            self.register_buffer("lbs_voxel_final", grid.permute(3, 0, 1, 2).unsqueeze(0).contiguous())
        elif self.mode == "preset_smooth":  # fskin's diffusion: nearest vertex, smoothed off the surface
            grid = diffuse_weights_to_grid(verts, weights, self.box)
            self.register_buffer("lbs_voxel_final", grid.permute(3, 0, 1, 2).unsqueeze(0).contiguous())
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

    def _warn_once(self, key, message):
        if key not in self._warned:
            self._warned.add(key)
            warnings.warn(f"fskin.compat.fast_snarf: {message}", UserWarning, stacklevel=3)

    def _check_inside_box(self, verts):
        # The reference's box is a cube of the largest extent squeezed z_ratio times along z: a
        # character deep along z (an animal facing +z) sticks out of it, and points there find no root.
        outside = 1.0 - self.box.contains(verts).float().mean().item()
        if outside > 0:
            self._warn_once("box", f"{100 * outside:.1f} % of the canonical vertices lie outside the reference "
                            "voxel box (res, z_ratio, global_scale); posed points there find no root. "
                            "fskin.FastSnarfDeformer with fskin.VoxelBox.fit(...) takes any proportions")

    # --- InstantAvatar's construction -------------------------------------------------------
    def switch_to_explicit(self, resolution=32, smpl_verts=None, smpl_weights=None, use_smpl=False):
        """InstantAvatar's grid: the box around smpl_verts [1, V, 3] (1.2 x its largest half extent,
        a quarter as deep along z) and the template's weights smpl_weights [1, V, J] diffused into
        the voxels (fskin's nearest vertex + smoothing, where InstantAvatar averages 30 neighbours)."""
        if not use_smpl or smpl_verts is None or smpl_weights is None:
            raise NotImplementedError("switch_to_explicit: fskin builds the grid from the template "
                                      "(use_smpl=True with smpl_verts and smpl_weights)")
        self.resolution = int(resolution)
        verts = smpl_verts[0].detach().float().cpu()
        weights = smpl_weights[0].detach().float().cpu()
        device = smpl_verts.device
        self.num_bones = weights.shape[-1]
        self.init_bones = INSTANT_AVATAR_INIT_BONES if self.num_bones == 24 else list(range(self.num_bones))
        self.ratio = 4.0
        self.box = VoxelBox.around(verts, (self.resolution // 4, self.resolution, self.resolution),
                                   self.global_scale, self.ratio)
        self._check_inside_box(verts)
        self.length_unit = character_size(verts) / 1.7
        centre = -torch.tensor(self.box.offset, dtype=torch.float32).view(1, 1, 3)
        half = 1.0 / self.box.scale[0]  # the box's half size along x and y
        self.register_buffer("offset", centre.to(device))
        self.register_buffer("scale", torch.tensor(half, dtype=torch.float32, device=device))
        self.register_buffer("offset_kernel", -self.offset)
        self.register_buffer("scale_kernel",
                             torch.tensor(self.box.scale, dtype=torch.float32, device=device).view(1, 1, 3))
        corner = torch.full((1, 3), half)
        corner[0, 2] /= self.ratio
        self.bbox = torch.cat([centre[0] - corner, centre[0] + corner]).to(device)
        grid = diffuse_weights_to_grid(verts, weights, self.box)
        self.register_buffer("lbs_voxel_final", grid.permute(3, 0, 1, 2).unsqueeze(0).contiguous().to(device))
        self.register_buffer("grid_denorm", self.box.voxel_centres().reshape(1, -1, 3).to(device))

    def normalize(self, x):
        """Canonical points -> grid coordinates in [-1, 1] (InstantAvatar's normalize)."""
        return (x + self.offset_kernel) * self.scale_kernel

    def denormalize(self, x):
        return x / self.scale_kernel - self.offset_kernel

    # --- the grid ---------------------------------------------------------------------------
    def skinning_grid(self):
        """The grid the search reads, [D, H, W, J] (fskin's layout), with the learned modes' graph."""
        if self.mode == "voxel":
            return torch.softmax(self.soft_blend * self.lbs_voxel[0], dim=0).permute(1, 2, 3, 0)
        if self.mode == "mlp":
            d, h, w = self.box.shape
            logits = self.lbs_network(self.voxel_centres)
            return torch.softmax(self.soft_blend * logits, dim=-1).reshape(d, h, w, -1)
        return self.lbs_voxel_final[0].permute(1, 2, 3, 0)

    def _update_learned_grid(self):
        """The reference's voxel_to_voxel / mlp_to_voxel: lbs_voxel_final [1, J, D, H, W] from the learned grid."""
        if self.mode in ("voxel", "mlp"):
            self.lbs_voxel_final = self.skinning_grid().permute(3, 0, 1, 2).unsqueeze(0)

    def _current_grid(self, eval_mode):
        if self.box is None:
            raise RuntimeError("fskin.compat.fast_snarf: call switch_to_explicit(...) before using the deformer")
        if self.mode in ("voxel", "mlp") and (not eval_mode or not hasattr(self, "lbs_voxel_final")):
            self._update_learned_grid()
        return self.lbs_voxel_final[0].permute(1, 2, 3, 0)

    def _deformer(self, device, dtype, grid):
        return FastSnarfDeformer(grid.to(device=device, dtype=dtype), self.box, start_bones=self.init_bones,
                                 max_iterations=self.n_iters, length_unit=self.length_unit, tolerance=self.cvg,
                                 divergence=self.dvg, exact_gradient=self.exact_gradient)

    def precompute(self, tfs=None, recompute_skinning=True):
        """The voxel centres deformed by tfs [B, J, 4, 4] and each voxel's blended transform:
        returns (voxel_d [B, 3, D, H, W], voxel_J [B, 12, D, H, W]) and keeps them as attributes
        (InstantAvatar's get_bbox_deformed reads voxel_d). With recompute_skinning the learned
        modes' lbs_voxel_final is rebuilt first. Without tfs, only that."""
        if recompute_skinning or not hasattr(self, "lbs_voxel_final"):
            self._update_learned_grid()
        if tfs is None:
            return None
        grid = self._current_grid(eval_mode=True)  # [D, H, W, J]
        weights = grid.to(device=tfs.device, dtype=tfs.dtype)
        blended = torch.einsum("dhwj,bjkl->bdhwkl", weights, tfs[:, :, :3, :])  # [B, D, H, W, 3, 4]
        centres = self.box.voxel_centres().to(device=tfs.device, dtype=tfs.dtype)
        deformed = torch.einsum("bdhwkl,dhwl->bdhwk", blended[..., :3], centres) + blended[..., 3]
        self.voxel_J = blended.flatten(-2).permute(0, 4, 1, 2, 3).contiguous()
        self.voxel_d = deformed.permute(0, 4, 1, 2, 3).contiguous()
        return self.voxel_d, self.voxel_J

    # --- search and skinning ----------------------------------------------------------------
    def forward(self, xd, cond, tfs, mask=None, eval_mode=False):
        """xd [B, N, 3], tfs [B, J, 4, 4] -> xc [B, N, I, 3], others {'result', 'valid_ids', 'J_inv'}.
        Outside eval_mode a learned grid's gradient flows from xc to its parameters; in eval_mode
        xc has no graph (as the reference, which skips the correction)."""
        tfs = tfs.to(xd.dtype)
        if eval_mode:
            with torch.no_grad():
                grid = self._current_grid(eval_mode=True)
                xc, valid = self._deformer(xd.device, xd.dtype, grid).forward(xd, tfs)
        else:
            grid = self._current_grid(eval_mode=False)
            xc, valid = self._deformer(xd.device, xd.dtype, grid).forward(xd, tfs)
        if mask is not None:
            valid = valid & mask.expand_as(valid)
        result = xc.detach()
        return xc, _SearchResult(lambda: self._inverse_jacobian(result, valid, tfs, grid.detach()),
                                 result=result, valid_ids=valid)

    def _inverse_jacobian(self, xc, valid, tfs, grid):
        """(d forward_skinning / d x)^-1 at the roots xc [B, N, I, 3] -> [B, N, I, 3, 3] (identity where invalid)."""
        b, n, i, _ = xc.shape
        deformer = self._deformer(xc.device, xc.dtype, grid)
        with torch.enable_grad():
            x = xc.detach().reshape(b, n * i, 3).requires_grad_(True)
            y = deformer.deform(x, tfs.detach())
            rows = [torch.autograd.grad(y[..., k].sum(), x, retain_graph=k < 2)[0] for k in range(3)]
        jacobian = torch.stack(rows, dim=-2).reshape(b, n, i, 3, 3)
        eye = torch.eye(3, dtype=xc.dtype, device=xc.device)
        jacobian = torch.where(valid[..., None, None], jacobian, eye)
        return torch.linalg.inv(jacobian)

    def forward_skinning(self, xc, cond, tfs, mask=None):
        """Canonical points [B, ..., 3] -> deformed points by LBS with the grid's weights: xc's shape
        (Fast-SNARF), or the points where mask [B, ...] holds, [P, 3] (InstantAvatar)."""
        b = xc.shape[0]
        grid = self._current_grid(eval_mode=not torch.is_grad_enabled())
        xd = self._deformer(xc.device, xc.dtype, grid).deform(xc.reshape(b, -1, 3), tfs.to(xc.dtype))
        xd = xd.reshape(xc.shape)
        if mask is not None and self.flavour == "instant-avatar":
            return xd[mask]
        return xd

    def query_weights(self, xc, cond=None, mask=None, mode="bilinear"):
        """Skinning weights at canonical points [..., 3] -> [..., J]."""
        grid = self._current_grid(eval_mode=not torch.is_grad_enabled())
        weights = self._deformer(xc.device, xc.dtype, grid).weights(xc.reshape(1, -1, 3))
        return weights.reshape(*xc.shape[:-1], -1)


def _mlp(d_in, d_out, width, depth):
    """A plain MLP (Softplus(beta=100) hidden activations, as the reference's ImplicitNetwork)."""
    layers, size = [], d_in
    for _ in range(depth):
        layers += [torch.nn.Linear(size, width), torch.nn.Softplus(beta=100)]
        size = width
    layers.append(torch.nn.Linear(size, d_out))
    return torch.nn.Sequential(*layers)
