// The Python bindings of libfskin (`import fskin`): thin wrappers, no
// algorithm of their own. Tensors are the caller's torch tensors (the same
// LibTorch underneath), so results join the caller's autograd graph: the
// deformer's roots carry the implicit gradient (SNARF eq. 14 / Fast-SNARF
// eq. 17) to the posed points, the bone transforms and the skinning grid.
// fskin::Error becomes fskin.Error (a RuntimeError) with fskin's message.
#include <pybind11/stl.h>
#include <torch/extension.h>

#include <filesystem>
#include <optional>

#include <nlohmann/json.hpp>
#include "fskin/util/atomic_file.h"
#include "fskin/radiance/avatar_config.h"
#include "fskin/geometry/nearest_vertex.h"
#include "fskin/body/body_model.h"
#include "fskin/body/character.h"
#include "fskin/body/quadruped.h"
#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/data/dataset.h"
#include "fskin/data/dataset_builder.h"
#include "fskin/data/dataset_posing.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/pose_generators.h"
#include "fskin/data/pose_set.h"
#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/deformers/snarf_deformer.h"
#include "fskin/fields/mlp_skinning_field.h"
#include "fskin/fields/preset_skinning_field.h"
#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/geometry/character_size.h"
#include "fskin/geometry/voxel_box.h"
#include "fskin/invertible/pin.h"
#include "fskin/io/mesh_io.h"
#include "fskin/ops/hash_encoding.h"
#include "fskin/ops/pin_pass.h"
#include "fskin/ops/ray_compositing.h"
#include "fskin/radiance/avatar_evaluation.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/image_dataset_builder.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/inference/posed_meshing.h"
#include "fskin/inference/run_animation.h"
#include "fskin/inference/rigged_avatar.h"
#include "fskin/inference/run_evaluation.h"
#include "fskin/inference/trained_run.h"
#include "fskin/training/train_run.h"
#include "fskin/util/blas_kernels.h"
#include "fskin/util/blas_threads.h"
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

// A Fast-SNARF deformer over a voxel skinning grid the caller owns: a fixed
// grid, or one computed with a graph (a softmax of a voxel parameter, an MLP
// at the voxel centres) and set again before each search, so the roots'
// implicit gradient reaches what computed it.
class PyFastSnarf {
 public:
  PyFastSnarf(const torch::Tensor& grid_weights, const VoxelBox& box, const py::object& start_bones,
              int max_iterations, bool exact_gradient, double length_unit, std::optional<double> tolerance)
      : field_(std::make_shared<fskin::CallerGridSkinningField>(grid_weights, box)),
        deformer_(field_, options(box, start_bones, max_iterations, exact_gradient, length_unit, tolerance)),
        arguments_(py::make_tuple(start_bones, max_iterations, exact_gradient, length_unit, tolerance)) {}

  // pickle / copy.deepcopy: the grid (detached), the box and the constructor's search arguments.
  py::tuple state() const { return py::make_tuple(field_->grid_weights().detach(), field_->box(), arguments_); }
  static PyFastSnarf from_state(const py::tuple& state) {
    FSKIN_CHECK(state.size() == 3, "FastSnarfDeformer: a pickled state has 3 parts, got {}", state.size());
    const auto arguments = state[2].cast<py::tuple>();
    FSKIN_CHECK(arguments.size() == 5, "FastSnarfDeformer: pickled search arguments have 5 parts, got {}",
                arguments.size());
    return PyFastSnarf(state[0].cast<torch::Tensor>(), state[1].cast<VoxelBox>(), arguments[0],
                       arguments[1].cast<int>(), arguments[2].cast<bool>(), arguments[3].cast<double>(),
                       arguments[4].cast<std::optional<double>>());
  }

  std::tuple<torch::Tensor, torch::Tensor> forward(const torch::Tensor& x_posed, const torch::Tensor& bones) {
    const auto out = deformer_.forward(x_posed, bones);
    return {out.x_canonical, out.valid};
  }
  torch::Tensor deform(const torch::Tensor& x_canonical, const torch::Tensor& bones) {
    return deformer_.deform(x_canonical, bones);
  }
  torch::Tensor weights(const torch::Tensor& x_canonical) { return field_->weights(x_canonical); }
  torch::Tensor grid_weights() const { return field_->grid_weights(); }
  void set_grid_weights(const torch::Tensor& grid) { field_->set_grid(grid); }
  const VoxelBox& box() const { return field_->box(); }

