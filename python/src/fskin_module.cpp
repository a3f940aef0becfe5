// The Python bindings of libfskin (`import fskin`): thin wrappers, no
// algorithm of their own. Tensors are the caller's torch tensors (the same
// LibTorch underneath), so results join the caller's autograd graph: the
// deformer's roots carry the implicit gradient (SNARF eq. 14 / Fast-SNARF
// eq. 17) to the posed points, the bone transforms and the skinning grid.
// fskin::Error becomes fskin.Error (a RuntimeError) with fskin's message.
#include <torch/extension.h>

#include <optional>

#include "fskin/body/body_model.h"
#include "fskin/body/character.h"
#include "fskin/body/quadruped.h"
#include "fskin/core/error.h"
#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/deformers/snarf_deformer.h"
#include "fskin/fields/mlp_skinning_field.h"
#include "fskin/fields/preset_skinning_field.h"
#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/geometry/character_size.h"
#include "fskin/geometry/voxel_box.h"
#include "fskin/inference/run_evaluation.h"
#include "fskin/training/train_run.h"
#include "fskin/version.h"

namespace py = pybind11;
using fskin::BodyModel;
using fskin::VoxelBox;

namespace {

torch::Tensor or_undefined(const std::optional<torch::Tensor>& t) { return t ? *t : torch::Tensor(); }

fskin::StartBones parse_start_bones(const py::object& value) {
  if (value.is_none()) return fskin::StartBones::all();
  if (py::isinstance<py::str>(value)) {
    const auto text = value.cast<std::string>();
    if (text == "all") return fskin::StartBones::all();
    fskin::fail("start_bones: '{}' is not 'all', an int (automatic: that many starts per point) or a list of bones",
                text);
  }
  if (py::isinstance<py::int_>(value)) return fskin::StartBones::automatic(value.cast<int64_t>());
  return fskin::StartBones::subset(value.cast<std::vector<int64_t>>());
}

// The search options both deformers take from Python: the paper's settings
// scaled to the character, then the caller's start bones, iterations and
// convergence tolerance (a residual norm).
fskin::DeformerOptions search_options(const char* who, fskin::DeformerOptions paper, const py::object& start_bones,
                                      int max_iterations, double length_unit, std::optional<double> tolerance) {
  FSKIN_CHECK(length_unit > 0 && std::isfinite(length_unit), "{}: length_unit {} must be > 0", who, length_unit);
  FSKIN_CHECK(max_iterations >= 1, "{}: max_iterations {} must be >= 1", who, max_iterations);
  auto o = paper.scaled(length_unit);
  o.start_bones = parse_start_bones(start_bones);
  o.max_iterations = max_iterations;
  if (tolerance) {
    FSKIN_CHECK(*tolerance > 0 && std::isfinite(*tolerance), "{}: tolerance {} must be > 0", who, *tolerance);
    o.converge_sq = *tolerance * *tolerance;
  }
  return o;
}

// A Fast-SNARF deformer over a voxel skinning grid the caller owns.
class PyFastSnarf {
 public:
  PyFastSnarf(const torch::Tensor& grid_weights, const VoxelBox& box, const py::object& start_bones,
              int max_iterations, bool exact_gradient, double length_unit, std::optional<double> tolerance)
      : field_(std::make_shared<fskin::FrozenSkinningField>(grid_weights, box)),
        deformer_(field_, options(box, start_bones, max_iterations, exact_gradient, length_unit, tolerance)) {}

  std::tuple<torch::Tensor, torch::Tensor> forward(const torch::Tensor& x_posed, const torch::Tensor& bones) {
    const auto out = deformer_.forward(x_posed, bones);
    return {out.x_canonical, out.valid};
  }
  torch::Tensor deform(const torch::Tensor& x_canonical, const torch::Tensor& bones) {
    return deformer_.deform(x_canonical, bones);
  }
  torch::Tensor weights(const torch::Tensor& x_canonical) { return field_->weights(x_canonical); }

