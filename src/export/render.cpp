#include "fskin/export/render.h"

#include <ATen/Parallel.h>
#include <Eigen/Geometry>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/geometry/mesh_topology.h"

namespace fskin {
namespace {

constexpr double kPi = 3.14159265358979323846;
double radians(double degrees) { return degrees * kPi / 180.0; }

// Output of the visibility pass for one sample: the nearest face and the
// perspective-correct barycentric weights of its corners 1 and 2.
struct Fragment {
  float inverse_depth = 0;  // 1 / z; 0 = nothing drawn (z is always > 0)
  int32_t face = -1;
  float b1 = 0, b2 = 0;
};

// Twice the signed area of triangle (a, b, p) in screen space.
float edge(const Eigen::Vector2f& a, const Eigen::Vector2f& b, const Eigen::Vector2f& p) {
  return (b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x());
}

// Z-buffered visibility: for every sample, the nearest triangle covering its
// centre. Triangles are not culled by orientation, so open or inconsistently
// oriented meshes still render; shading lights both sides.
// Samples' centres sit at (x + 0.5, y + 0.5), OpenCV's pixel centres at
// (u, v): screen = the camera's pixel position + 0.5.
std::vector<Fragment> rasterize(const float* vertices, const int64_t* faces, int64_t num_faces,
                                const PinholeCamera& camera) {
  const int width = camera.width, height = camera.height;
  std::vector<Fragment> fragments(static_cast<size_t>(width) * height);
  const Eigen::Matrix3d rotation = camera.extrinsic.topLeftCorner<3, 3>();
  const Eigen::Vector3d translation = camera.extrinsic.topRightCorner<3, 1>();
  const Eigen::Matrix3d& K = camera.intrinsic;
  for (int64_t f = 0; f < num_faces; ++f) {
    Eigen::Vector2f screen[3];
    float inverse_depth[3];
    bool in_front = true;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Map<const Eigen::Vector3f> world(vertices + 3 * faces[3 * f + k]);
      const Eigen::Vector3d point = rotation * world.cast<double>() + translation;
      in_front = in_front && point.z() > 1e-6;
      const double x = point.x() / point.z(), y = point.y() / point.z();
      screen[k] = Eigen::Vector2f(static_cast<float>(K(0, 0) * x + K(0, 1) * y + K(0, 2) + 0.5),
                                  static_cast<float>(K(1, 1) * y + K(1, 2) + 0.5));
      inverse_depth[k] = static_cast<float>(1.0 / point.z());
    }
    // frame_camera keeps the framed box in front of the camera; a triangle
    // reaching behind it only occurs with a user-chosen framing box.
    if (!in_front) continue;
    const float area = edge(screen[0], screen[1], screen[2]);
    if (area == 0.0f) continue;
    const Eigen::Vector2f lower = screen[0].cwiseMin(screen[1]).cwiseMin(screen[2]);
    const Eigen::Vector2f upper = screen[0].cwiseMax(screen[1]).cwiseMax(screen[2]);
    const int x0 = std::max(0, static_cast<int>(std::floor(lower.x())));
    const int x1 = std::min(width - 1, static_cast<int>(std::ceil(upper.x())));
    const int y0 = std::max(0, static_cast<int>(std::floor(lower.y())));
    const int y1 = std::min(height - 1, static_cast<int>(std::ceil(upper.y())));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Vector2f p(x + 0.5f, y + 0.5f);
        // Screen-space barycentrics; dividing by the signed area makes them
        // positive inside for either winding.
        const float w0 = edge(screen[1], screen[2], p) / area;
        const float w1 = edge(screen[2], screen[0], p) / area;
        const float w2 = edge(screen[0], screen[1], p) / area;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        // 1/z is affine in screen space; attributes need the division by z.
        const float inv_z = w0 * inverse_depth[0] + w1 * inverse_depth[1] + w2 * inverse_depth[2];
        Fragment& fragment = fragments[static_cast<size_t>(y) * width + x];
        if (inv_z <= fragment.inverse_depth) continue;
        fragment.inverse_depth = inv_z;
        fragment.face = static_cast<int32_t>(f);
        fragment.b1 = w1 * inverse_depth[1] / inv_z;
        fragment.b2 = w2 * inverse_depth[2] / inv_z;
      }
    }
  }
  return fragments;
}

Eigen::Vector3f to_unit(const Rgb8& color) {
  return Eigen::Vector3f(color[0], color[1], color[2]) / 255.0f;
}

}  // namespace

ViewAngles view_angles(View view) {
  switch (view) {
    case View::Front: return {0, 0};
    case View::ThreeQuarter: return {45, 10};
    case View::Side: return {90, 0};
    case View::Back: return {180, 0};
  }
  fail("unknown view {}", static_cast<int>(view));
}

