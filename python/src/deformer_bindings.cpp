// The deformers over skinning fields the caller owns (Fast-SNARF's grid, SNARF's MLP).
#include "bindings.h"

#include "fskin/core/error.h"
#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/deformers/snarf_deformer.h"
#include "fskin/fields/mlp_skinning_field.h"
#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/geometry/voxel_box.h"

namespace fskin::python {
namespace {

fskin::StartBones parse_start_bones(const py::object& value) {
  if (value.is_none()) return fskin::StartBones::all();
  if (py::isinstance<py::str>(value)) {
    const auto text = value.cast<std::string>();
    if (text == "all") return fskin::StartBones::all();
    fskin::fail("start_bones: '{}' is not 'all', an int (automatic: that many starts per point) or a list of bones",
                text);
  }
  const auto is_whole_number = [](const py::handle& v) {
    return py::isinstance<py::int_>(v) && !py::isinstance<py::bool_>(v);
  };
  const auto shown = [](const py::handle& v) { return py::repr(v).cast<std::string>(); };
  if (is_whole_number(value)) return fskin::StartBones::automatic(value.cast<int64_t>());
  FSKIN_CHECK(py::isinstance<py::sequence>(value) && !py::isinstance<py::bool_>(value),
              "start_bones: {} is not 'all', an int (automatic: that many starts per point) or a list of bones",
              shown(value));
  std::vector<int64_t> bones;
  for (const auto& bone : value.cast<py::sequence>()) {
    FSKIN_CHECK(is_whole_number(bone), "start_bones: the list {} holds {}, not a bone index (an int)", shown(value),
                shown(bone));
    bones.push_back(bone.cast<int64_t>());
  }
  return fskin::StartBones::subset(bones);
}

// The search options both deformers take from Python: the paper's settings
// scaled to the character, then the caller's start bones, iterations and
// convergence tolerance and divergence threshold (residual norms).
fskin::DeformerOptions search_options(const char* who, fskin::DeformerOptions paper, const py::object& start_bones,
                                      int max_iterations, double length_unit, std::optional<double> tolerance,
                                      std::optional<double> divergence = std::nullopt) {
  FSKIN_CHECK(length_unit > 0 && std::isfinite(length_unit), "{}: length_unit {} must be > 0", who, length_unit);
  FSKIN_CHECK(max_iterations >= 1, "{}: max_iterations {} must be >= 1", who, max_iterations);
  auto o = paper.scaled(length_unit);
  o.start_bones = parse_start_bones(start_bones);
  o.max_iterations = max_iterations;
  if (tolerance) {
    FSKIN_CHECK(*tolerance > 0 && std::isfinite(*tolerance), "{}: tolerance {} must be > 0", who, *tolerance);
    o.converge_sq = *tolerance * *tolerance;
  }
  if (divergence) {
    FSKIN_CHECK(std::isfinite(*divergence) && *divergence * *divergence > o.converge_sq,
                "{}: divergence {} must be finite and above the tolerance", who, *divergence);
    o.diverge_sq = *divergence * *divergence;
  }
  return o;
}

// A Fast-SNARF deformer over a voxel skinning grid the caller owns: a fixed
// grid, or one computed with a graph (a softmax of a voxel parameter, an MLP
// at the voxel centres) and set again before each search, so the roots'
// implicit gradient reaches what computed it.
// What both deformers give Python: the search, forward skinning and the
// weights of the field they own.
template <typename Field, typename Deformer>
class PyDeformer {
 public:
  PyDeformer(std::shared_ptr<Field> field, const fskin::DeformerOptions& options)
      : field_(std::move(field)), deformer_(field_, options) {}

  std::tuple<torch::Tensor, torch::Tensor> forward(const torch::Tensor& x_posed, const torch::Tensor& bones) {
    const auto out = deformer_.forward(x_posed, bones);
    return {out.x_canonical, out.valid};
  }
  torch::Tensor deform(const torch::Tensor& x_canonical, const torch::Tensor& bones) {
    return deformer_.deform(x_canonical, bones);
  }
  torch::Tensor weights(const torch::Tensor& x_canonical) { return field_->weights(x_canonical); }
 protected:
  std::shared_ptr<Field> field_;
  Deformer deformer_;
};

class PyFastSnarf : public PyDeformer<fskin::CallerGridSkinningField, fskin::FastSnarfDeformer> {
 public:
  PyFastSnarf(const torch::Tensor& grid_weights, const VoxelBox& box, const py::object& start_bones,
              int max_iterations, bool exact_gradient, double length_unit, std::optional<double> tolerance,
              std::optional<double> divergence)
      : PyDeformer(std::make_shared<fskin::CallerGridSkinningField>(grid_weights, box),
                   options(box, start_bones, max_iterations, exact_gradient, length_unit, tolerance, divergence)),
        arguments_(py::make_tuple(start_bones, max_iterations, exact_gradient, length_unit, tolerance, divergence)) {}