 private:
  static fskin::DeformerOptions options(const VoxelBox& box, const py::object& start_bones, int max_iterations,
                                        bool exact_gradient, double length_unit, std::optional<double> tolerance) {
    box.validate("FastSnarfDeformer: box");
    auto o = search_options("FastSnarfDeformer", fskin::DeformerOptions::fast_snarf(), start_bones, max_iterations,
                            length_unit, tolerance);
    if (exact_gradient) o.gradient = fskin::GradientMode::Exact;
    return o;
  }
  std::shared_ptr<fskin::CallerGridSkinningField> field_;
  fskin::FastSnarfDeformer deformer_;
  py::tuple arguments_;  // start_bones, max_iterations, exact_gradient, length_unit, tolerance
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

// Poses [N, J, 3] (and root translations [N, 3]) as a PoseSet for a model's joints.
fskin::PoseSet pose_set(const torch::Tensor& poses, const std::optional<torch::Tensor>& trans,
                        const std::vector<std::string>& joint_names, const char* what) {
  fskin::expect_shape(poses, {-1, static_cast<int64_t>(joint_names.size()), 3}, what);
  fskin::PoseSet set;
  set.poses = poses.detach().to(torch::kCPU, torch::kFloat32).contiguous();
  set.trans = trans ? trans->detach().to(torch::kCPU, torch::kFloat32).contiguous() : torch::zeros({poses.size(0), 3});
  fskin::expect_shape(set.trans, {poses.size(0), 3}, what);
  set.joint_names = joint_names;
  return set;
}

py::dict frame_dict(const fskin::DatasetFrame& f) {
  py::dict d(py::arg("points") = f.points, py::arg("occupancy") = f.occupancy, py::arg("num_uniform") = f.num_uniform,
             py::arg("bone_transforms") = f.bone_transforms, py::arg("pose") = f.pose, py::arg("trans") = f.trans);
  if (f.vertices.defined()) {
    d["vertices"] = f.vertices;
    d["faces"] = f.faces;
  }
  return d;
}

// INS's pose-conditioned invertible network (INS eq. 13-14) driven by pose
// embeddings the caller computes: differentiable in the points, the embedding
// and its parameters (torch.optim on parameters()); fused() is the inference
// kernel (ops/pin_pass.h), no gradients.
class PyPin {
 public:
  PyPin(int64_t num_layers, int64_t embedding_dim, int64_t space_hidden_dim, int64_t space_layers,
        int64_t map_hidden_dim, int64_t map_hidden_layers, bool linear_output, double first_omega,
        double hidden_omega)
      : pin_(options(num_layers, embedding_dim, space_hidden_dim, space_layers, map_hidden_dim, map_hidden_layers,
                     linear_output, first_omega, hidden_omega)) {}

  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& embedding) {
    return pin_->forward_embedded(x, embedding);
  }
  torch::Tensor inverse(const torch::Tensor& y, const torch::Tensor& embedding) {
    return pin_->inverse_embedded(y, embedding);
  }
  torch::Tensor fused(const torch::Tensor& x, const torch::Tensor& embedding, bool inverse) {
    torch::NoGradGuard no_grad;
    return fskin::fused_pin_pass(*pin_, x, embedding, inverse);
  }
  std::vector<torch::Tensor> parameters() { return pin_->parameters(); }
  void to(const std::string& target) {
    if (target == "float32" || target == "float64") {
      pin_->to(target == "float64" ? torch::kFloat64 : torch::kFloat32);
      return;
    }
    pin_->to(fskin::parse_device(target, "Pin.to"));
  }

 private:
  static fskin::PinOptions options(int64_t num_layers, int64_t embedding_dim, int64_t space_hidden_dim,
                                   int64_t space_layers, int64_t map_hidden_dim, int64_t map_hidden_layers,
                                   bool linear_output, double first_omega, double hidden_omega) {
    fskin::PinOptions o;
    o.num_layers = num_layers;
    o.own_pose_encoder = false;
    o.coupling.embedding_dim = embedding_dim;
    o.coupling.space_hidden_dim = space_hidden_dim;
    o.coupling.space_layers = space_layers;
    o.coupling.space_linear_output = linear_output;
    o.coupling.first_omega = first_omega;
    o.coupling.hidden_omega = hidden_omega;
    o.coupling.map_hidden_dim = map_hidden_dim;
    o.coupling.map_hidden_layers = map_hidden_layers;
    o.validate();
    return o;
  }
  fskin::Pin pin_;
};

// A trained run (`fskin train`'s directory) for inference from Python: the
// same loading, meshing, re-posing and export as `fskin mesh`, `animate` and
// `export`, on the device the model was moved to. No gradients (inference).
class PyRun {
 public:
  PyRun(const std::string& dir, const std::string& data, const std::string& checkpoint, const std::string& device)
      : run_(fskin::TrainedRun::load(dir, data, fskin::CheckpointChoice::parse(checkpoint),
                                     fskin::parse_device(device, "Run.load: device"))) {}

  const std::string& method() const { return run_.config.method; }
  int64_t step() const { return run_.step; }
  const std::vector<std::string>& joint_names() const { return run_.skeleton.joint_names; }
  const std::vector<int64_t>& parents() const { return run_.skeleton.parents; }
  torch::Tensor canonical_joints() const { return run_.skeleton.joints; }
  torch::Tensor canonical_pose() const { return run_.canonical_pose; }
  std::string device() const { return fskin::module_device(*run_.model).str(); }

  // Axis-angle poses [N, J, 3] (and root translations [N, 3]) -> bones [N, J, 4, 4], as the dataset poses.
  torch::Tensor bone_transforms(const torch::Tensor& poses, const std::optional<torch::Tensor>& trans,
                                const std::string& body_model) const {
    fskin::expect_shape(poses, {-1, static_cast<int64_t>(run_.skeleton.parents.size()), 3}, "Run.bone_transforms: poses");
    fskin::PoseSet set;
    set.poses = poses.to(torch::kCPU, torch::kFloat32);
    set.trans = trans ? trans->to(torch::kCPU, torch::kFloat32) : torch::zeros({poses.size(0), 3});
    return fskin::DatasetPosing::load(run_.data_dir, body_model).bone_transforms(set, "Run.bone_transforms");
  }

