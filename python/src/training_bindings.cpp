// Datasets of posed points, training and evaluation, as `fskin data build`, `train` and `eval`.
#include "bindings.h"

#include "fskin/body/body_model.h"
#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/data/dataset.h"
#include "fskin/data/dataset_builder.h"
#include "fskin/data/pose_set.h"
#include "fskin/engine/stop_signal.h"
#include "fskin/inference/run_evaluation.h"
#include "fskin/training/train_run.h"
#include "fskin/util/blas_threads.h"

namespace fskin::python {
namespace {

py::dict frame_dict(const fskin::DatasetFrame& f) {
  py::dict d(py::arg("points") = f.points, py::arg("occupancy") = f.occupancy, py::arg("num_uniform") = f.num_uniform,
             py::arg("bone_transforms") = f.bone_transforms, py::arg("pose") = f.pose, py::arg("trans") = f.trans);
  if (f.vertices.defined()) {
    d["vertices"] = f.vertices;
    d["faces"] = f.faces;
  }
  return d;
}

}  // namespace

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

void bind_training(py::module_& m) {
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
      "build_dataset",
      [](const std::string& model_path, const torch::Tensor& poses, const std::string& out,
         const std::optional<torch::Tensor>& trans, const std::optional<torch::Tensor>& ood_poses, int64_t points,
         uint64_t seed, const std::string& canonical_pose, double thin_surface_share, double thin_thickness,
         bool progress) {
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
        options.thin_surface_share = thin_surface_share;
        options.thin_thickness = thin_thickness;
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
      py::arg("canonical_pose") = "default",
      py::arg("thin_surface_share") = fskin::DatasetBuildOptions{}.thin_surface_share,
      py::arg("thin_thickness") = fskin::DatasetBuildOptions{}.thin_thickness, py::arg("progress") = false,
      "A dataset directory as `fskin data build` writes it, from a model file and poses [N, J, 3] (ood_poses: "
      "the test_ood split; thin_surface_share: the share of the training frames' near-surface points drawn on "
      "parts thinner than thin_thickness x the character's size); needs Embree (built_with_embree)");
  py::class_<fskin::Dataset>(m, "Dataset", "One split of a dataset directory: frames of posed points and occupancy")
      .def(py::init([](const std::string& dir, const std::string& split, bool with_meshes) {
             return fskin::Dataset::load(dir, split, with_meshes);
           }),
           py::arg("dir"), py::arg("split") = "train", py::arg("with_meshes") = false,
           py::call_guard<py::gil_scoped_release>(), "split: train, val, test_within or test_ood")
      .def("__len__", &fskin::Dataset::size, "The split's number of frames")
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
      .def_property_readonly("split", &fskin::Dataset::split, "train, val, test_within or test_ood")
      .def_property_readonly("joint_names", &fskin::Dataset::joint_names, "The skeleton's J joint names")
      .def_property_readonly("parents", &fskin::Dataset::parents, "Each joint's parent index (-1 for the root)")
      .def_property_readonly(
          "canonical", [](const fskin::Dataset& d) { return frame_dict(d.canonical()); },
          "The canonical frame (the rest pose's points, occupancy and bones), as a frame dict");
}

}  // namespace fskin::python
