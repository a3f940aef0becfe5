// Body models, the built-in characters and the pose generators.
#include "bindings.h"

#include "fskin/body/body_model.h"
#include "fskin/body/character.h"
#include "fskin/body/quadruped.h"
#include "fskin/core/error.h"
#include "fskin/data/lowpoly_character.h"
#include "fskin/data/pose_generators.h"
#include "fskin/geometry/character_size.h"

namespace fskin::python {

void bind_body(py::module_& m) {
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
      .def("save", &BodyModel::save, py::arg("path"), "Write the model as fskin's .npz (BodyModel.load reads it)")
      .def_property_readonly("num_joints", &BodyModel::num_joints, "J, the skeleton's joints (bones)")
      .def_property_readonly("num_vertices", &BodyModel::num_vertices, "V, the template's vertices")
      .def_property_readonly(
          "joint_names", [](const BodyModel& b) { return b.data().joint_names; }, "The J joint names, in order")
      .def_property_readonly(
          "parents", [](const BodyModel& b) { return b.data().parents; }, "Each joint's parent index (-1 for the root)")
      .def_property_readonly(
          "v_template", [](const BodyModel& b) { return b.data().v_template; }, "Template vertices [V, 3] at rest")
      .def_property_readonly(
          "faces", [](const BodyModel& b) { return b.data().faces; }, "Triangles [F, 3] (vertex indices)")
      .def_property_readonly(
          "weights", [](const BodyModel& b) { return b.data().weights; }, "Skinning weights [V, J], rows summing to 1")
      .def_property_readonly(
          "rest_joints", [](const BodyModel& b) { return b.skeleton().rest_joints; }, "Joint positions [J, 3] at rest")
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
      "lowpoly_character",
      [](const std::string& kind, uint64_t seed, double size, double variation) {
        fskin::LowPolyOptions o;
        o.kind = fskin::parse_lowpoly_kind(kind);
        o.seed = seed;
        o.size = size;
        o.variation = variation;
        auto character = fskin::make_lowpoly_character(o);
        const auto& clips = character.clips;
        py::dict animation(py::arg("poses") = clips.poses, py::arg("trans") = clips.trans,
                           py::arg("clip_names") = clips.clip_names, py::arg("clip_starts") = clips.clip_starts);
        return py::make_tuple(BodyModel(std::move(character.model), "built-in " + kind), animation);
      },
      py::arg("kind") = "lowpoly-humanoid", py::arg("seed") = 0, py::arg("size") = 0.0, py::arg("variation") = 0.05,
      "A built-in character like real game assets (`fskin character --kind lowpoly-humanoid|lowpoly-animal`): "
      "faceted, thin flat parts, painted weights; returns (BodyModel, clips {poses [N, J, 3], trans [N, 3], "
      "clip_names, clip_starts}). size: height or nose-to-tail length (0: 1.8 / 0.9)");
  m.def(
      "character_size", [](const torch::Tensor& points) { return fskin::character_size(points); }, py::arg("points"),
      "Longest side of the points' bounding box (the unit every default length follows)");
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
}

}  // namespace fskin::python
