"""fskin's fused ops as operators in PyTorch's dispatcher (torch.ops.fskin.*):
the same values and gradients as fskin's typed wrappers, float64 gradchecks,
TorchScript, and clear errors."""
import pytest
import torch

import fskin


def random_rays(rays=6, samples=10, dtype=torch.float64):
    g = torch.Generator().manual_seed(0)
    sigma = torch.rand(rays, samples, generator=g, dtype=dtype) * 5
    rgb = torch.rand(rays, samples, 3, generator=g, dtype=dtype)
    delta = torch.rand(rays, samples, generator=g, dtype=dtype) * 0.1
    background = torch.rand(rays, 3, generator=g, dtype=dtype)
    return sigma, rgb, delta, background


def test_composite_rays_is_a_dispatcher_op_with_gradients_in_all_four_inputs():
    inputs = [t.requires_grad_() for t in random_rays()]
    color, opacity = torch.ops.fskin.composite_rays(*inputs)
    expected_color, expected_opacity = fskin.composite_rays(*inputs)
    assert torch.allclose(color, expected_color) and torch.allclose(opacity, expected_opacity)
    assert torch.autograd.gradcheck(lambda *x: torch.ops.fskin.composite_rays(*x), inputs)


def test_composite_rays_refuses_double_backward():
    inputs = [t.requires_grad_() for t in random_rays()]
    color, _ = torch.ops.fskin.composite_rays(*inputs)
    with pytest.raises(RuntimeError, match="double backward"):
        torch.autograd.grad(color.sum(), inputs[0], create_graph=True)


@torch.jit.script
def scripted_composite(sigma: torch.Tensor, rgb: torch.Tensor, delta: torch.Tensor, background: torch.Tensor):
    color, opacity = torch.ops.fskin.composite_rays(sigma, rgb, delta, background)
    return color * opacity.unsqueeze(-1)


def test_ops_run_in_torchscript():
    sigma, rgb, delta, background = random_rays()
    color, opacity = fskin.composite_rays(sigma, rgb, delta, background)
    assert torch.allclose(scripted_composite(sigma, rgb, delta, background), color * opacity.unsqueeze(-1))


def test_bad_inputs_to_a_dispatcher_op_say_what_is_wrong():
    sigma, rgb, delta, background = random_rays()
    with pytest.raises(RuntimeError, match="composite_rays: rgb"):
        torch.ops.fskin.composite_rays(sigma, rgb[:, :, :2], delta, background)
    with pytest.raises(RuntimeError, match="share one dtype"):
        torch.ops.fskin.composite_rays(sigma.float(), rgb, delta, background)