  // The canonical surface (pose None) or the surface in one pose: (vertices [V, 3], faces [F, 3]).
  std::tuple<torch::Tensor, torch::Tensor> mesh(const std::optional<torch::Tensor>& pose,
                                                const std::optional<torch::Tensor>& trans, int64_t resolution,
                                                int64_t initial, bool largest_component, int64_t surface_steps) {
    auto options = meshing_options(resolution, initial, largest_component);
    FSKIN_CHECK(surface_steps >= 0 && surface_steps <= 64, "Run.mesh: surface_steps {} must be in 0..64", surface_steps);
    options.surface_steps = surface_steps;
    fskin::MeshingResult result;
    if (!pose) {
      result = fskin::mesh_canonical(*run_.model, run_.skeleton, run_.canonical_pose, options);
    } else {
      const auto p = pose->dim() == 2 ? pose->unsqueeze(0) : *pose;
      const auto t = trans ? std::optional<torch::Tensor>(trans->dim() == 1 ? trans->unsqueeze(0) : *trans) : std::nullopt;
      const auto bones = bone_transforms(p, t, "");
      FSKIN_CHECK(bones.size(0) == 1, "Run.mesh: one pose [J, 3], got {}", bones.size(0));
      result = fskin::mesh_posed(*run_.model, run_.skeleton, bones[0], p[0].to(torch::kFloat32), options);
    }
    return {result.mesh.vertices, result.mesh.faces};
  }

  // Canonical vertices [V, 3] moved into every pose of bones [N, J, 4, 4] -> [N, V, 3] (INS eq. 19;
  // for SNARF / Fast-SNARF the LBS of their learned weights).
  torch::Tensor repose(const torch::Tensor& vertices, const torch::Tensor& faces, const torch::Tensor& bones,
                       int64_t batch) {
    fskin::Mesh canonical{vertices.to(torch::kCPU, torch::kFloat32).contiguous(), faces.to(torch::kCPU, torch::kInt64), {}};
    return fskin::repose_vertices(*run_.model, canonical, bones, batch, /*progress=*/false);
  }

  // Occupancy logits of posed points [B, N, 3] in bones [B, J, 4, 4] with pose [B, J, 3] (the hard max
  // over candidates, as evaluation), on the host.
  torch::Tensor occupancy(const torch::Tensor& points, const torch::Tensor& bones, const torch::Tensor& pose) {
    torch::NoGradGuard no_grad;
    run_.model->train(false);
    run_.model->freeze_for_inference();
    const auto device = fskin::module_device(*run_.model);
    return run_.model
        ->predict(points.to(device, torch::kFloat32), bones.to(device, torch::kFloat32),
                  pose.to(device, torch::kFloat32), fskin::Aggregation::Max)
        .logits.cpu();
  }

  // `fskin animate RUN --poses`: every pose of poses [N, J, 3] (root translations [N, 3]) into `out`
  // (inference/run_animation.h); returns meshing.json's contents.
  std::string animate(const torch::Tensor& poses, const std::optional<torch::Tensor>& trans, const std::string& out,
                      const std::string& mode, int64_t resolution, int64_t initial, int64_t surface_steps,
                      bool largest_component, double fps, const std::string& body_model) {
    fskin::RunAnimationOptions options;
    FSKIN_CHECK(mode == "default" || mode == "repose" || mode == "per-pose",
                "Run.animate: mode must be \"default\", \"repose\" or \"per-pose\", got \"{}\"", mode);
    options.mode = mode == "repose"     ? fskin::RunAnimationMode::Repose
                   : mode == "per-pose" ? fskin::RunAnimationMode::PerPose
                                        : fskin::RunAnimationMode::Default;
    options.meshing = meshing_options(resolution, initial, largest_component);
    FSKIN_CHECK(surface_steps >= 0 && surface_steps <= 64, "Run.animate: surface_steps {} must be in 0..64",
                surface_steps);
    options.meshing.surface_steps = surface_steps;
    options.fps = fps;
    options.progress = false;
    const auto bones = bone_transforms(poses, trans, body_model);
    return fskin::animate_run(run_, poses.to(torch::kCPU, torch::kFloat32), bones, "Run.animate", out, options)
        .summary.dump();
  }

  // The canonical mesh with the learned skinning as a rigged glTF (`fskin export RUN`).
  void export_gltf(const std::string& path, const std::optional<torch::Tensor>& bones, double fps, int64_t influences,
                   int64_t resolution, int64_t initial) {
    const auto ext = std::filesystem::path(path).extension().string();
    FSKIN_CHECK(ext == ".glb" || ext == ".gltf", "{}: the output must end in .glb or .gltf", path);  // before meshing
    const auto canonical = fskin::mesh_canonical(*run_.model, run_.skeleton, run_.canonical_pose,
                                                 meshing_options(resolution, initial, true));
    auto avatar = fskin::rigged_avatar(*run_.model, run_.config.method, run_.skeleton, canonical.mesh,
                                       bones ? bones->to(torch::kCPU, torch::kFloat32) : torch::Tensor(), fps);
    avatar.influences = influences;
    fskin::write_skinned_gltf(path, avatar);
  }