 private:
  static fskin::DeformerOptions options(const VoxelBox& box, const py::object& start_bones, int max_iterations,
                                        bool exact_gradient, double length_unit, std::optional<double> tolerance) {
    box.validate("FastSnarfDeformer: box");
    auto o = search_options("FastSnarfDeformer", fskin::DeformerOptions::fast_snarf(), start_bones, max_iterations,
                            length_unit, tolerance);
    if (exact_gradient) o.gradient = fskin::GradientMode::Exact;
    return o;
  }
  std::shared_ptr<fskin::FrozenSkinningField> field_;
  fskin::FastSnarfDeformer deformer_;
};

// SNARF's deformer over fskin's skinning MLP, whose parameters the caller
// optimises (torch.optim on `parameters()`): the roots' implicit gradient
// reaches them (SNARF eq. 14).
class PySnarf {
 public:
  PySnarf(int64_t num_bones, const torch::Tensor& extent, int64_t hidden_dim, int64_t hidden_layers,
          const py::object& start_bones, int max_iterations, double length_unit, std::optional<double> tolerance)
      : field_(std::make_shared<fskin::MlpSkinningField>(field_options(num_bones, extent, hidden_dim, hidden_layers))),
        deformer_(field_, options(start_bones, max_iterations, length_unit, tolerance)) {}

  std::tuple<torch::Tensor, torch::Tensor> forward(const torch::Tensor& x_posed, const torch::Tensor& bones) {
    const auto out = deformer_.forward(x_posed, bones);
    return {out.x_canonical, out.valid};
  }
  torch::Tensor deform(const torch::Tensor& x_canonical, const torch::Tensor& bones) {
    return deformer_.deform(x_canonical, bones);
  }
  torch::Tensor weights(const torch::Tensor& x_canonical) { return field_->weights(x_canonical); }
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
  std::shared_ptr<fskin::MlpSkinningField> field_;
  fskin::SnarfDeformer deformer_;
};

}  // namespace

