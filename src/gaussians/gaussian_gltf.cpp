#include "fskin/gaussians/gaussian_gltf.h"

#include <torch/torch.h>

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/gaussians/spherical_harmonics.h"
#include "export/gltf_skin.h"
#include "io/gltf_file.h"

namespace fskin {
namespace {

constexpr const char* kExtension = "KHR_gaussian_splatting";

// A float vertex attribute without the min/max that only positions need.
int add_attribute(gltf::BufferWriter& writer, const torch::Tensor& values, int type) {
  return writer.add_floats(values, type, TINYGLTF_TARGET_ARRAY_BUFFER, /*bounds=*/false);
}

}  // namespace

void write_gaussian_gltf(const std::string& path, GaussianAvatarImpl& avatar, const Skeleton& skeleton,
                         const GaussianExportOptions& options) {
  torch::NoGradGuard no_grad;
  skeleton.validate(path + ": skeleton");
  const bool binary = gltf::is_binary_path(path);
  const int64_t joints = skeleton.num_joints();
  FSKIN_CHECK(joints <= 65535, "{}: {} joints do not fit glTF's 16-bit joint indices", path, joints);
  const auto weights = avatar.skinning_weights().detach();
  FSKIN_CHECK(weights.size(1) == joints, "{}: the avatar has {} bones and the skeleton {} joints", path,
              weights.size(1), joints);
  FSKIN_CHECK(options.influences >= 0, "{}: influences {} must be >= 0 (0: every joint)", path, options.influences);
  FSKIN_CHECK(std::isfinite(options.fps) && options.fps >= 1e-3 && options.fps <= 1e5,
              "{}: fps {} is not a frame rate (1e-3 to 1e5 expected)", path, options.fps);
  if (options.bones.defined()) {
    expect_shape(options.bones, {-1, joints, 4, 4}, path + ": bone transforms");
    expect_finite(options.bones, path + ": bone transforms");
  }

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "fskin";
  model.extensionsUsed.push_back(kExtension);
  gltf::BufferWriter writer(model);
  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_POINTS;
  const std::string prefix = std::string(kExtension) + ":";
  primitive.attributes["POSITION"] =
      writer.add_floats(avatar.means().detach(), TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER);
  // fskin's quaternions are (w, x, y, z) and unnormalised; the extension's are unit (x, y, z, w).
  const auto q = avatar.rotations().detach();
  const auto unit = q / q.norm(2, 1, true).clamp_min(1e-12);
  primitive.attributes[prefix + "ROTATION"] =
      add_attribute(writer, torch::cat({unit.narrow(1, 1, 3), unit.narrow(1, 0, 1)}, 1), TINYGLTF_TYPE_VEC4);
  primitive.attributes[prefix + "SCALE"] =
      add_attribute(writer, torch::exp(avatar.log_scales().detach()), TINYGLTF_TYPE_VEC3);
  const auto opacity = torch::sigmoid(avatar.opacity_logits().detach());
  primitive.attributes[prefix + "OPACITY"] = add_attribute(writer, opacity.unsqueeze(1), TINYGLTF_TYPE_SCALAR);
  // Coefficient k of degree l is column l^2 + k of fskin's [N, (degree + 1)^2, 3] (3DGS's order).
  const auto sh = avatar.average_appearance_sh();
  for (int64_t l = 0; l <= avatar.sh_degree(); ++l) {
    for (int64_t k = 0; k <= 2 * l; ++k) {
      primitive.attributes[prefix + "SH_DEGREE_" + std::to_string(l) + "_COEF_" + std::to_string(k)] =
          add_attribute(writer, sh.select(1, l * l + k), TINYGLTF_TYPE_VEC3);
    }
  }
  const auto base_color = spherical_harmonics_dc_color(sh.select(1, 0)).clamp(0, 1);
  primitive.attributes["COLOR_0"] =
      add_attribute(writer, torch::cat({base_color, opacity.unsqueeze(1)}, 1), TINYGLTF_TYPE_VEC4);
  gltf::add_skin_influences(model, writer, primitive, weights, options.influences);
  tinygltf::Value::Object extension;
  extension["kernel"] = tinygltf::Value(std::string("ellipse"));
  extension["colorSpace"] = tinygltf::Value(std::string("srgb_rec709_display"));
  extension["projection"] = tinygltf::Value(std::string("perspective"));
  extension["sortingMethod"] = tinygltf::Value(std::string("cameraDistance"));
  primitive.extensions[kExtension] = tinygltf::Value(extension);
  tinygltf::Value::Object fskin_extras;
  fskin_extras["antialiased"] = tinygltf::Value(avatar.options().antialiased);
  fskin_extras["dilation"] = tinygltf::Value(avatar.options().dilation);
  fskin_extras["sh_space"] = tinygltf::Value(std::string("canonical"));
  tinygltf::Value::Object extras;
  extras["fskin"] = tinygltf::Value(fskin_extras);
  primitive.extras = tinygltf::Value(extras);
  tinygltf::Mesh mesh;
  mesh.name = "gaussian_avatar";
  mesh.primitives.push_back(primitive);
  model.meshes.push_back(mesh);

  gltf::add_skinned_node(model, writer, skeleton, 0, "gaussian_avatar");
  if (options.bones.defined() && options.bones.size(0) > 0) {
    const auto animation = animation_from_bones(skeleton, options.bones);
    gltf::add_joint_animation(model, writer, skeleton, animation, options.fps, options.animation_name);
  }
  gltf::save(path, model, binary);
}

}  // namespace fskin