View parse_view(const std::string& name) {
  if (name == "front") return View::Front;
  if (name == "three-quarter") return View::ThreeQuarter;
  if (name == "side") return View::Side;
  if (name == "back") return View::Back;
  fail("unknown view '{}': expected front, three-quarter, side or back", name);
}

std::vector<ViewAngles> turntable_views(int count, double elevation_degrees) {
  FSKIN_CHECK(count > 0, "turntable needs at least one view, got {}", count);
  std::vector<ViewAngles> views;
  for (int i = 0; i < count; ++i) views.push_back({360.0 * i / count, elevation_degrees});
  return views;
}

void BoundingBox::extend(const Eigen::Vector3f& point) {
  lower = lower.cwiseMin(point);
  upper = upper.cwiseMax(point);
}

void BoundingBox::extend(const BoundingBox& other) {
  lower = lower.cwiseMin(other.lower);
  upper = upper.cwiseMax(other.upper);
}

BoundingBox bounding_box(const Mesh& mesh) {
  BoundingBox box;
  if (mesh.num_vertices() == 0) return box;
  const auto vertices = mesh.vertices.to(torch::kFloat32).contiguous();
  const auto lower = std::get<0>(vertices.min(0)), upper = std::get<0>(vertices.max(0));
  for (int c = 0; c < 3; ++c) {
    box.lower[c] = lower[c].item<float>();
    box.upper[c] = upper[c].item<float>();
  }
  return box;
}

PinholeCamera frame_camera(const BoundingBox& box, const ViewAngles& angles, int width, int height,
                           double vertical_fov_degrees, double margin) {
  FSKIN_CHECK(!box.empty() && box.lower.allFinite() && box.upper.allFinite(),
              "cannot frame an empty or non-finite bounding box");
  FSKIN_CHECK(std::abs(angles.elevation_degrees) < 90, "view elevation must be within (-90, 90) "
              "degrees, got {}", angles.elevation_degrees);
  FSKIN_CHECK(vertical_fov_degrees > 0 && vertical_fov_degrees < 180,
              "vertical field of view must be within (0, 180) degrees, got {}",
              vertical_fov_degrees);
  FSKIN_CHECK(margin >= 0 && margin < 0.5, "frame margin must be within [0, 0.5), got {}",
              margin);
  FSKIN_CHECK(width > 0 && height > 0, "picture size must be positive, got {}x{}", width, height);
  const double aspect = static_cast<double>(width) / height;
  const double azimuth = radians(angles.azimuth_degrees);
  const double elevation = radians(angles.elevation_degrees);
  // Unit vector from the subject to the camera; azimuth 0 = on +Z (front).
  const Eigen::Vector3f to_eye(static_cast<float>(std::sin(azimuth) * std::cos(elevation)),
                               static_cast<float>(std::sin(elevation)),
                               static_cast<float>(std::cos(azimuth) * std::cos(elevation)));
  const Eigen::Vector3f forward = -to_eye;
  const Eigen::Vector3f right = forward.cross(Eigen::Vector3f::UnitY()).normalized();
  const Eigen::Vector3f up = right.cross(forward);
  const double tan_half_fov_y = std::tan(radians(vertical_fov_degrees) / 2);
  const Eigen::Vector3f centre = 0.5f * (box.lower + box.upper);
  const double usable = 1 - 2 * margin;
  const double tan_x = tan_half_fov_y * aspect * usable;
  const double tan_y = tan_half_fov_y * usable;
  // With the eye at distance D from the centre, a corner at camera-space
  // offset (x, y, z) from the centre has depth D + z and fits when
  // |x| <= tan_x (D + z) and |y| <= tan_y (D + z).
  double distance = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3f point((corner & 1) ? box.upper.x() : box.lower.x(),
                                (corner & 2) ? box.upper.y() : box.lower.y(),
                                (corner & 4) ? box.upper.z() : box.lower.z());
    const Eigen::Vector3f d = point - centre;
    const double x = d.dot(right), y = d.dot(up), z = d.dot(forward);
    distance = std::max({distance, std::abs(x) / tan_x - z, std::abs(y) / tan_y - z});
  }
  // A flat or point-like box still needs the eye in front of it.
  const double extent = std::max(1e-3, static_cast<double>((box.upper - box.lower).norm()));
  distance = std::max(distance, extent);
  const Eigen::Vector3d eye = (centre + static_cast<float>(distance) * to_eye).cast<double>();
  PinholeCamera camera;
  camera.width = width;
  camera.height = height;
  Eigen::Matrix3d rotation;  // rows: the camera's x (right), y (down), z (forward) in world space
  rotation.row(0) = right.cast<double>();
  rotation.row(1) = -up.cast<double>();
  rotation.row(2) = forward.cast<double>();
  camera.extrinsic.topLeftCorner<3, 3>() = rotation;
  camera.extrinsic.topRightCorner<3, 1>() = -rotation * eye;
  // x/z = +-tan_half_fov_x at the picture's outer edges, u = -0.5 and W - 0.5.
  camera.intrinsic(0, 0) = 0.5 * width / (tan_half_fov_y * aspect);
  camera.intrinsic(1, 1) = 0.5 * height / tan_half_fov_y;
  camera.intrinsic(0, 2) = 0.5 * (width - 1);
  camera.intrinsic(1, 2) = 0.5 * (height - 1);
  return camera;
}

