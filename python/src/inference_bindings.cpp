// A trained run for inference: meshing, re-posing, occupancy, animation and glTF export.
#include "bindings.h"

#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/data/dataset_posing.h"
#include "fskin/data/pose_set.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/inference/posed_meshing.h"
#include "fskin/inference/rigged_avatar.h"
#include "fskin/inference/run_animation.h"
#include "fskin/inference/trained_run.h"

namespace fskin::python {
namespace {

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

void bind_inference(py::module_& m) {
  py::class_<PyRun>(m, "Run",
                    "A trained run directory for inference: meshing, re-posing, occupancy and glTF export, as "
                    "`fskin mesh`, `animate` and `export` do them")
      .def(py::init<const std::string&, const std::string&, const std::string&, const std::string&>(), py::arg("dir"),
           py::arg("data") = "", py::arg("checkpoint") = "latest", py::arg("device") = "cpu",
           py::call_guard<py::gil_scoped_release>(),
           "data: the dataset (default: the one the run trained on); checkpoint: latest, best or a step; device: "
           "cpu, cuda or cuda:N")
      .def_property_readonly("method", &PyRun::method, "snarf, fast-snarf, ins or a baseline")
      .def_property_readonly("step", &PyRun::step, "The loaded checkpoint's training step")
      .def_property_readonly("joint_names", &PyRun::joint_names, "The skeleton's J joint names")
      .def_property_readonly("parents", &PyRun::parents, "Each joint's parent index (-1 for the root)")
      .def_property_readonly("canonical_joints", &PyRun::canonical_joints, "[J, 3]")
      .def_property_readonly("canonical_pose", &PyRun::canonical_pose, "[J, 3] axis-angle")
      .def_property_readonly("device", &PyRun::device, "The device the model runs on")
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
}

}  // namespace fskin::python
