"""fskin from Python: the C++ library's body models, characters and deformers.

Tensors are torch tensors shared with the library (no copies); every result
joins the caller's autograd graph. Errors raise fskin.Error with fskin's
message (which names the file, tensor or argument at fault).

    import torch, fskin
    body = fskin.humanoid(resolution=48)
    vertices, joints, bones = body.forward(torch.zeros(1, body.num_joints, 3))
"""
import torch  # noqa: F401  (loads LibTorch's Python bindings before the extension)

from ._fskin import (  # noqa: F401
    BodyModel,
    Error,
    FastSnarfDeformer,
    SnarfDeformer,
    VoxelBox,
    __version__,
    character_size,
    diffuse_weights_to_grid,
    evaluate,
    humanoid,
    quadruped,
    train,
)