 private:
  fskin::PosedMeshingOptions meshing_options(int64_t resolution, int64_t initial, bool largest_component) const {
    fskin::PosedMeshingOptions o;
    o.mise = fskin::MiseOptions::resolutions(initial, resolution);
    o.mise.batch_size = run_.config.eval_chunk_points;
    o.largest_component = largest_component;
    return o;
  }
  fskin::TrainedRun run_;
};

}  // namespace

PYBIND11_MODULE(_fskin, m) {
  m.doc() = "fskin: differentiable forward skinning (SNARF, Fast-SNARF, INS) in C++, from Python";
  m.attr("__version__") = FSKIN_VERSION;
  py::register_exception<fskin::Error>(m, "Error", PyExc_RuntimeError);

  py::class_<BodyModel>(m, "BodyModel",
                        "An SMPL-format body model: template mesh, skinning weights, skeleton (any joints)")
      .def_static("load", &BodyModel::load, py::arg("path"), "Read a model .npz (SMPL files, fskin's own, imports)")
      .def(py::pickle(
          [](const BodyModel& b) {
            const auto& d = b.data();
            const auto optional = [](const torch::Tensor& t) { return t.defined() ? py::cast(t) : py::none(); };
            py::dict state;
            state["v_template"] = d.v_template;
            state["faces"] = d.faces;
            state["weights"] = d.weights;
            state["J_regressor"] = optional(d.J_regressor);
            state["rest_joints"] = optional(d.rest_joints);
            state["parents"] = d.parents;
            state["joint_names"] = d.joint_names;
            state["shapedirs"] = optional(d.shapedirs);
            state["posedirs"] = optional(d.posedirs);
            state["canonical_pose"] = optional(d.canonical_pose);
            return state;
          },
          [](const py::dict& state) {
            const auto tensor = [&](const char* key) {
              FSKIN_CHECK(state.contains(key), "BodyModel: a pickled state lacks '{}'", key);
              const py::object value = state[key];
              return value.is_none() ? torch::Tensor() : value.cast<torch::Tensor>();
            };
            fskin::BodyModelData d;
            d.v_template = tensor("v_template");
            d.faces = tensor("faces");
            d.weights = tensor("weights");
            d.J_regressor = tensor("J_regressor");
            d.rest_joints = tensor("rest_joints");
            d.shapedirs = tensor("shapedirs");
            d.posedirs = tensor("posedirs");
            d.canonical_pose = tensor("canonical_pose");
            FSKIN_CHECK(state.contains("parents") && state.contains("joint_names"),
                        "BodyModel: a pickled state lacks its skeleton");
            d.parents = state["parents"].cast<std::vector<int64_t>>();
            d.joint_names = state["joint_names"].cast<std::vector<std::string>>();
            return BodyModel(std::move(d), "BodyModel (unpickled)");
          }))
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
         const std::vector<std::string>& settings, const std::string& config, bool full, bool resume, bool progress,
         const std::string& device) {
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
        request.device = device;
        fskin::TrainRunResult run;
        {
          py::gil_scoped_release no_gil;
          const fskin::SingleThreadedBlasScope blas;  // as `fskin train` runs
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
      py::arg("resume") = false, py::arg("progress") = false, py::arg("device") = "cpu",
      "Train a run on a dataset directory (`fskin data build`) into `out`, as `fskin train` does; settings are "
      "key=value config overrides. Returns the losses, steps and time.");

  m.def(
      "evaluate",
      [](const std::string& run, const std::string& split, const std::string& data, const std::string& checkpoint,
         int64_t max_frames, bool write_json, const std::string& device) {
        fskin::RunEvaluationRequest request;
        request.run = run;
        request.split = split;
        request.data = data;
        request.checkpoint = checkpoint;
        request.max_frames = max_frames;
        request.progress = false;
        request.write_json = write_json;
        request.device = device;
        fskin::RunEvaluation result;
        {
          py::gil_scoped_release no_gil;
          const fskin::SingleThreadedBlasScope blas;  // as `fskin eval` runs
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
      py::arg("max_frames") = -1, py::arg("write_json") = false, py::arg("device") = "cpu",
      "IoU_bbox / IoU_surf of a trained run on a split, as `fskin eval` computes them");

  m.def(
      "training_poses",
      [](const BodyModel& body, int64_t sequences, int64_t frames, uint64_t seed) {
        const fskin::TrainingPoseOptions options{sequences, frames, seed};
        return fskin::make_training_poses(body.data().joint_names, options).poses;
      },
      py::arg("body"), py::arg("sequences") = 10, py::arg("frames") = 30, py::arg("seed") = 0,
      "Natural motions within moderate joint ranges, as `fskin poses train`: [sequences * frames, J, 3]");
  m.def(
      "ood_poses",
      [](const BodyModel& body, int64_t count, uint64_t seed) {
        const fskin::OodPoseOptions options{count, seed};
        return fskin::make_ood_poses(body.data().joint_names, options).poses;
      },
      py::arg("body"), py::arg("count") = 50, py::arg("seed") = 0,
      "Extreme poses outside the training ranges, as `fskin poses ood`: [count, J, 3]");
  m.def(
      "build_dataset",
      [](const std::string& model_path, const torch::Tensor& poses, const std::string& out,
         const std::optional<torch::Tensor>& trans, const std::optional<torch::Tensor>& ood_poses, int64_t points,
         uint64_t seed, const std::string& canonical_pose, bool progress) {
        const auto model = BodyModel::load(model_path);
        const auto& names = model.data().joint_names;
        const auto train = pose_set(poses, trans, names, "build_dataset: poses");
        const auto ood = ood_poses ? pose_set(*ood_poses, std::nullopt, names, "build_dataset: ood_poses") : fskin::PoseSet{};
        FSKIN_CHECK(points >= 2, "build_dataset: points {} must be >= 2", points);
        fskin::DatasetBuildOptions options;
        options.out_dir = out;
        options.model_source = std::filesystem::absolute(model_path).string();
        options.poses_source = "(python)";
        options.ood_poses_source = ood_poses ? "(python)" : "";
        options.sampling.uniform_points = points / 2;
        options.sampling.surface_points = points - points / 2;
        options.seed = seed;
        options.canonical_pose = canonical_pose;
        options.progress = progress;
        fskin::DatasetBuildSummary summary;
        {
          py::gil_scoped_release no_gil;
          summary = fskin::build_dataset(model, train, ood, options);
        }
        return py::dict(py::arg("frames") = summary.frames_written, py::arg("skipped") = summary.frames_skipped,
                        py::arg("train") = summary.train, py::arg("val") = summary.val,
                        py::arg("test_within") = summary.test_within, py::arg("test_ood") = summary.test_ood);
      },
      py::arg("model"), py::arg("poses"), py::arg("out"), py::arg("trans") = py::none(),
      py::arg("ood_poses") = py::none(), py::arg("points") = 50000, py::arg("seed") = 0,
      py::arg("canonical_pose") = "default", py::arg("progress") = false,
      "A dataset directory as `fskin data build` writes it, from a model file and poses [N, J, 3] (ood_poses: "
      "the test_ood split); needs Embree (built_with_embree)");
  m.def(
      "write_mesh",
      [](const std::string& path, const torch::Tensor& vertices, const torch::Tensor& faces,
         const std::optional<torch::Tensor>& colors) {
        // Casts below would silently drop imaginary parts or round fractional indices.
        FSKIN_CHECK(vertices.is_floating_point(), "{}: vertices must be real floating point, got {}", path,
                    c10::toString(vertices.scalar_type()));
        FSKIN_CHECK(!faces.is_floating_point() && !faces.is_complex() && faces.scalar_type() != torch::kBool,
                    "{}: faces must be integer vertex indices, got {}", path, c10::toString(faces.scalar_type()));
        fskin::Mesh mesh{vertices.detach().to(torch::kCPU, torch::kFloat32).contiguous(),
                         faces.to(torch::kCPU, torch::kInt64).contiguous(),
                         colors ? colors->to(torch::kCPU, torch::kUInt8).contiguous() : torch::Tensor()};
        mesh.validate(path);
        fskin::io::write_mesh(path, mesh);
      },
      py::arg("path"), py::arg("vertices"), py::arg("faces"), py::arg("colors") = py::none(),
      "Write a mesh (vertices [V, 3], faces [F, 3], colours [V, 3] uint8) as .ply or .obj");
  m.def(
      "nearest_vertices",
      [](const torch::Tensor& points, const torch::Tensor& vertices) {
        const auto nearest = fskin::nearest_vertices(points, vertices);
        return py::make_tuple(nearest.index, nearest.distance);
      },
      py::arg("points"), py::arg("vertices"),
      "The nearest vertex of each point (k-d tree): points [Q, 3], vertices [V, 3] -> (index [Q] int64, "
      "distance [Q] float32)");
  m.def(
      "read_mesh",
      [](const std::string& path) {
        const auto mesh = fskin::io::read_mesh(path);
        return py::make_tuple(mesh.vertices, mesh.faces);
      },
      py::arg("path"), "Read a .ply or .obj mesh: (vertices [V, 3], faces [F, 3])");
  // Radiance-field ops and avatars from images (src/radiance; docs/image_datasets.md).
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
      "build_image_dataset",
      [](const std::string& model_path, const torch::Tensor& poses, const std::string& out,
         const std::optional<torch::Tensor>& held_out_poses, int size, int views, int held_out_views,
         int novel_view_frames, bool monocular, bool progress) {
        const auto model = BodyModel::load(model_path);
        const auto as_set = [&](const torch::Tensor& p) {
          fskin::PoseSet set;
          set.poses = p.detach().to(torch::kCPU, torch::kFloat32).contiguous();
          set.trans = torch::zeros({set.poses.size(0), 3});
          set.joint_names = model.data().joint_names;
          return set;
        };
        fskin::ImageDatasetOptions options;
        options.out_dir = out;
        options.width = options.height = size;
        options.training_views = views;
        options.held_out_views = held_out_views;
        options.novel_view_frames = novel_view_frames;
        options.monocular = monocular;
        options.progress = progress;
        options.model_source = std::filesystem::absolute(model_path).string();
        options.poses_source = "python";
        options.ood_poses_source = held_out_poses ? "python" : "";
        py::gil_scoped_release release;
        return fskin::build_image_dataset(model, as_set(poses), held_out_poses ? as_set(*held_out_poses) : fskin::PoseSet{},
                                          options)
            .to_string();
      },
      py::arg("model"), py::arg("poses"), py::arg("out"), py::arg("held_out_poses") = py::none(),
      py::arg("size") = 256, py::arg("views") = 4, py::arg("held_out_views") = 4, py::arg("novel_view_frames") = 8,
      py::arg("monocular") = false, py::arg("progress") = false,
      "An image dataset as `fskin data images` writes it (PeopleSnapshot's layout), from a model file and poses "
      "[N, J, 3]; returns its summary");
  m.def(
      "train_avatar",
      [](const std::string& data, const std::string& out, int64_t steps, int64_t rays_per_step, bool resume,
         uint64_t seed, bool progress, const std::vector<std::string>& settings, const std::string& config) {
        fskin::AvatarTrainOptions options;
        options.data_dir = data;
        options.out_dir = out;
        options.steps = steps;
        options.rays_per_step = rays_per_step;
        options.resume = resume;
        options.seed = seed;
        options.progress = progress;
        // As `fskin avatar train`: the arguments, then the config file, then each setting.
        if (!config.empty()) {
          nlohmann::json document;
          try {
            document = nlohmann::json::parse(fskin::read_file(config));
          } catch (const nlohmann::json::exception& e) {
            fskin::fail("{}: {}", config, e.what());
          }
          options = fskin::avatar_options_from_document(document, options, config);
        }
        for (const auto& setting : settings) fskin::set_avatar_option(options, setting);
        fskin::AvatarTrainSummary summary;
        {
          py::gil_scoped_release release;
          const fskin::SingleThreadedBlasScope blas;  // as `fskin avatar train` runs
          summary = fskin::train_avatar(options);
        }
        return py::dict(py::arg("first_step") = summary.first_step, py::arg("last_step") = summary.last_step,
                        py::arg("seconds") = summary.seconds, py::arg("loss") = summary.final_loss,
                        py::arg("batch_psnr") = summary.final_psnr);
      },
      py::arg("data"), py::arg("out"), py::arg("steps") = 2000, py::arg("rays_per_step") = 4096,
      py::arg("resume") = false, py::arg("seed") = 0, py::arg("progress") = false,
      py::arg("settings") = std::vector<std::string>{}, py::arg("config") = "",
      "`fskin avatar train`: a radiance field through the Fast-SNARF deformer from an image dataset; every option "
      "of the avatar's config (radiance/avatar_config.h) through settings ['model.occupancy_grid.every=50', ...] "
      "and a config file");
  m.def(
      "evaluate_avatar",
      [](const std::string& run, const std::string& split, const std::string& data, int64_t max_images) {
        py::gil_scoped_release release;
        auto trained = fskin::TrainedAvatar::load(run);
        const fskin::ImageDataset dataset(data.empty() ? trained.options.data_dir : data);
        const auto scores = fskin::evaluate_avatar(trained.avatar, dataset, split, max_images, false);
        py::gil_scoped_acquire acquire;
        return py::module_::import("json").attr("loads")(scores.to_json());
      },
      py::arg("run"), py::arg("split") = "novel_view", py::arg("data") = "", py::arg("max_images") = 0,
      "`fskin avatar eval`: PSNR / SSIM per image of a split, as a dict (mean_psnr, mean_ssim, frames, ...)");
  m.def(
      "render_avatar",
      [](const std::string& run, const torch::Tensor& bones, const torch::Tensor& intrinsic,
         const torch::Tensor& extrinsic, int width, int height, std::vector<double> background) {
        FSKIN_CHECK(background.size() == 3, "render_avatar: background must have 3 components");
        fskin::PinholeCamera camera;
        camera.width = width;
        camera.height = height;
        const auto k = intrinsic.to(torch::kCPU, torch::kFloat64).contiguous();
        const auto e = extrinsic.to(torch::kCPU, torch::kFloat64).contiguous();
        fskin::expect_shape(k, {3, 3}, "render_avatar: intrinsic");
        fskin::expect_shape(e, {4, 4}, "render_avatar: extrinsic");
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) camera.intrinsic(r, c) = k[r][c].item<double>();
        for (int r = 0; r < 4; ++r)
          for (int c = 0; c < 4; ++c) camera.extrinsic(r, c) = e[r][c].item<double>();
        py::gil_scoped_release release;
        auto trained = fskin::TrainedAvatar::load(run);
        const auto frame = trained.avatar->pose(bones.detach().to(torch::kCPU, torch::kFloat32));
        const auto [rgb, opacity] =
            trained.avatar->render_image(frame, camera, {background[0], background[1], background[2]});
        py::gil_scoped_acquire acquire;
        return py::make_tuple(rgb, opacity);
      },
      py::arg("run"), py::arg("bones"), py::arg("intrinsic"), py::arg("extrinsic"), py::arg("width"),
      py::arg("height"), py::arg("background") = std::vector<double>{1.0, 1.0, 1.0},
      "Render a trained avatar in bones [J, 4, 4] (canonical -> posed) by an OpenCV camera: (rgb [H, W, 3], "
      "opacity [H, W])");
  m.def("openblas_core", &fskin::openblas_core, "The kernels OpenBLAS runs (openblas_get_corename), or None");
  m.def("recommended_openblas_core", &fskin::openblas_core_setting,
        "The OPENBLAS_CORETYPE to start Python with where OpenBLAS fell back to its SSE3 kernels on a CPU with "
        "AVX2 / AVX-512 (the fskin CLI restarts itself with it), or None");
  m.def("built_with_embree", &fskin::inside_test_available, "Whether datasets can be built (Embree's inside test)");
  m.def("built_with_cuda", &fskin::built_with_cuda, "Whether the CUDA kernels are linked (device='cuda' works)");

  py::class_<fskin::Dataset>(m, "Dataset", "One split of a dataset directory: frames of posed points and occupancy")
      .def(py::init([](const std::string& dir, const std::string& split, bool with_meshes) {
             return fskin::Dataset::load(dir, split, with_meshes);
           }),
           py::arg("dir"), py::arg("split") = "train", py::arg("with_meshes") = false,
           py::call_guard<py::gil_scoped_release>(), "split: train, val, test_within or test_ood")
      .def("__len__", &fskin::Dataset::size)
      .def(
          "__getitem__",
          [](const fskin::Dataset& d, int64_t i) {
            if (i < 0) i += d.size();
            if (i < 0 || i >= d.size()) throw py::index_error("Dataset: frame index out of range");
            return frame_dict(d.frame(i));
          },
          py::arg("index"),
          "A frame: points [N, 3], occupancy [N], num_uniform (the first points are uniform in the box, the rest "
          "near the surface), bone_transforms [J, 4, 4], pose [J, 3], trans [3] (and vertices, faces)")
      .def_property_readonly("split", &fskin::Dataset::split)
      .def_property_readonly("joint_names", &fskin::Dataset::joint_names)
      .def_property_readonly("parents", &fskin::Dataset::parents)
      .def_property_readonly("canonical", [](const fskin::Dataset& d) { return frame_dict(d.canonical()); });

  py::class_<PyPin>(m, "Pin",
                    "INS's pose-conditioned invertible network (eq. 13-14) over pose embeddings [B, E] the caller "
                    "computes; identity at initialisation")
      .def(py::init<int64_t, int64_t, int64_t, int64_t, int64_t, int64_t, bool, double, double>(),
           py::arg("num_layers") = 6, py::arg("embedding_dim") = 16, py::arg("space_hidden_dim") = 32,
           py::arg("space_layers") = 2, py::arg("map_hidden_dim") = 8, py::arg("map_hidden_layers") = 2,
           py::arg("linear_output") = true, py::arg("first_omega") = 30.0, py::arg("hidden_omega") = 30.0)
      .def("forward", &PyPin::forward, py::arg("x"), py::arg("embedding"), py::call_guard<py::gil_scoped_release>(),
           "PIN(x [B, N, 3], z [B, E]) -> [B, N, 3], differentiable")
      .def("inverse", &PyPin::inverse, py::arg("y"), py::arg("embedding"), py::call_guard<py::gil_scoped_release>(),
           "PIN^-1(y, z), differentiable")
      .def("fused", &PyPin::fused, py::arg("x"), py::arg("embedding"), py::arg("inverse") = false,
           py::call_guard<py::gil_scoped_release>(),
           "The fused inference kernel (float32, no gradients): the same map in one pass per point")
      .def("parameters", &PyPin::parameters)
      .def("to", &PyPin::to, py::arg("target"), "'float32', 'float64' or a device ('cpu', 'cuda')");

  py::class_<PyRun>(m, "Run",
                    "A trained run directory for inference: meshing, re-posing, occupancy and glTF export, as "
                    "`fskin mesh`, `animate` and `export` do them")
      .def(py::init<const std::string&, const std::string&, const std::string&, const std::string&>(), py::arg("dir"),
           py::arg("data") = "", py::arg("checkpoint") = "latest", py::arg("device") = "cpu",
           py::call_guard<py::gil_scoped_release>(),
           "data: the dataset (default: the one the run trained on); checkpoint: latest, best or a step; device: "
           "cpu, cuda or cuda:N")
      .def_property_readonly("method", &PyRun::method)
      .def_property_readonly("step", &PyRun::step)
      .def_property_readonly("joint_names", &PyRun::joint_names)
      .def_property_readonly("parents", &PyRun::parents)
      .def_property_readonly("canonical_joints", &PyRun::canonical_joints, "[J, 3]")
      .def_property_readonly("canonical_pose", &PyRun::canonical_pose, "[J, 3] axis-angle")
      .def_property_readonly("device", &PyRun::device)
      .def("bone_transforms", &PyRun::bone_transforms, py::arg("poses"), py::arg("trans") = py::none(),
           py::arg("body_model") = "", py::call_guard<py::gil_scoped_release>(),
           "Axis-angle poses [N, J, 3] (root translations [N, 3]) -> bones [N, J, 4, 4] canonical -> posed, as the "
           "dataset computes them")
      .def("mesh", &PyRun::mesh, py::arg("pose") = py::none(), py::arg("trans") = py::none(),
           py::arg("resolution") = 128, py::arg("initial") = 32, py::arg("largest_component") = false,
           py::arg("surface_steps") = fskin::PosedMeshingOptions{}.surface_steps, py::call_guard<py::gil_scoped_release>(),
           "MISE surface of the canonical shape (pose None) or of one pose [J, 3]: (vertices [V, 3], faces [F, 3]); "
           "surface_steps model evaluations per vertex put it on the learned surface (0: marching cubes' linear "
           "interpolation, which leaves terraces)")
      .def("repose", &PyRun::repose, py::arg("vertices"), py::arg("faces"), py::arg("bones"), py::arg("batch") = 8,
           py::call_guard<py::gil_scoped_release>(),
           "Canonical mesh vertices [V, 3] into every pose of bones [N, J, 4, 4] -> [N, V, 3], keeping the faces")
      .def(
          "animate",
          [](PyRun& run, const torch::Tensor& poses, const std::string& out, const std::optional<torch::Tensor>& trans,
             const std::string& mode, int64_t resolution, int64_t initial, int64_t surface_steps,
             bool largest_component, double fps, const std::string& body_model) {
            std::string summary;
            {
              py::gil_scoped_release release;
              summary = run.animate(poses, trans, out, mode, resolution, initial, surface_steps, largest_component,
                                    fps, body_model);
            }
            return py::module_::import("json").attr("loads")(summary);
          },
          py::arg("poses"), py::arg("out"), py::arg("trans") = py::none(), py::arg("mode") = "default",
          py::arg("resolution") = 128, py::arg("initial") = 32,
          py::arg("surface_steps") = fskin::PosedMeshingOptions{}.surface_steps, py::arg("largest_component") = false,
          py::arg("fps") = 30.0, py::arg("body_model") = "",
          "Every pose of poses [N, J, 3] (trans [N, 3]) into directory `out`, as `fskin animate RUN --poses`: "
          "mode 'repose' (canonical.ply, frame_*.ply, animation.glb), 'per-pose' (one MISE mesh per pose) or "
          "'default' (repose for ins runs, per-pose for the others); returns meshing.json as a dict")
      .def("occupancy", &PyRun::occupancy, py::arg("points"), py::arg("bones"), py::arg("pose"),
           py::call_guard<py::gil_scoped_release>(),
           "Occupancy logits [B, N] of posed points [B, N, 3] (bones [B, J, 4, 4], pose [B, J, 3])")
      .def("export_gltf", &PyRun::export_gltf, py::arg("path"), py::arg("bones") = py::none(), py::arg("fps") = 30.0,
           py::arg("influences") = 4, py::arg("resolution") = 128, py::arg("initial") = 32,
           py::call_guard<py::gil_scoped_release>(),
           "The canonical mesh with the learned skinning weights as a rigged .glb/.gltf, animated by bones "
           "[T, J, 4, 4] when given (forward-skinning methods)");

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
           "Canonical positions of the voxel centres [D, H, W, 3]")
      .def("__repr__",
           [](const VoxelBox& b) {
             return fmt::format("VoxelBox(shape=({}, {}, {}), offset=({:g}, {:g}, {:g}), scale=({:g}, {:g}, {:g}))",
                                b.shape.depth, b.shape.height, b.shape.width, b.offset[0], b.offset[1], b.offset[2],
                                b.scale[0], b.scale[1], b.scale[2]);
           })
      .def(py::pickle(
          [](const VoxelBox& b) {
            return py::make_tuple(b.offset, b.scale, py::make_tuple(b.shape.depth, b.shape.height, b.shape.width));
          },
          [](const py::tuple& state) {
            FSKIN_CHECK(state.size() == 3, "VoxelBox: a pickled state has 3 parts, got {}", state.size());
            VoxelBox b;
            b.offset = state[0].cast<std::array<double, 3>>();
            b.scale = state[1].cast<std::array<double, 3>>();
            const auto shape = state[2].cast<std::tuple<int64_t, int64_t, int64_t>>();
            b.shape = fskin::GridShape{std::get<0>(shape), std::get<1>(shape), std::get<2>(shape)};
            b.validate("VoxelBox (unpickled)");
            return b;
          }));

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
                          "Fast-SNARF's deformer over a voxel skinning grid [D, H, W, J] (weights summing to 1); a grid "
                          "that requires grad receives the roots' implicit gradient")
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
      .def("weights", &PyFastSnarf::weights, py::arg("x_canonical"), "Skinning weights at canonical points [..., J]")
      .def_property("grid_weights", &PyFastSnarf::grid_weights, &PyFastSnarf::set_grid_weights,
                    "The skinning grid [D, H, W, J] the search reads; set a new one (with its graph) before each "
                    "forward to learn it")
      .def_property_readonly("box", &PyFastSnarf::box)
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
           py::call_guard<py::gil_scoped_release>())
      .def("weights", &PySnarf::weights, py::arg("x_canonical"))
      .def("parameters", &PySnarf::parameters, "The MLP's parameters (tensors shared with the deformer)")
      .def("to", &PySnarf::to_dtype, py::arg("dtype"), "'float32' or 'float64' (gradcheck)");
}
