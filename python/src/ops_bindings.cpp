// The fused ops' typed wrappers; the same ops are torch.ops.fskin.* (PyTorch's dispatcher).
#include "bindings.h"

#include "fskin/ops/gaussian_rasterization.h"
#include "fskin/ops/hash_encoding.h"
#include "fskin/ops/ray_compositing.h"

namespace fskin::python {

void bind_ops(py::module_& m) {
  const auto encoding_options = [](int64_t levels, int64_t features, int64_t log2_size, int64_t base, double scale) {
    fskin::HashEncodingOptions o;
    o.levels = levels;
    o.features_per_level = features;
    o.log2_table_size = log2_size;
    o.base_resolution = base;
    o.per_level_scale = scale;
    o.validate();
    return o;
  };
  m.def(
      "hash_encoding",
      [encoding_options](const torch::Tensor& positions, const torch::Tensor& table, int64_t levels,
                         int64_t features_per_level, int64_t log2_table_size, int64_t base_resolution,
                         double per_level_scale) {
        return fskin::hash_encoding(
            positions, table,
            encoding_options(levels, features_per_level, log2_table_size, base_resolution, per_level_scale));
      },
      py::arg("positions"), py::arg("table"), py::arg("levels") = 16, py::arg("features_per_level") = 2,
      py::arg("log2_table_size") = 19, py::arg("base_resolution") = 16, py::arg("per_level_scale") = 1.5,
      "instant-NGP's multi-resolution hash encoding (fused op): positions [N, 3] in the unit cube, table "
      "[L, 2^T, F] -> features [N, L * F]; differentiable in the table and the positions");
  m.def(
      "hash_encoding_table",
      [encoding_options](int64_t levels, int64_t features_per_level, int64_t log2_table_size,
                         int64_t base_resolution, double per_level_scale, py::object dtype) {
        auto options = torch::TensorOptions();
        if (!dtype.is_none()) options = options.dtype(torch::python::detail::py_object_to_dtype(dtype));
        return fskin::hash_encoding_table(
            encoding_options(levels, features_per_level, log2_table_size, base_resolution, per_level_scale), options);
      },
      py::arg("levels") = 16, py::arg("features_per_level") = 2, py::arg("log2_table_size") = 19,
      py::arg("base_resolution") = 16, py::arg("per_level_scale") = 1.5, py::arg("dtype") = py::none(),
      "A hash-encoding table [L, 2^T, F] initialised as instant-NGP does: U(-1e-4, 1e-4)");
  m.def(
      "composite_rays",
      [](const torch::Tensor& sigma, const torch::Tensor& rgb, const torch::Tensor& delta,
         const torch::Tensor& background) {
        const auto [color, opacity] = fskin::composite_rays(sigma, rgb, delta, background);
        return py::make_tuple(color, opacity);
      },
      py::arg("sigma"), py::arg("rgb"), py::arg("delta"), py::arg("background"),
      "Volume-rendering compositing (fused op): sigma [R, S], rgb [R, S, 3], delta [R, S], background [R, 3] -> "
      "(color [R, 3], opacity [R]); differentiable in all four inputs");
  m.def(
      "rasterize_gaussians",
      [](const torch::Tensor& means2d, const torch::Tensor& conics, const torch::Tensor& colors,
         const torch::Tensor& opacities, const torch::Tensor& depths, const torch::Tensor& radii,
         const torch::Tensor& background, int64_t width, int64_t height) {
        const auto [image, alpha] =
            fskin::rasterize_gaussians(means2d, conics, colors, opacities, depths, radii, background, width, height);
        return py::make_tuple(image, alpha);
      },
      py::arg("means2d"), py::arg("conics"), py::arg("colors"), py::arg("opacities"), py::arg("depths"),
      py::arg("radii"), py::arg("background"), py::arg("width"), py::arg("height"),
      "Tile-based rasterisation of 2-D Gaussians (fused op, 3DGS's image formation): means2d [N, 2] pixels, conics "
      "[N, 3] (inverse 2-D covariance a, b, c), colors [N, C], opacities [N], depths [N], radii [N] pixels, "
      "background [C] -> (image [H, W, C], alpha [H, W]); differentiable in means2d, conics, colors, opacities and "
      "background");
}

}  // namespace fskin::python