  // pickle / copy.deepcopy: the grid (detached), the box and the constructor's search arguments.
  py::tuple state() const { return py::make_tuple(field_->grid_weights().detach(), field_->box(), arguments_); }
  static PyFastSnarf from_state(const py::tuple& state) {
    FSKIN_CHECK(state.size() == 3, "FastSnarfDeformer: a pickled state has 3 parts, got {}", state.size());
    const auto arguments = state[2].cast<py::tuple>();
    FSKIN_CHECK(arguments.size() == 6, "FastSnarfDeformer: pickled search arguments have 6 parts, got {}",
                arguments.size());
    return PyFastSnarf(state[0].cast<torch::Tensor>(), state[1].cast<VoxelBox>(), arguments[0],
                       arguments[1].cast<int>(), arguments[2].cast<bool>(), arguments[3].cast<double>(),
                       arguments[4].cast<std::optional<double>>(), arguments[5].cast<std::optional<double>>());
  }

  torch::Tensor grid_weights() const { return field_->grid_weights(); }
  void set_grid_weights(const torch::Tensor& grid) { field_->set_grid(grid); }
  const VoxelBox& box() const { return field_->box(); }

 private:
  static fskin::DeformerOptions options(const VoxelBox& box, const py::object& start_bones, int max_iterations,
                                        bool exact_gradient, double length_unit, std::optional<double> tolerance,
                                        std::optional<double> divergence) {
    box.validate("FastSnarfDeformer: box");
    auto o = search_options("FastSnarfDeformer", fskin::DeformerOptions::fast_snarf(), start_bones, max_iterations,
                            length_unit, tolerance, divergence);
    if (exact_gradient) o.gradient = fskin::GradientMode::Exact;
    return o;
  }
  py::tuple arguments_;  // start_bones, max_iterations, exact_gradient, length_unit, tolerance, divergence
};

// SNARF's deformer over fskin's skinning MLP, whose parameters the caller
// optimises (torch.optim on `parameters()`): the roots' implicit gradient
// reaches them (SNARF eq. 14).
class PySnarf : public PyDeformer<fskin::MlpSkinningField, fskin::SnarfDeformer> {
 public:
  PySnarf(int64_t num_bones, const torch::Tensor& extent, int64_t hidden_dim, int64_t hidden_layers,
          const py::object& start_bones, int max_iterations, double length_unit, std::optional<double> tolerance)
      : PyDeformer(std::make_shared<fskin::MlpSkinningField>(field_options(num_bones, extent, hidden_dim, hidden_layers)),
                   options(start_bones, max_iterations, length_unit, tolerance)) {}

  std::vector<torch::Tensor> parameters() { return field_->parameters(); }
  void to_dtype(const std::string& dtype) {
    FSKIN_CHECK(dtype == "float32" || dtype == "float64", "SnarfDeformer.to: dtype '{}' is not float32 or float64",
                dtype);
    field_->to(dtype == "float64" ? torch::kFloat64 : torch::kFloat32);
  }

