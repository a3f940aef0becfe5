"""fskin's Fast-SNARF deformer as a torch.nn.Module.

The search itself is C++ (`fskin._fskin.FastSnarfDeformer`, deformers/fast_snarf_deformer.h);
this module owns its skinning grid as a buffer (or a parameter, when given one), so that
`.to()`, `state_dict()`, `load_state_dict()`, `copy.deepcopy`, `torch.save` and `repr`
behave as they do for torch's own modules, and calling the module runs `forward`.
"""
from typing import Optional, Sequence, Tuple, Union

import torch

from . import _fskin

StartBones = Union[None, str, int, Sequence[int]]


class FastSnarfDeformer(torch.nn.Module):
    """Fast-SNARF's deformer over a voxel skinning grid [D, H, W, J] (weights summing to 1).

    grid_weights: the grid over `box` (a buffer; a torch.nn.Parameter becomes a parameter
    the roots' implicit gradient reaches; a tensor computed with a graph, assigned to
    `grid_weights` before each call, passes the gradient to what computed it).
    start_bones: None / 'all', an int k (per point, the k bones with the largest weight), or
    a list of bones. length_unit scales the thresholds for characters not 1.7 m long
    (character_size / 1.7); tolerance: the residual norm a root converges to (default
    Fast-SNARF's 1e-4 x length_unit); divergence: the residual norm at which a candidate is
    dropped (default 0.5 x length_unit)."""

    def __init__(self, grid_weights: torch.Tensor, box: "_fskin.VoxelBox", start_bones: StartBones = None,
                 max_iterations: int = 10, exact_gradient: bool = False, length_unit: float = 1.0,
                 tolerance: Optional[float] = None, divergence: Optional[float] = None) -> None:
        super().__init__()
        native = _fskin.FastSnarfDeformer(grid_weights, box, start_bones, max_iterations, exact_gradient,
                                          length_unit, tolerance, divergence)
        self.box = box
        self.search_options = dict(start_bones=start_bones, max_iterations=max_iterations,
                                   exact_gradient=exact_gradient, length_unit=length_unit, tolerance=tolerance,
                                   divergence=divergence)
        self._native = native
        if isinstance(grid_weights, torch.nn.Parameter):
            self.grid_weights = grid_weights
        else:
            self.register_buffer("grid_weights", grid_weights)

    def __setattr__(self, name, value):
        if name == "grid_weights" and "_native" in self.__dict__:
            self._native.grid_weights = value  # fskin validates the new grid (shape, finite, >= 0)
        super().__setattr__(name, value)

    def _synced(self) -> "_fskin.FastSnarfDeformer":
        # .to(), .double() and copies replace the grid tensor: hand the search the one the
        # module holds now (the search keeps the very tensor it is given, so `is` tells).
        if self._native.grid_weights is not self.grid_weights:
            self._native.grid_weights = self.grid_weights
        return self._native

    def forward(self, x_posed: torch.Tensor, bones: torch.Tensor) -> Tuple[torch.Tensor, torch.Tensor]:
        """x_posed [B, N, 3], bones [B, J, 4, 4] canonical -> posed: (x_canonical [B, N, I, 3],
        valid [B, N, I]); x_canonical carries the implicit gradient (Fast-SNARF eq. 16-17) to the
        points, the bones and the grid."""
        return self._synced().forward(x_posed, bones)

    def deform(self, x_canonical: torch.Tensor, bones: torch.Tensor) -> torch.Tensor:
        """LBS of canonical points [B, N, 3] with the grid's weights -> posed [B, N, 3]."""
        return self._synced().deform(x_canonical, bones)

    def weights(self, x_canonical: torch.Tensor) -> torch.Tensor:
        """Skinning weights at canonical points [..., 3] -> [..., J]."""
        return self._synced().weights(x_canonical)

    def extra_repr(self) -> str:
        options = ", ".join(f"{k}={v!r}" for k, v in self.search_options.items())
        return f"grid={tuple(self.grid_weights.shape)}, box={self.box!r}, {options}"


