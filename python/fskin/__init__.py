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
    Dataset,
    Error,
    Pin,
    Run,
    VoxelBox,
    __version__,
    build_dataset,
    build_image_dataset,
    built_with_cuda,
    built_with_embree,
    character_size,
    composite_rays,
    diffuse_weights_to_grid,
    evaluate,
    evaluate_avatar,
    export_avatar,
    hash_encoding,
    hash_encoding_table,
    humanoid,
    import_capture,
    import_character,
    lowpoly_character,
    nearest_vertices,
    ood_poses,
    perturb_poses,
    quadruped,
    rasterize_gaussians,
    read_mesh,
    read_png,
    refined_poses,
    render_avatar,
    train,
    train_avatar,
    train_gaussian_avatar,
    training_poses,
    write_mesh,
    write_png,
)
from ._fskin import openblas_core, recommended_openblas_core  # noqa: F401
from .deformers import FastSnarfDeformer, SnarfDeformer  # noqa: F401  (torch.nn.Modules over the C++ search)

# OpenBLAS picks its kernels once, when LibTorch loads it: a Python process
# cannot switch them as the fskin CLI does (util/runtime_restart.h), so say so.
if recommended_openblas_core() is not None:
    import warnings

    warnings.warn(
        f"fskin: OpenBLAS runs its generic SSE3 kernels ({openblas_core()}) on this CPU; start Python with "
        f"OPENBLAS_CORETYPE={recommended_openblas_core()} for the several times faster kernels the fskin CLI uses",
        RuntimeWarning, stacklevel=2)

# Debian's torch (libgomp) can start with one intra-op thread on a machine
# with more cores, and fskin's ops (at::parallel_for) then run on one core
# where the CLI uses them all. Unless the user chose a count in the
# environment (OMP_NUM_THREADS), use the cores this process may run on;
# torch.set_num_threads(n) after the import still decides.
def _default_threads() -> None:
    import os

    if "OMP_NUM_THREADS" in os.environ:
        return
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    if torch.get_num_threads() < cores:
        torch.set_num_threads(cores)


_default_threads()
