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


def test_hash_encoding_is_a_dispatcher_op_differentiable_in_positions_and_table():
    table = fskin.hash_encoding_table(levels=3, features_per_level=2, log2_table_size=6, base_resolution=2,
                                      per_level_scale=2.0, dtype=torch.float64).mul_(1e3).requires_grad_()
    positions = torch.rand(20, 3, dtype=torch.float64, generator=torch.Generator().manual_seed(1)).requires_grad_()
    features = torch.ops.fskin.hash_encoding(positions, table, 2, 2.0)
    expected = fskin.hash_encoding(positions, table, levels=3, features_per_level=2, log2_table_size=6,
                                   base_resolution=2, per_level_scale=2.0)
    assert features.shape == (20, 6) and torch.allclose(features, expected)
    assert torch.autograd.gradcheck(lambda p, t: torch.ops.fskin.hash_encoding(p, t, 2, 2.0), (positions, table))


def identity_grid(depth=4, height=5, width=6, dtype=torch.float64):
    grid = torch.zeros(1, depth, height, width, 12, dtype=dtype)
    grid[..., 0] = grid[..., 5] = grid[..., 10] = 1  # row-major [R | t] with R = I, t = 0
    return grid


def test_grid_forward_skinning_and_broyden_search_are_dispatcher_ops():
    grid = identity_grid()
    grid[..., 3] = 0.25  # translate every voxel by +0.25 in x
    offset, scale = [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]
    x = torch.rand(1, 30, 3, dtype=torch.float64, generator=torch.Generator().manual_seed(2)) - 0.5
    posed = torch.ops.fskin.grid_forward_skinning(grid, offset, scale, x)
    assert torch.allclose(posed, x + torch.tensor([0.25, 0.0, 0.0], dtype=torch.float64))
    starts = torch.eye(4, dtype=torch.float64).expand(1, 2, 4, 4).contiguous()
    roots, valid, iterations, start_index, inverse_jacobian = torch.ops.fskin.broyden_search(
        grid, offset, scale, posed, starts, return_inverse_jacobian=True)
    assert roots.shape == (1, 30, 2, 3) and bool(valid.all())
    assert torch.allclose(roots, x.unsqueeze(2).expand_as(roots), atol=1e-6)
    assert inverse_jacobian.shape == (1, 30, 2, 3, 3) and start_index.dtype == torch.int64
    kept = torch.ops.fskin.filter_duplicate_roots(roots, valid)
    assert bool(kept[..., 0].all()) and not bool(kept[..., 1].any())  # both starts found the same root


def test_a_box_of_the_wrong_size_is_an_error_naming_the_op():
    with pytest.raises(RuntimeError, match="grid_forward_skinning: box_offset"):
        torch.ops.fskin.grid_forward_skinning(identity_grid(), [0.0, 0.0], [1.0, 1.0, 1.0], torch.zeros(1, 2, 3))


@torch.jit.script
def scripted_pin_pass(points: torch.Tensor, packed: torch.Tensor, shape: list[int], inverse: bool):
    return torch.ops.fskin.pin_pass(points, packed, shape, inverse)


def test_pin_pass_is_a_dispatcher_op_the_fused_pin_calls():
    torch.manual_seed(3)
    pin = fskin.Pin(num_layers=3, embedding_dim=6)
    embedding = torch.randn(2, 6) * 0.5
    points = torch.rand(2, 30, 3) * 2 - 1
    packed, shape = pin.fused_arguments(embedding)
    assert packed.shape[0] == 2 and packed.dtype == torch.float32 and len(shape) == 6 + 5 * 3
    moved = torch.ops.fskin.pin_pass(points, packed, shape, False)
    assert torch.equal(moved, pin.fused(points, embedding))
    assert torch.equal(scripted_pin_pass(points, packed, shape, False), moved)
    back = torch.ops.fskin.pin_pass(moved, packed, shape, True)
    assert torch.allclose(back, points, atol=1e-4)
    with pytest.raises(RuntimeError, match="pin_pass: layer 0"):
        torch.ops.fskin.pin_pass(points, packed, shape[:6] + [3] + shape[7:], False)
    with pytest.raises(RuntimeError, match="pin_pass: packed parameters"):
        torch.ops.fskin.pin_pass(points, packed[:, :-1], shape, False)


def test_rasterize_gaussians_is_a_dispatcher_op_with_gradients():
    torch.manual_seed(1)
    n = 5
    means2d = (torch.rand(n, 2, dtype=torch.float64) * 20).requires_grad_()
    sigma = 1.5 + 2 * torch.rand(n, dtype=torch.float64)
    conics = torch.stack([1 / sigma**2, torch.zeros(n, dtype=torch.float64), 1 / sigma**2], 1).requires_grad_()
    colors = torch.rand(n, 3, dtype=torch.float64, requires_grad=True)
    opacities = (0.2 + 0.5 * torch.rand(n, dtype=torch.float64)).requires_grad_()
    depths = torch.rand(n, dtype=torch.float64)
    radii = torch.ceil(3 * sigma)
    background = torch.rand(3, dtype=torch.float64, requires_grad=True)
    image, alpha = torch.ops.fskin.rasterize_gaussians(means2d, conics, colors, opacities, depths, radii, background,
                                                       20, 18)
    expected_image, expected_alpha = fskin.rasterize_gaussians(means2d, conics, colors, opacities, depths, radii,
                                                               background, 20, 18)
    assert image.shape == (18, 20, 3) and alpha.shape == (18, 20)
    assert torch.equal(image, expected_image) and torch.equal(alpha, expected_alpha)
    assert torch.autograd.gradcheck(
        lambda m, q, c, o, b: torch.ops.fskin.rasterize_gaussians(m, q, c, o, depths, radii, b, 20, 18),
        (means2d, conics, colors, opacities, background))
    # The internal forward returns the tile lists its backward walks; lists
    # that would index outside the Gaussians are refused, not read.
    with torch.no_grad():
        args = (means2d, conics, colors, opacities, depths, radii, background, 20, 18)
        image, alpha, tile_gaussians, tile_ranges = torch.ops.fskin._rasterize_gaussians_forward(*args)
        assert tile_ranges.shape == (2 * 2 + 1,) and int(tile_ranges[-1]) == tile_gaussians.numel() > 0
        grads = torch.ops.fskin._rasterize_gaussians_backward(
            torch.ones_like(image), None, image, alpha, tile_gaussians, tile_ranges, means2d, conics, colors,
            opacities, depths, radii, background, 20, 18, [True] * 5)
        assert torch.isfinite(grads[0]).all()
        for bad_gaussians, bad_ranges, message in (
                (tile_gaussians + n, tile_ranges, "tile_gaussians must index the 5 Gaussians"),
                (tile_gaussians, tile_ranges.flip(0), "tile_ranges must rise"),
                (tile_gaussians, tile_ranges[:-1], "tile_ranges")):
            with pytest.raises(RuntimeError, match=message):
                torch.ops.fskin._rasterize_gaussians_backward(
                    torch.ones_like(image), None, image, alpha, bad_gaussians, bad_ranges, means2d, conics, colors,
                    opacities, depths, radii, background, 20, 18, [True] * 5)