Image render_mesh(const Mesh& mesh, const RenderOptions& options) {
  mesh.validate("render_mesh: mesh");
  FSKIN_CHECK(mesh.num_faces() > 0, "render_mesh: mesh has no faces");
  FSKIN_CHECK(!mesh.colors.defined() || mesh.colors.scalar_type() == torch::kUInt8,
              "render_mesh: mesh colors must be uint8 (0..255), got {}",
              std::string(c10::toString(mesh.colors.scalar_type())));
  FSKIN_CHECK(options.width > 0 && options.height > 0 && options.width <= 16384 &&
                  options.height <= 16384,
              "render_mesh: picture size must be within 1..16384, got {}x{}", options.width,
              options.height);
  FSKIN_CHECK(options.supersampling >= 1 && options.supersampling <= 8,
              "render_mesh: supersampling must be within 1..8, got {}", options.supersampling);
  const auto vertices = mesh.vertices.contiguous();
  const auto faces = mesh.faces.contiguous();
  const auto normals = vertex_normals(mesh).contiguous();
  const auto colors = mesh.colors.defined() ? mesh.colors.to(torch::kFloat32).div(255).contiguous()
                                            : torch::Tensor();
  const float* vertex_data = vertices.data_ptr<float>();
  const int64_t* face_data = faces.data_ptr<int64_t>();
  const float* normal_data = normals.data_ptr<float>();
  const float* color_data = colors.defined() ? colors.data_ptr<float>() : nullptr;

  const int samples = options.supersampling;
  const int width = options.width * samples, height = options.height * samples;
  const PinholeCamera camera =
      frame_camera(options.framing ? *options.framing : bounding_box(mesh), options.view, options.width,
                   options.height, options.vertical_fov_degrees, options.margin);
  const auto fragments = rasterize(vertex_data, face_data, mesh.num_faces(), camera.supersampled(samples));

  // Light directions in world space, fixed relative to the camera so every
  // view is lit alike: the key light comes from above left, behind the viewer.
  const Eigen::Vector3f to_light =
      (-0.35 * camera.right() - 0.55 * camera.down() - 0.75 * camera.forward()).normalized().cast<float>();
  const Eigen::Vector3f eye = camera.centre().cast<float>();
  const Eigen::Vector3f base_color = to_unit(options.base_color);
  const Eigen::Vector3f top = to_unit(options.background_top);
  const Eigen::Vector3f bottom = to_unit(options.background_bottom);
  const auto ambient = static_cast<float>(options.ambient);
  const auto diffuse = static_cast<float>(options.diffuse);
  const auto specular = static_cast<float>(options.specular);
  const auto shininess = static_cast<float>(options.shininess);

  // Shade every sample, then box-filter s x s samples into one pixel.
  std::vector<Eigen::Vector3f> shaded(fragments.size());
  at::parallel_for(0, height, 16, [&](int64_t begin, int64_t end) {
    for (int64_t y = begin; y < end; ++y) {
      const Eigen::Vector3f background =
          top + (bottom - top) * ((static_cast<float>(y) + 0.5f) / height);
      for (int x = 0; x < width; ++x) {
        const size_t index = static_cast<size_t>(y) * width + x;
        const Fragment& fragment = fragments[index];
        if (fragment.face < 0) {
          shaded[index] = background;
          continue;
        }
        const int64_t* corner = face_data + 3 * fragment.face;
        const float b[3] = {1 - fragment.b1 - fragment.b2, fragment.b1, fragment.b2};
        Eigen::Vector3f position = Eigen::Vector3f::Zero(), normal = Eigen::Vector3f::Zero();
        Eigen::Vector3f albedo = color_data ? Eigen::Vector3f::Zero() : base_color;
        for (int k = 0; k < 3; ++k) {
          position += b[k] * Eigen::Map<const Eigen::Vector3f>(vertex_data + 3 * corner[k]);
          normal += b[k] * Eigen::Map<const Eigen::Vector3f>(normal_data + 3 * corner[k]);
          if (color_data)
            albedo += b[k] * Eigen::Map<const Eigen::Vector3f>(color_data + 3 * corner[k]);
        }
        const Eigen::Vector3f to_viewer = (eye - position).normalized();
        // Vertices without faces of their own have zero normals; fall back to
        // facing the viewer. Back sides are lit like front sides.
        normal = normal.squaredNorm() > 0 ? normal.normalized() : to_viewer;
        if (normal.dot(to_viewer) < 0) normal = -normal;
        const Eigen::Vector3f half_vector = (to_light + to_viewer).normalized();
        const float lambert = std::max(0.0f, normal.dot(to_light));
        const float highlight = std::pow(std::max(0.0f, normal.dot(half_vector)), shininess);
        shaded[index] = (albedo * (ambient + diffuse * lambert) +
                         Eigen::Vector3f::Constant(specular * highlight))
                            .cwiseMin(1.0f)
                            .cwiseMax(0.0f);
      }
    }
  });

  Image image(options.width, options.height);
  const float weight = 1.0f / static_cast<float>(samples * samples);
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x < options.width; ++x) {
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      for (int sy = 0; sy < samples; ++sy)
        for (int sx = 0; sx < samples; ++sx)
          sum += shaded[static_cast<size_t>(y * samples + sy) * width + x * samples + sx];
      uint8_t* out = image.pixel(x, y);
      for (int c = 0; c < 3; ++c)
        out[c] = static_cast<uint8_t>(std::lround(255.0f * weight * sum[c]));
    }
  }
  return image;
}

