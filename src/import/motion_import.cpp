#include "fskin/import/motion_import.h"

#include <torch/torch.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "fskin/body/smpl_skeleton.h"
#include "fskin/core/error.h"
#include "fskin/io/npz.h"
#include "fskin/skeleton/rotations.h"
#include "fskin/util/atomic_file.h"

namespace fskin {
namespace {

// More joints than any motion-capture skeleton has.
constexpr size_t kMostBvhJoints = 10'000;
// Rotation channels beyond 100 turns are corrupt values, not motion.
constexpr double kLargestRotationDegrees = 36'000;
// Root positions beyond this many skeleton sizes are corrupt, not motion.
constexpr double kFarthestRootInSizes = 1e4;

struct BvhJoint {
  std::string name;
  int parent = -1;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  std::vector<std::string> channels;  // e.g. Xposition, Zrotation
  int first_channel = 0;              // column in a MOTION line
};

// Hand-written: BVH is a small whitespace-separated format with no Debian library.
class BvhReader {
 public:
  explicit BvhReader(const std::string& path) : path_(path), text_(read_file(path)), in_(text_) {
    text_begin_ = text_.data();
    text_size_ = text_.size();
  }

  std::string word() {
    std::string w;
    FSKIN_CHECK(static_cast<bool>(in_ >> w), "{}: unexpected end of file", path_);
    return w;
  }
  void expect(const std::string& what) {
    const auto w = word();
    FSKIN_CHECK(w == what, "{}: expected '{}', found '{}'", path_, what, w);
  }
  double number() { return parse_number(word()); }
  double parse_number(const std::string& w) const {
    try {
      size_t used = 0;
      const double v = std::stod(w, &used);
      FSKIN_CHECK(used == w.size() && std::isfinite(v), "{}: '{}' is not a finite number", path_, w);
      return v;
    } catch (const std::logic_error&) {
      fail("{}: '{}' is not a number", path_, w);
    }
  }

  // ROOT name { OFFSET x y z CHANNELS n ... children }, walked with a stack
  // of open joints (no recursion: a hierarchy may nest as deep as the file
  // is long), at most kMostBvhJoints.
  void hierarchy(int& channel_count) {
    std::vector<int> open;
    open_joint(-1, channel_count, open);
    while (!open.empty()) {
      const auto w = word();
      if (w == "}") {
        open.pop_back();
      } else if (w == "JOINT") {
        open_joint(open.back(), channel_count, open);
      } else if (w == "End") {
        expect("Site");
        expect("{");
        expect("OFFSET");
        for (int a = 0; a < 3; ++a) number();
        expect("}");
      } else {
        fail("{}: unexpected '{}' in joint '{}'", path_, w, joints[open.back()].name);
      }
    }
  }

  void open_joint(int parent, int& channel_count, std::vector<int>& open) {
    FSKIN_CHECK(joints.size() < kMostBvhJoints, "{}: more than {} joints; not a skeleton fskin reads", path_,
                kMostBvhJoints);
    BvhJoint j;
    j.name = word();
    j.parent = parent;
    FSKIN_CHECK(names_.insert(j.name).second, "{}: two joints are named '{}'; joint names must be unique", path_,
                j.name);
    expect("{");
    expect("OFFSET");
    for (int a = 0; a < 3; ++a) j.offset[a] = number();
    expect("CHANNELS");
    const double n = number();
    FSKIN_CHECK(n >= 0 && n <= 6 && n == std::floor(n), "{}: joint '{}' has {} channels", path_, j.name, n);
    for (int c = 0; c < static_cast<int>(n); ++c) {
      j.channels.push_back(word());
      static const std::vector<std::string> known = {"Xposition", "Yposition", "Zposition",
                                                     "Xrotation", "Yrotation", "Zrotation"};
      FSKIN_CHECK(std::find(known.begin(), known.end(), j.channels.back()) != known.end(),
                  "{}: joint '{}' has an unknown channel '{}'", path_, j.name, j.channels.back());
    }
    j.first_channel = channel_count;
    channel_count += static_cast<int>(j.channels.size());
    open.push_back(static_cast<int>(joints.size()));
    joints.push_back(std::move(j));
  }

