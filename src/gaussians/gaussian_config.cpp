#include "fskin/gaussians/gaussian_config.h"

#include <algorithm>
#include <filesystem>
#include <utility>

#include "fskin/core/error.h"
#include "fskin/engine/config_document.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/util/atomic_file.h"
#include "fskin/version.h"

namespace fskin {

using json = nlohmann::json;

namespace {

constexpr const char* kRunFormat = "fskin-gaussian-avatar-run";

const FixedKinds kFixedKinds = {
    {"/model/type", "gaussian-avatar"}, {"/optimizer/type", "adam"}, {"/schedule/type", "cosine-decay"}};

// Every option once: its path in the document and the member it reads and writes.
struct Field {
  const char* path;
  json (*read)(const GaussianTrainOptions&);
  void (*write)(GaussianTrainOptions&, const json&);
};

#define FSKIN_GAUSSIAN_FIELD(path, member)                                     \
  Field {                                                                      \
    path, [](const GaussianTrainOptions& o) -> json { return o.member; },      \
        [](GaussianTrainOptions& o, const json& v) { v.get_to(o.member); }     \
  }

const Field kFields[] = {
    FSKIN_GAUSSIAN_FIELD("/model/gaussians/initial", avatar.initial_gaussians),
    FSKIN_GAUSSIAN_FIELD("/model/gaussians/sh_degree", avatar.sh_degree),
    FSKIN_GAUSSIAN_FIELD("/model/gaussians/initial_opacity", avatar.initial_opacity),
    FSKIN_GAUSSIAN_FIELD("/model/gaussians/antialiased", avatar.antialiased),
    FSKIN_GAUSSIAN_FIELD("/model/gaussians/initial_thickness", avatar.initial_thickness),
    FSKIN_GAUSSIAN_FIELD("/model/gaussians/dilation", avatar.dilation),
    FSKIN_GAUSSIAN_FIELD("/model/shading", avatar.shading),
    FSKIN_GAUSSIAN_FIELD("/model/non_rigid/enabled", avatar.non_rigid),
    FSKIN_GAUSSIAN_FIELD("/model/non_rigid/frequencies", avatar.non_rigid_network.frequencies),
    FSKIN_GAUSSIAN_FIELD("/model/non_rigid/hidden", avatar.non_rigid_network.hidden),
    FSKIN_GAUSSIAN_FIELD("/model/appearance/dim", avatar.appearance.dim),
    FSKIN_GAUSSIAN_FIELD("/model/appearance/hidden", avatar.appearance.hidden),
    FSKIN_GAUSSIAN_FIELD("/model/skinning/source", avatar.skinning_source),
    FSKIN_GAUSSIAN_FIELD("/model/skinning/grid_resolution", avatar.skinning_grid_resolution),
    FSKIN_GAUSSIAN_FIELD("/model/skinning/learned", avatar.learned_skinning),
    FSKIN_GAUSSIAN_FIELD("/density/start", density.start),
    FSKIN_GAUSSIAN_FIELD("/density/stop_fraction", density.stop_fraction),
    FSKIN_GAUSSIAN_FIELD("/density/every", density.every),
    FSKIN_GAUSSIAN_FIELD("/density/gradient_threshold", density.gradient_threshold),
    FSKIN_GAUSSIAN_FIELD("/density/dense_fraction", density.dense_fraction),
    FSKIN_GAUSSIAN_FIELD("/density/min_opacity", density.min_opacity),
    FSKIN_GAUSSIAN_FIELD("/density/max_scale_fraction", density.max_scale_fraction),
    FSKIN_GAUSSIAN_FIELD("/density/max_scale_spacings", density.max_scale_spacings),
    FSKIN_GAUSSIAN_FIELD("/density/opacity_reset_every", density.opacity_reset_every),
    FSKIN_GAUSSIAN_FIELD("/density/max_gaussians", density.max_gaussians),
    FSKIN_GAUSSIAN_FIELD("/pose_refinement/enabled", refine_poses),
    FSKIN_GAUSSIAN_FIELD("/pose_refinement/learning_rate", pose_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/pose_refinement/translation_learning_rate", pose_translation_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/pose_refinement/regularizer", pose_regularizer),
    FSKIN_GAUSSIAN_FIELD("/pose_refinement/first_pass_steps", pose_first_pass_steps),
    FSKIN_GAUSSIAN_FIELD("/pose_refinement/second_pass_learning_rate", pose_second_pass_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/pose_refinement/fit_steps", pose_fit_steps),
    FSKIN_GAUSSIAN_FIELD("/pose_refinement/fit_rounds", pose_fit_rounds),
    FSKIN_GAUSSIAN_FIELD("/losses/ssim/weight", ssim_weight),
    FSKIN_GAUSSIAN_FIELD("/losses/mask/weight", mask_weight),
    FSKIN_GAUSSIAN_FIELD("/losses/skinning/weight", skinning_weight),
    FSKIN_GAUSSIAN_FIELD("/losses/non_rigid/weight", non_rigid_weight),
    FSKIN_GAUSSIAN_FIELD("/losses/surface_layer/weight", layer_weight),
    FSKIN_GAUSSIAN_FIELD("/losses/opacity/weight", opacity_weight),
    FSKIN_GAUSSIAN_FIELD("/losses/alpha_entropy/weight", alpha_entropy_weight),
    FSKIN_GAUSSIAN_FIELD("/losses/unseen_view/degrees", unseen_view_degrees),
    FSKIN_GAUSSIAN_FIELD("/losses/unseen_view/every", unseen_view_every),
    FSKIN_GAUSSIAN_FIELD("/losses/rig_silhouette/weight", rig_silhouette_weight),
    FSKIN_GAUSSIAN_FIELD("/optimizer/learning_rates/means", means_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/optimizer/learning_rates/scales", scales_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/optimizer/learning_rates/rotations", rotations_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/optimizer/learning_rates/opacity", opacity_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/optimizer/learning_rates/sh", sh_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/optimizer/learning_rates/skinning", skinning_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/optimizer/learning_rates/non_rigid", non_rigid_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/optimizer/learning_rates/shading", shading_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/optimizer/learning_rates/appearance", appearance_learning_rate),
    FSKIN_GAUSSIAN_FIELD("/schedule/decay_fraction", decay_fraction),
    FSKIN_GAUSSIAN_FIELD("/schedule/decay_factor", decay_factor),
    FSKIN_GAUSSIAN_FIELD("/data/path", data_dir),
    FSKIN_GAUSSIAN_FIELD("/data/crop_margin", crop_margin),
    FSKIN_GAUSSIAN_FIELD("/run/checkpoint_every", checkpoint_every),
    FSKIN_GAUSSIAN_FIELD("/run/log_every", log_every),
    FSKIN_GAUSSIAN_FIELD("/seed", seed),
    FSKIN_GAUSSIAN_FIELD("/steps", steps),
};
#undef FSKIN_GAUSSIAN_FIELD

}  // namespace

json gaussian_config_document(const GaussianTrainOptions& options) {
  return fields_document(options, kFields, kFixedKinds);
}

GaussianTrainOptions gaussian_options_from_document(const json& document, const GaussianTrainOptions& base,
                                                    const std::string& context) {
  return options_from_fields(document, base, kFields, kFixedKinds, context);
}

json gaussian_run_document(const GaussianTrainOptions& o) {
  GaussianTrainOptions recorded = o;
  recorded.data_dir = std::filesystem::absolute(o.data_dir).string();
  auto document = gaussian_config_document(recorded);
  document["format"] = kRunFormat;
  document["fskin_version"] = FSKIN_VERSION;
  return document;
}

GaussianTrainOptions read_gaussian_run_config(const std::string& path, const std::string& run_dir) {
  json document = read_json_document(path);
  FSKIN_CHECK(document.is_object() && document.contains("format") && document.at("format") == kRunFormat,
              "{}: not a Gaussian avatar run", path);
  GaussianTrainOptions base;
  base.out_dir = run_dir;
  base.data_dir = "(the run's dataset)";  // every run file names its own
  // Runs written before the skinning source existed read the grid.
  if (!document.contains(json::json_pointer("/model/skinning/source"))) base.avatar.skinning_source = "grid";
  // ... and those written before the dilation's compensation drew without it.
  if (!document.contains(json::json_pointer("/model/gaussians/antialiased"))) base.avatar.antialiased = false;
  // ... those written before disc-shaped starts began with spheres, and pruned by the size alone.
  if (!document.contains(json::json_pointer("/model/gaussians/initial_thickness"))) base.avatar.initial_thickness = 1;
  if (!document.contains(json::json_pointer("/density/max_scale_spacings"))) base.density.max_scale_spacings = 0;
  // ... those written before the dilation was a key drew with 3DGS's.
  if (!document.contains(json::json_pointer("/model/gaussians/dilation"))) base.avatar.dilation = 0.3;
  // ... and those written before the surface layer prior kept no anchors.
  if (!document.contains(json::json_pointer("/losses/surface_layer/weight"))) base.layer_weight = 0;
  // ... those written before the rig silhouette prior drew no rig silhouette.
  if (!document.contains(json::json_pointer("/losses/rig_silhouette/weight"))) base.rig_silhouette_weight = 0;
  // ... and those written before the unseen view's interval drew it on every step.
  if (!document.contains(json::json_pointer("/losses/unseen_view/every"))) base.unseen_view_every = 1;
  // ... and those written before training poses were fitted refined them in two passes.
  if (!document.contains(json::json_pointer("/pose_refinement/fit_steps"))) base.pose_fit_steps = 0;
  // ... and those written before the second round fitted them once.
  if (!document.contains(json::json_pointer("/pose_refinement/fit_rounds"))) base.pose_fit_rounds = 1;
  // ... and those written before the rig silhouette prior shared the unseen view kept its angle with the entropy's.
  const json::json_pointer old_degrees("/losses/alpha_entropy/degrees");
  if (document.is_object() && document.contains(old_degrees)) {
    document[json::json_pointer("/losses/unseen_view/degrees")] = document.at(old_degrees);
    document.at(json::json_pointer("/losses/alpha_entropy")).erase("degrees");
  }
  return gaussian_options_from_document(document, base, path);
}

GaussianTrainOptions configure_gaussian_options(const GaussianTrainOptions& base, const std::string& config_path,
                                                const std::vector<std::string>& settings) {
  GaussianTrainOptions options = base;
  const json::json_pointer silhouette("/losses/rig_silhouette/weight");
  bool silhouette_given = false;
  if (!config_path.empty()) {
    const json document = read_json_document(config_path);
    silhouette_given = silhouette_given || document.contains(silhouette);
    options = gaussian_options_from_document(document, options, config_path);
  }
  for (const auto& setting : settings) {
    const std::string context = "--set " + setting;
    const json overlay = assignment_overlay(setting, "--set");
    silhouette_given = silhouette_given || overlay.contains(silhouette);
    options = gaussian_options_from_document(overlay, options, context);
  }
  // A capture's mesh is a body model fitted to its photographs, not the
  // subject's surface: unless asked for, no rig silhouette prior, which would
  // draw the clothing in to the body (rig_silhouette_prior.h).
  if (!silhouette_given && image_dataset_mesh_is_fitted(options.data_dir)) options.rig_silhouette_weight = 0;
  return options;
}

}  // namespace fskin