class SnarfDeformer(torch.nn.Module):
    """SNARF's deformer over a skinning MLP (softmax(20 logits)) whose parameters the caller
    optimises: the roots' exact implicit gradient (SNARF eq. 14) reaches them.

    extent: canonical points [M, 3] whose bounding box the network's inputs are normalised
    to. start_bones, length_unit and tolerance as FastSnarfDeformer's."""

    def __init__(self, num_bones: int, extent: torch.Tensor, hidden_dim: int = 128, hidden_layers: int = 4,
                 start_bones: StartBones = None, max_iterations: int = 50, length_unit: float = 1.0,
                 tolerance: Optional[float] = None) -> None:
        super().__init__()
        self._build(dict(num_bones=num_bones, extent=extent, hidden_dim=hidden_dim, hidden_layers=hidden_layers,
                         start_bones=start_bones, max_iterations=max_iterations, length_unit=length_unit,
                         tolerance=tolerance))

    def _build(self, arguments):
        a = arguments
        self.arguments = arguments
        self._native = _fskin.SnarfDeformer(a["num_bones"], a["extent"], a["hidden_dim"], a["hidden_layers"],
                                            a["start_bones"], a["max_iterations"], a["length_unit"], a["tolerance"])
        self._adopt_parameters()

    def _adopt_parameters(self):
        # The MLP's tensors live in C++ (fields/mlp_skinning_field.h), and the search's graph
        # accumulates gradients on those very tensors: the module lists them as they are (torch
        # keeps one Python object per tensor), so optimisers, state_dict() and load_state_dict()
        # reach the tensors the search uses.
        self._parameters.clear()
        for index, tensor in enumerate(self._native.parameters()):
            self._parameters[f"mlp_{index}"] = tensor

    def _apply(self, fn):
        # .double(), .float(), .to(dtype): the C++ field converts itself (in place).
        probe = fn(torch.zeros((), dtype=self._parameters["mlp_0"].dtype))
        if probe.device.type != "cpu":
            raise NotImplementedError("SnarfDeformer runs on the CPU (its MLP is a LibTorch module on the host)")
        if probe.dtype in (torch.float32, torch.float64):
            self._native.to("float64" if probe.dtype == torch.float64 else "float32")
        self._adopt_parameters()
        return self

    def to(self, *args, **kwargs):
        """A dtype or a device as torch's modules take them; also 'float32' / 'float64'."""
        if len(args) == 1 and not kwargs and isinstance(args[0], str) and not args[0].startswith(("cpu", "cuda")):
            self._native.to(args[0])  # fskin checks the name
            self._adopt_parameters()
            return self
        return super().to(*args, **kwargs)

    def __getstate__(self):
        return {"arguments": self.arguments, "state": {k: v.detach().clone() for k, v in self.state_dict().items()},
                "training": self.training}

    def __setstate__(self, state):
        torch.nn.Module.__init__(self)
        self._build(state["arguments"])
        dtype = state["state"]["mlp_0"].dtype
        if dtype != self._parameters["mlp_0"].dtype:
            self._native.to("float64" if dtype == torch.float64 else "float32")
            self._adopt_parameters()
        self.load_state_dict(state["state"])
        self.train(state["training"])

    def forward(self, x_posed: torch.Tensor, bones: torch.Tensor) -> Tuple[torch.Tensor, torch.Tensor]:
        """x_posed [B, N, 3], bones [B, J, 4, 4] -> (x_canonical [B, N, I, 3], valid [B, N, I]); exact
        implicit gradient to the points, the bones and the MLP."""
        return self._native.forward(x_posed, bones)

    def deform(self, x_canonical: torch.Tensor, bones: torch.Tensor) -> torch.Tensor:
        """LBS of canonical points [B, N, 3] with the MLP's weights -> posed [B, N, 3]."""
        return self._native.deform(x_canonical, bones)

    def weights(self, x_canonical: torch.Tensor) -> torch.Tensor:
        """Skinning weights at canonical points [..., 3] -> [..., J]."""
        return self._native.weights(x_canonical)

    def extra_repr(self) -> str:
        a = self.arguments
        return (f"num_bones={a['num_bones']}, hidden_dim={a['hidden_dim']}, hidden_layers={a['hidden_layers']}, "
                f"start_bones={a['start_bones']!r}, max_iterations={a['max_iterations']}")