  void read() {
    expect("HIERARCHY");
    expect("ROOT");
    int channels = 0;
    hierarchy(channels);
    FSKIN_CHECK(channels >= 1, "{}: the hierarchy has no channels, so its motion moves nothing", path_);
    FSKIN_CHECK(word() == "MOTION", "{}: expected MOTION after the hierarchy (one ROOT only)", path_);
    expect("Frames:");
    const double frames = number();
    FSKIN_CHECK(frames >= 1 && frames == std::floor(frames), "{}: 'Frames: {}' must be a positive count", path_, frames);
    expect("Frame");
    expect("Time:");
    frame_time = number();
    FSKIN_CHECK(frame_time >= 1e-6 && frame_time <= 1e3, "{}: Frame Time {} s is not a frame interval (1 us to 1000 s)",
                path_, frame_time);
    // Each value takes at least two bytes ("0 "): a count the rest of the
    // file cannot hold is refused before anything is allocated.
    // tellg is -1 once a read has hit the end of the text (a file cut after
    // Frame Time): then nothing follows.
    const std::streamoff read_to = in_.tellg();
    const size_t position = read_to < 0 ? text_size_ : std::min(static_cast<size_t>(read_to), text_size_);
    const double bytes_left = static_cast<double>(text_size_ - position);
    FSKIN_CHECK(frames * channels <= bytes_left / 2 + channels,
                "{}: 'Frames: {:.0f}' of {} channels needs at least {:.3g} bytes, but {:.0f} follow", path_, frames,
                channels, 2 * frames * channels, bytes_left);
    num_channels = channels;
    num_frames = static_cast<int64_t>(frames);
    // One line per frame with exactly one value per channel, as Frames: says.
    int64_t line_number = 1 + std::count(text_begin_, text_begin_ + position, '\n');
    std::string line;
    std::getline(in_, line);  // the rest of the Frame Time line
    FSKIN_CHECK(line.find_first_not_of(" \t\r") == std::string::npos, "{}:{}: unexpected '{}' after Frame Time", path_,
                line_number, line);
    values.reserve(static_cast<size_t>(num_frames) * channels);
    int64_t frame = 0;
    while (std::getline(in_, line)) {
      ++line_number;
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      FSKIN_CHECK(frame < num_frames, "{}:{}: a motion line beyond the {} frames 'Frames:' declares", path_,
                  line_number, num_frames);
      std::istringstream fields(line);
      int count = 0;
      for (std::string w; fields >> w; ++count) {
        FSKIN_CHECK(count < channels, "{}:{}: frame {} has more than the hierarchy's {} channel values", path_,
                    line_number, frame, channels);
        values.push_back(parse_number(w));
      }
      FSKIN_CHECK(count == channels, "{}:{}: frame {} has {} values for the hierarchy's {} channels", path_,
                  line_number, frame, count, channels);
      ++frame;
    }
    FSKIN_CHECK(frame == num_frames, "{}: 'Frames: {}' but the file holds {} motion lines", path_, num_frames, frame);
  }

  std::vector<BvhJoint> joints;
  std::vector<double> values;  // [frames * channels]
  int num_channels = 0;
  int64_t num_frames = 0;
  double frame_time = 0;

 private:
  std::string path_;
  std::string text_;
  std::istringstream in_;
  const char* text_begin_ = nullptr;
  size_t text_size_ = 0;
  std::set<std::string> names_;
};

Eigen::Matrix3d axis_rotation(char axis, double degrees) {
  const double r = degrees * M_PI / 180.0;
  const Eigen::Vector3d a = axis == 'X' ? Eigen::Vector3d::UnitX() : axis == 'Y' ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitZ();
  return Eigen::AngleAxisd(r, a).toRotationMatrix();
}

double extent_of(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d lo = points.front(), hi = points.front();
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return (hi - lo).maxCoeff();
}

}  // namespace

std::map<std::string, std::string> read_name_map(const std::string& path) {
  std::ifstream in(path);
  FSKIN_CHECK(in.good(), "{}: cannot read the joint name map", path);
  std::map<std::string, std::string> map;
  int line_number = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    const auto eq = line.find('=');
    FSKIN_CHECK(eq != std::string::npos && eq > 0 && eq + 1 < line.size(),
                "{}:{}: expected 'file_joint=model_joint', got '{}'", path, line_number, line);
    const auto trim = [](std::string text) {
      const auto first = text.find_first_not_of(" \t"), last = text.find_last_not_of(" \t");
      return first == std::string::npos ? std::string() : text.substr(first, last - first + 1);
    };
    const std::string from = trim(line.substr(0, eq)), to = trim(line.substr(eq + 1));
    FSKIN_CHECK(!from.empty() && !to.empty(), "{}:{}: expected 'file_joint=model_joint', got '{}'", path,
                line_number, line);
    map[from] = to;
  }
  return map;
}