PYBIND11_MODULE(_fskin, m) {
  m.doc() = "fskin: differentiable forward skinning (SNARF, Fast-SNARF, INS) in C++, from Python";
  m.attr("__version__") = FSKIN_VERSION;
  py::register_exception<fskin::Error>(m, "Error", PyExc_RuntimeError);

  py::class_<BodyModel>(m, "BodyModel",
                        "An SMPL-format body model: template mesh, skinning weights, skeleton (any joints)")
      .def_static("load", &BodyModel::load, py::arg("path"), "Read a model .npz (SMPL files, fskin's own, imports)")
      .def("save", &BodyModel::save, py::arg("path"))
      .def_property_readonly("num_joints", &BodyModel::num_joints)
      .def_property_readonly("num_vertices", &BodyModel::num_vertices)
      .def_property_readonly("joint_names", [](const BodyModel& b) { return b.data().joint_names; })
      .def_property_readonly("parents", [](const BodyModel& b) { return b.data().parents; })
      .def_property_readonly("v_template", [](const BodyModel& b) { return b.data().v_template; })
      .def_property_readonly("faces", [](const BodyModel& b) { return b.data().faces; })
      .def_property_readonly("weights", [](const BodyModel& b) { return b.data().weights; })
      .def_property_readonly("rest_joints", [](const BodyModel& b) { return b.skeleton().rest_joints; })
      .def(
          "forward",
          [](const BodyModel& b, const torch::Tensor& pose, std::optional<torch::Tensor> betas,
             std::optional<torch::Tensor> trans, std::optional<torch::Tensor> joint_translations) {
            const auto posed = b.pose(pose, or_undefined(betas), or_undefined(trans), or_undefined(joint_translations));
            return py::make_tuple(posed.vertices, posed.joints, posed.bone_transforms);
          },
          py::arg("pose"), py::arg("betas") = py::none(), py::arg("trans") = py::none(),
          py::arg("joint_translations") = py::none(),
          "pose [B, J, 3] axis-angle -> (vertices [B, V, 3], joints [B, J, 3], bone transforms [B, J, 4, 4], rest -> "
          "posed)");

  m.def(
      "humanoid",
      [](double height, uint64_t seed, int64_t resolution) {
        fskin::CharacterOptions o;
        o.height = height;
        o.seed = seed;
        o.resolution = resolution;
        return fskin::make_character_model(o);
      },
      py::arg("height") = 1.7, py::arg("seed") = 0, py::arg("resolution") = 110,
      "The built-in 24-joint humanoid (SMPL's joints) as a BodyModel");
  m.def(
      "quadruped",
      [](double length, uint64_t seed, int64_t resolution) {
        fskin::QuadrupedOptions o;
        o.length = length;
        o.seed = seed;
        o.resolution = resolution;
        return fskin::make_quadruped_model(o);
      },
      py::arg("length") = 1.5, py::arg("seed") = 0, py::arg("resolution") = 150,
      "The built-in 33-joint quadruped as a BodyModel");
  m.def(
      "character_size", [](const torch::Tensor& points) { return fskin::character_size(points); }, py::arg("points"),
      "Longest side of the points' bounding box (the unit every default length follows)");

  m.def(
      "train",
      [](const std::string& data, const std::string& out, int64_t steps, const std::string& method,
         const std::vector<std::string>& settings, const std::string& config, bool full, bool resume, bool progress) {
        fskin::TrainRunRequest request;
        request.data = data;
        request.out = out;
        request.steps = steps;
        request.method = method;
        request.settings = settings;
        request.config_path = config;
        request.full = full;
        request.resume = resume;
        request.progress = progress;
        fskin::TrainRunResult run;
        {
          py::gil_scoped_release no_gil;
          const fskin::StopSignal stop;  // Ctrl-C: finish the step, checkpoint, return
          request.stop = &stop;
          run = fskin::train_run(request);
        }
        const auto& r = run.result;
        return py::dict(py::arg("method") = run.config.method, py::arg("frames") = run.frames,
                        py::arg("first_step") = r.first_step, py::arg("last_step") = r.last_step,
                        py::arg("first_loss") = r.first_loss, py::arg("last_loss") = r.last_loss,
                        py::arg("seconds") = r.seconds, py::arg("stopped") = r.stopped,
                        py::arg("best_step") = r.best_step, py::arg("best_iou_surf") = r.best_iou_surf);
      },
      py::arg("data"), py::arg("out"), py::arg("steps") = -1, py::arg("method") = "",
      py::arg("settings") = std::vector<std::string>{}, py::arg("config") = "", py::arg("full") = false,
      py::arg("resume") = false, py::arg("progress") = false,
      "Train a run on a dataset directory (`fskin data build`) into `out`, as `fskin train` does; settings are "
      "key=value config overrides. Returns the losses, steps and time.");

  m.def(
      "evaluate",
      [](const std::string& run, const std::string& split, const std::string& data, const std::string& checkpoint,
         int64_t max_frames, bool write_json) {
        fskin::RunEvaluationRequest request;
        request.run = run;
        request.split = split;
        request.data = data;
        request.checkpoint = checkpoint;
        request.max_frames = max_frames;
        request.progress = false;
        request.write_json = write_json;
        fskin::RunEvaluation result;
        {
          py::gil_scoped_release no_gil;
          result = fskin::evaluate_run(request);
        }
        py::list frames;
        for (const auto& f : result.metrics.frames)
          frames.append(py::dict(py::arg("frame") = f.frame, py::arg("iou_bbox") = f.iou_bbox,
                                 py::arg("iou_surf") = f.iou_surf, py::arg("mean_valid") = f.mean_valid));
        return py::dict(py::arg("method") = result.method, py::arg("step") = result.step,
                        py::arg("checkpoint") = result.checkpoint, py::arg("mean_iou_bbox") = result.metrics.mean_iou_bbox,
                        py::arg("mean_iou_surf") = result.metrics.mean_iou_surf, py::arg("frames") = frames);
      },
      py::arg("run"), py::arg("split") = "test-within", py::arg("data") = "", py::arg("checkpoint") = "latest",
      py::arg("max_frames") = -1, py::arg("write_json") = false,
      "IoU_bbox / IoU_surf of a trained run on a split, as `fskin eval` computes them");

  py::class_<VoxelBox>(m, "VoxelBox", "The canonical box of a voxel skinning grid (docs/conventions.md)")
      .def_static(
          "fit",
          [](const torch::Tensor& points, int64_t longest_voxels, double padding) {
            return VoxelBox::fit(points, longest_voxels, padding);
          },
          py::arg("points"), py::arg("longest_voxels") = 32, py::arg("padding") = 0.05,
          "Box around points [N, 3]: `longest_voxels` along the longest side, near-cubic voxels")
      .def_static(
          "around",
          [](const torch::Tensor& points, std::tuple<int64_t, int64_t, int64_t> shape, double padding, double z_factor) {
            return VoxelBox::around(points, fskin::GridShape{std::get<0>(shape), std::get<1>(shape), std::get<2>(shape)},
                                    padding, z_factor);
          },
          py::arg("points"), py::arg("shape"), py::arg("padding") = 1.2, py::arg("z_factor") = 4.0,
          "The papers' box: offset -centre, scale 1 / (max extent / 2 * padding), times z_factor along z; "
          "shape (D, H, W)")
      .def_property_readonly("shape",
                             [](const VoxelBox& b) {
                               return py::make_tuple(b.shape.depth, b.shape.height, b.shape.width);
                             })
      .def("contains", &VoxelBox::contains, py::arg("points"))
      .def("voxel_centres", [](const VoxelBox& b) { return b.voxel_centres(); },
           "Canonical positions of the voxel centres [D, H, W, 3]");

  m.def(
      "diffuse_weights_to_grid",
      [](const torch::Tensor& vertices, const torch::Tensor& weights, const VoxelBox& box, int smoothing_iterations,
         double surface_band) {
        fskin::WeightDiffusionOptions o;
        o.smoothing_iterations = smoothing_iterations;
        o.surface_band = surface_band;
        return fskin::diffuse_weights_to_grid(vertices, weights, box, o)->grid_weights();
      },
      py::arg("vertices"), py::arg("weights"), py::arg("box"), py::arg("smoothing_iterations") = 10,
      py::arg("surface_band") = 1.0,
      "A body model's skinning weights [V, J] at its vertices [V, 3] as a voxel grid [D, H, W, J] over box: nearest "
      "vertex, then smoothing passes off the surface (fields/preset_skinning_field.h)");

  py::class_<PyFastSnarf>(m, "FastSnarfDeformer",
                          "Fast-SNARF's deformer over a voxel skinning grid [D, H, W, J] (weights summing to 1)")
      .def(py::init<const torch::Tensor&, const VoxelBox&, const py::object&, int, bool, double,
                    std::optional<double>>(),
           py::arg("grid_weights"), py::arg("box"), py::arg("start_bones") = py::none(), py::arg("max_iterations") = 10,
           py::arg("exact_gradient") = false, py::arg("length_unit") = 1.0, py::arg("tolerance") = py::none(),
           "start_bones: None/'all', an int k (per point, the k bones with the largest weight), or a list of bones; "
           "length_unit scales the thresholds for characters not 1.7 m long (character_size / 1.7); tolerance: "
           "the residual norm a root converges to (default Fast-SNARF's 1e-4 times length_unit)")
      // The search runs LibTorch's autograd (exact gradients) and threads: without the GIL.
      .def("forward", &PyFastSnarf::forward, py::arg("x_posed"), py::arg("bones"),
           py::call_guard<py::gil_scoped_release>(),
           "x_posed [B, N, 3], bones [B, J, 4, 4] canonical -> posed: (x_canonical [B, N, I, 3], valid [B, N, I])")
      .def("deform", &PyFastSnarf::deform, py::arg("x_canonical"), py::arg("bones"),
           py::call_guard<py::gil_scoped_release>(),
           "LBS of canonical points [B, N, 3] with the grid's weights -> posed [B, N, 3]")
      .def("weights", &PyFastSnarf::weights, py::arg("x_canonical"), "Skinning weights at canonical points [..., J]");

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
           py::call_guard<py::gil_scoped_release>())
      .def("weights", &PySnarf::weights, py::arg("x_canonical"))
      .def("parameters", &PySnarf::parameters, "The MLP's parameters (tensors shared with the deformer)")
      .def("to", &PySnarf::to_dtype, py::arg("dtype"), "'float32' or 'float64' (gradcheck)");
}