 private:
  static fskin::MlpSkinningFieldOptions field_options(int64_t num_bones, const torch::Tensor& extent,
                                                      int64_t hidden_dim, int64_t hidden_layers) {
    FSKIN_CHECK(num_bones >= 1 && hidden_dim >= 1 && hidden_layers >= 1,
                "SnarfDeformer: num_bones {}, hidden_dim {} and hidden_layers {} must be >= 1", num_bones, hidden_dim,
                hidden_layers);
    fskin::MlpSkinningFieldOptions o;
    o.num_bones = num_bones;
    o.hidden_dim = hidden_dim;
    o.hidden_layers = hidden_layers;
    o.input = fskin::InputNormalization::around(extent.to(torch::kFloat64));
    return o;
  }
  static fskin::DeformerOptions options(const py::object& start_bones, int max_iterations, double length_unit,
                                        std::optional<double> tolerance) {
    return search_options("SnarfDeformer", fskin::DeformerOptions::snarf(), start_bones, max_iterations, length_unit,
                          tolerance);
  }
};

}  // namespace

void bind_deformers(py::module_& m) {
  py::class_<PyFastSnarf>(m, "FastSnarfDeformer",
                          "Fast-SNARF's deformer over a voxel skinning grid [D, H, W, J] (weights summing to 1); a grid "
                          "that requires grad receives the roots' implicit gradient")
      .def(py::init<const torch::Tensor&, const VoxelBox&, const py::object&, int, bool, double,
                    std::optional<double>, std::optional<double>>(),
           py::arg("grid_weights"), py::arg("box"), py::arg("start_bones") = py::none(), py::arg("max_iterations") = 10,
           py::arg("exact_gradient") = false, py::arg("length_unit") = 1.0, py::arg("tolerance") = py::none(),
           py::arg("divergence") = py::none(),
           "start_bones: None/'all', an int k (per point, the k bones with the largest weight), or a list of bones; "
           "length_unit scales the thresholds for characters not 1.7 m long (character_size / 1.7); tolerance: "
           "the residual norm a root converges to (default Fast-SNARF's 1e-4 times length_unit); divergence: the "
           "residual norm at which a candidate is dropped (default 0.5 times length_unit; the reference's dvg)")
      // The search runs LibTorch's autograd (exact gradients) and threads: without the GIL.
      .def("forward", &PyFastSnarf::forward, py::arg("x_posed"), py::arg("bones"),
           py::call_guard<py::gil_scoped_release>(),
           "x_posed [B, N, 3], bones [B, J, 4, 4] canonical -> posed: (x_canonical [B, N, I, 3], valid [B, N, I])")
      .def("deform", &PyFastSnarf::deform, py::arg("x_canonical"), py::arg("bones"),
           py::call_guard<py::gil_scoped_release>(),
           "LBS of canonical points [B, N, 3] with the grid's weights -> posed [B, N, 3]")
      .def("weights", &PyFastSnarf::weights, py::arg("x_canonical"), "Skinning weights at canonical points [..., J]")
      .def_property("grid_weights", &PyFastSnarf::grid_weights, &PyFastSnarf::set_grid_weights,
                    "The skinning grid [D, H, W, J] the search reads; set a new one (with its graph) before each "
                    "forward to learn it")
      .def_property_readonly("box", &PyFastSnarf::box, "The VoxelBox the grid covers")
      .def(py::pickle([](const PyFastSnarf& d) { return d.state(); }, &PyFastSnarf::from_state));

  py::class_<PySnarf>(m, "SnarfDeformer",
                      "SNARF's deformer over a skinning MLP (softmax(20 logits)) whose parameters the caller optimises")
      .def(py::init<int64_t, const torch::Tensor&, int64_t, int64_t, const py::object&, int, double,
                    std::optional<double>>(),
           py::arg("num_bones"), py::arg("extent"), py::arg("hidden_dim") = 128, py::arg("hidden_layers") = 4,
           py::arg("start_bones") = py::none(), py::arg("max_iterations") = 50, py::arg("length_unit") = 1.0,
           py::arg("tolerance") = py::none(),
           "extent: canonical points [M, 3] whose bounding box the network's inputs are normalised to")
      .def("forward", &PySnarf::forward, py::arg("x_posed"), py::arg("bones"), py::call_guard<py::gil_scoped_release>(),
           "x_posed [B, N, 3], bones [B, J, 4, 4] -> (x_canonical [B, N, I, 3], valid [B, N, I]); exact implicit "
           "gradient to the points, the bones and the MLP")
      .def("deform", &PySnarf::deform, py::arg("x_canonical"), py::arg("bones"),
           py::call_guard<py::gil_scoped_release>(),
           "LBS of canonical points [B, N, 3] with the MLP's weights -> posed [B, N, 3]")
      .def("weights", &PySnarf::weights, py::arg("x_canonical"), "Skinning weights at canonical points [..., J]")
      .def("parameters", &PySnarf::parameters, "The MLP's parameters (tensors shared with the deformer)")
      .def("to", &PySnarf::to_dtype, py::arg("dtype"), "'float32' or 'float64' (gradcheck)");
}

}  // namespace fskin::python