ImportedMotion import_bvh(const std::string& path, const Skeleton& model,
                          const std::map<std::string, std::string>& name_map) {
  model.validate("import_bvh: model");
  BvhReader bvh(path);
  bvh.read();
  const auto B = static_cast<int64_t>(bvh.joints.size());
  const int64_t J = model.num_joints(), T = bvh.num_frames;
  ImportedMotion out;
  out.fps = 1.0 / bvh.frame_time;
  // Model joint -> BVH joint.
  std::vector<int64_t> source(J, -1);
  std::vector<std::string> unused;
  for (int64_t b = 0; b < B; ++b) {
    const auto it = name_map.find(bvh.joints[b].name);
    const std::string target = it == name_map.end() ? bvh.joints[b].name : it->second;
    const int64_t j = model.find(target);
    if (j >= 0) source[j] = b;
    else unused.push_back(bvh.joints[b].name);
  }
  std::vector<std::string> missing;
  for (int64_t j = 0; j < J; ++j)
    if (source[j] < 0) missing.push_back(model.joint_names[j]);
  FSKIN_CHECK(source[0] >= 0, "{}: no BVH joint drives the model's root '{}' (map one with --map)", path,
              model.joint_names[0]);
  FSKIN_CHECK(static_cast<int64_t>(missing.size()) < J, "{}: no BVH joint matches a model joint", path);
  if (!missing.empty())
    out.notes.push_back(fmt::format("{} model joints have no BVH joint and follow their parent: {}", missing.size(),
                                    fmt::join(missing, ", ")));
  if (!unused.empty())
    out.notes.push_back(fmt::format("{} BVH joints drive no model joint (folded into their mapped descendants): {}",
                                    unused.size(), fmt::join(unused, ", ")));

  // BVH rest positions (zero pose), for the size ratio.
  std::vector<Eigen::Vector3d> rest(B);
  for (int64_t b = 0; b < B; ++b)
    rest[b] = bvh.joints[b].offset + (bvh.joints[b].parent < 0 ? Eigen::Vector3d::Zero() : rest[bvh.joints[b].parent]);
  const auto model_rest = model.rest_joints.to(torch::kFloat64).contiguous();
  std::vector<Eigen::Vector3d> model_points(J);
  for (int64_t j = 0; j < J; ++j)
    for (int a = 0; a < 3; ++a) model_points[j][a] = model_rest.data_ptr<double>()[3 * j + a];
  const double bvh_size = B > 1 ? extent_of(rest) : 0.0;
  for (int64_t b = 0; b < B; ++b) {
    const auto& joint = bvh.joints[b];
    for (size_t c = 0; c < joint.channels.size(); ++c) {
      const bool rotation = joint.channels[c][1] == 'r';
      const double limit = rotation ? kLargestRotationDegrees : kFarthestRootInSizes * bvh_size;
      if (!rotation && bvh_size <= 0) continue;  // one joint: no size to compare with
      for (int64_t t = 0; t < T; ++t) {
        const double value = bvh.values[t * bvh.num_channels + joint.first_channel + c];
        FSKIN_CHECK(std::abs(value) <= limit, "{}: frame {} gives joint '{}' {} = {:.4g}, beyond {:g}{}", path, t,
                    joint.name, joint.channels[c], value, limit,
                    rotation ? " degrees" : fmt::format(" ({:g} skeleton sizes)", kFarthestRootInSizes));
      }
    }
  }
  const double ratio = bvh_size > 0 ? extent_of(model_points) / bvh_size : 1.0;
  out.notes.push_back(fmt::format("root translation scaled by {:.4g} (model skeleton size / BVH skeleton size)", ratio));

  auto poses = torch::zeros({T, J, 3}, torch::kFloat64);
  auto trans = torch::zeros({T, 3}, torch::kFloat64);
  std::vector<Eigen::Matrix3d> global(B);
  std::vector<Eigen::Matrix3d> model_global(J);
  for (int64_t t = 0; t < T; ++t) {
    const double* v = bvh.values.data() + t * bvh.num_channels;
    Eigen::Vector3d root_position = bvh.joints[0].offset;
    for (int64_t b = 0; b < B; ++b) {
      const auto& joint = bvh.joints[b];
      Eigen::Matrix3d local = Eigen::Matrix3d::Identity();
      for (size_t c = 0; c < joint.channels.size(); ++c) {
        const auto& name = joint.channels[c];
        const double value = v[joint.first_channel + c];
        if (name[1] == 'r') local = local * axis_rotation(name[0], value);  // intrinsic, in listed order
        else if (b == 0) root_position[name[0] - 'X'] = joint.offset[name[0] - 'X'] + value;
      }
      global[b] = joint.parent < 0 ? local : Eigen::Matrix3d(global[joint.parent] * local);
    }
    for (int64_t j = 0; j < J; ++j) {
      const int64_t p = model.parents[j];
      model_global[j] = source[j] >= 0 ? global[source[j]] : model_global[p];
      const Eigen::Matrix3d local = p < 0 ? model_global[j] : Eigen::Matrix3d(model_global[p].transpose() * model_global[j]);
      const Eigen::AngleAxisd aa(local);
      for (int a = 0; a < 3; ++a) poses[t][j][a] = aa.angle() * aa.axis()[a];
    }
    for (int a = 0; a < 3; ++a) trans[t][a] = ratio * (root_position[a] - bvh.joints[0].offset[a]);
  }
  out.poses.poses = poses.to(torch::kFloat32);
  out.poses.trans = trans.to(torch::kFloat32);
  out.poses.joint_names = model.joint_names;
  out.poses.validate(path, J, model.joint_names);
  return out;
}

