#include "fskin/gaussians/gaussian_export.h"

#include <torch/torch.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <sstream>

#include <fmt/format.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/gaussians/gaussian_gltf.h"
#include "fskin/util/atomic_file.h"

namespace fskin {
namespace {

void append_floats(std::string& out, const torch::Tensor& rows) {
  const auto data = rows.to(torch::kFloat32).contiguous();
  const auto* begin = reinterpret_cast<const char*>(data.data_ptr<float>());
  out.append(begin, static_cast<size_t>(data.numel()) * sizeof(float));
}

}  // namespace

void write_gaussian_ply(const std::string& path, GaussianAvatarImpl& avatar, const Skeleton& skeleton,
                        const torch::Tensor& bones, double fps) {
  torch::NoGradGuard no_grad;
  skeleton.validate(path + ": skeleton");
  const int64_t n = avatar.size(), joints = skeleton.num_joints();
  const auto weights = avatar.skinning_weights();
  FSKIN_CHECK(weights.size(1) == joints, "{}: the avatar has {} bones and the skeleton {} joints", path,
              weights.size(1), joints);
  if (bones.defined()) {
    expect_shape(bones, {-1, joints, 4, 4}, path + ": bone transforms");
    expect_finite(bones, path + ": bone transforms");
  }
  FSKIN_CHECK(std::isfinite(fps) && fps > 0, "{}: fps must be positive, got {}", path, fps);
  const int64_t rest = avatar.sh_rest().size(1);

  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\n";
  header << "comment fskin Gaussian avatar: 3DGS vertex layout plus skinning (docs/gaussian_avatars.md)\n";
  for (int64_t j = 0; j < joints; ++j) {
    std::string name = skeleton.joint_names[static_cast<size_t>(j)];
    for (char& c : name)
      if (c == '\n' || c == '\r') c = ' ';
    header << "comment joint_name " << j << " " << name << "\n";
  }
  if (bones.defined()) header << fmt::format("comment fps {}\n", fps);
  if (avatar.options().antialiased) header << "comment antialiased\n";
  header << fmt::format("comment dilation {}\n", avatar.options().dilation);
  header << "element vertex " << n << "\n";
  for (const char* p : {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"})
    header << "property float " << p << "\n";
  for (int64_t k = 0; k < 3 * rest; ++k) header << "property float f_rest_" << k << "\n";
  for (const char* p : {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"})
    header << "property float " << p << "\n";
  for (int64_t j = 0; j < joints; ++j) header << "property float weight_" << j << "\n";
  header << "element joint " << joints << "\nproperty int parent\nproperty float x\nproperty float y\nproperty float z\n";
  if (bones.defined()) {
    header << "element bone_transform " << bones.size(0) * joints << "\n";
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) header << "property float m" << r << c << "\n";
  }
  header << "end_header\n";

  // 3DGS stores the higher-degree coefficients channel by channel: [N, 3, K - 1].
  const auto sh = avatar.average_appearance_sh();
  const auto vertex_rows = torch::cat({avatar.means().detach(), torch::zeros({n, 3}),
                                       sh.select(1, 0).reshape({n, 3}),
                                       sh.narrow(1, 1, rest).transpose(1, 2).reshape({n, 3 * rest}),
                                       avatar.opacity_logits().detach().unsqueeze(1), avatar.log_scales().detach(),
                                       avatar.rotations().detach(), weights.detach()},
                                      1);
  std::string bytes = header.str();
  append_floats(bytes, vertex_rows);
  const auto rest_joints = skeleton.rest_joints.to(torch::kFloat32).contiguous();
  for (int64_t j = 0; j < joints; ++j) {
    const int32_t parent = static_cast<int32_t>(skeleton.parents[static_cast<size_t>(j)]);
    bytes.append(reinterpret_cast<const char*>(&parent), sizeof(parent));
    append_floats(bytes, rest_joints[j]);
  }
  if (bones.defined()) append_floats(bytes, bones.reshape({-1, 16}));
  write_file_atomically(path, bytes);
}

void write_gaussian_avatar_file(const std::string& path, GaussianAvatarImpl& avatar, const Skeleton& skeleton,
                                const GaussianExportOptions& options) {
  const auto extension = std::filesystem::path(path).extension().string();
  if (extension == ".ply") {
    write_gaussian_ply(path, avatar, skeleton, options.bones, options.fps);
    return;
  }
  FSKIN_CHECK(extension == ".glb" || extension == ".gltf",
              "{}: a Gaussian avatar is written as a 3DGS .ply or a glTF .glb / .gltf: name it so", path);
  write_gaussian_gltf(path, avatar, skeleton, options);
}

}  // namespace fskin