Image render_grid(const std::vector<Mesh>& meshes, const std::vector<ViewAngles>& views,
                  const RenderOptions& options) {
  FSKIN_CHECK(!meshes.empty(), "render_grid: no meshes given");
  FSKIN_CHECK(!views.empty(), "render_grid: no views given");
  RenderOptions cell = options;
  if (!cell.framing) {
    BoundingBox all;
    for (size_t i = 0; i < meshes.size(); ++i) {
      meshes[i].validate(fmt::format("render_grid: mesh {}", i));
      all.extend(bounding_box(meshes[i]));
    }
    cell.framing = all;
  }
  Image grid(options.width * static_cast<int>(views.size()),
             options.height * static_cast<int>(meshes.size()));
  for (size_t row = 0; row < meshes.size(); ++row) {
    for (size_t column = 0; column < views.size(); ++column) {
      cell.view = views[column];
      grid.paste(render_mesh(meshes[row], cell), static_cast<int>(column) * options.width,
                 static_cast<int>(row) * options.height);
    }
  }
  return grid;
}

SurfaceRender render_surface(const Mesh& mesh, const PinholeCamera& camera, int supersampling,
                             const SurfaceShader& shade, Rgb8 background) {
  camera.validate("render_surface: camera");
  const int width = camera.width, height = camera.height;
  mesh.validate("render_surface: mesh");
  FSKIN_CHECK(mesh.num_faces() > 0, "render_surface: mesh has no faces");
  FSKIN_CHECK(width > 0 && height > 0 && width <= 16384 && height <= 16384,
              "render_surface: picture size must be within 1..16384, got {}x{}", width, height);
  FSKIN_CHECK(supersampling >= 1 && supersampling <= 8,
              "render_surface: supersampling must be within 1..8, got {}", supersampling);
  const auto vertices = mesh.vertices.contiguous();
  const auto faces = mesh.faces.contiguous();
  const int s = supersampling;
  const int sample_width = width * s;
  const auto fragments =
      rasterize(vertices.data_ptr<float>(), faces.data_ptr<int64_t>(), mesh.num_faces(), camera.supersampled(s));
  const Eigen::Vector3f back = to_unit(background);
  SurfaceRender out{Image(width, height), std::vector<uint8_t>(static_cast<size_t>(width) * height)};
  at::parallel_for(0, height, 8, [&](int64_t begin, int64_t end) {
    for (int64_t y = begin; y < end; ++y) {
      for (int x = 0; x < width; ++x) {
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        int covered = 0;
        for (int sy = 0; sy < s; ++sy) {
          for (int sx = 0; sx < s; ++sx) {
            const Fragment& f = fragments[static_cast<size_t>(y * s + sy) * sample_width + x * s + sx];
            if (f.face < 0) {
              sum += back;
              continue;
            }
            ++covered;
            sum += shade(f.face, 1 - f.b1 - f.b2, f.b1, f.b2).cwiseMax(0.0f).cwiseMin(1.0f);
          }
        }
        uint8_t* pixel = out.image.pixel(x, static_cast<int>(y));
        for (int c = 0; c < 3; ++c)
          pixel[c] = static_cast<uint8_t>(std::lround(255.0f * sum[c] / static_cast<float>(s * s)));
        out.mask[static_cast<size_t>(y) * width + x] =
            static_cast<uint8_t>(std::lround(255.0 * covered / (s * s)));
      }
    }
  });
  return out;
}

}  // namespace fskin