ImportedMotion import_amass(const std::string& path, const Skeleton& model) {
  io::NpzReader npz(path);
  FSKIN_CHECK(npz.contains("poses"), "{}: missing array 'poses' [T, 3J]", path);
  auto poses = npz.tensor("poses");
  FSKIN_CHECK(poses.is_floating_point(), "{}: 'poses' must be floating point (axis-angle in radians)", path);
  poses = poses.to(torch::kFloat32);
  if (poses.dim() == 2) {
    FSKIN_CHECK(poses.size(0) > 0 && poses.size(1) > 0 && poses.size(1) % 3 == 0,
                "{}: 'poses' is [{}, {}]: [T, 3J] with T, J > 0 expected", path, poses.size(0), poses.size(1));
    poses = poses.reshape({poses.size(0), -1, 3});
  }
  FSKIN_CHECK(poses.dim() == 3 && poses.size(2) == 3 && poses.size(0) > 0, "{}: 'poses' must be [T, 3J] or [T, J, 3]",
              path);
  const int64_t T = poses.size(0), file_joints = poses.size(1), J = model.num_joints();
  ImportedMotion out;
  if (npz.contains("mocap_framerate")) {
    const auto rate = npz.tensor("mocap_framerate");
    FSKIN_CHECK(rate.numel() == 1, "{}: 'mocap_framerate' has {} values, one expected", path, rate.numel());
    out.fps = rate.to(torch::kFloat64).item<double>();
    FSKIN_CHECK(std::isfinite(out.fps) && out.fps > 0, "{}: 'mocap_framerate' is {}, a positive rate expected", path,
                out.fps);
  }
  if (file_joints != J) {
    constexpr int64_t kBodyJoints = 22;
    FSKIN_CHECK(is_smpl_skeleton(model.joint_names) && file_joints >= kBodyJoints && J >= kBodyJoints,
                "{}: {} joints in the file for a model of {} joints; only SMPL-family files on SMPL models may "
                "differ (their first 22 body joints are shared)",
                path, file_joints, J);
    auto fitted = torch::zeros({T, J, 3});
    fitted.narrow(1, 0, kBodyJoints).copy_(poses.narrow(1, 0, kBodyJoints));
    poses = fitted;
    out.notes.push_back(fmt::format("kept the 22 SMPL body joints of the file's {}; the model's other {} joints stay at rest",
                                    file_joints, J - kBodyJoints));
  }
  out.poses.poses = poses.contiguous();
  out.poses.trans = npz.contains("trans") ? npz.tensor("trans").to(torch::kFloat32) : torch::zeros({T, 3});
  // Axis-angle beyond 100 turns and a root beyond 10^4 skeleton sizes are
  // corrupt values, not motion.
  const double largest_angle = poses.numel() ? poses.abs().max().item<double>() : 0.0;
  FSKIN_CHECK(largest_angle <= 200 * M_PI, "{}: 'poses' holds an angle of {:.4g} rad (beyond 100 turns)", path,
              largest_angle);
  const double skeleton_size = (std::get<0>(model.rest_joints.max(0)) - std::get<0>(model.rest_joints.min(0)))
                                   .max()
                                   .item<double>();
  if (out.poses.trans.numel() && skeleton_size > 0) {
    const double farthest = out.poses.trans.abs().max().item<double>();
    FSKIN_CHECK(farthest <= kFarthestRootInSizes * skeleton_size,
                "{}: 'trans' moves the root {:.4g} m, beyond {:g} times the model's skeleton size ({:.3g} m)", path,
                farthest, kFarthestRootInSizes, skeleton_size);
  }
  out.poses.joint_names = model.joint_names;
  out.poses.validate(path, J, model.joint_names);
  return out;
}

}  // namespace fskin
