#include "fskin/export/render.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "fskin/core/error.h"
#include "test_util.h"

namespace fskin {
namespace {

// UV sphere with `rings` x `segments` quads (poles as triangle fans),
// counter-clockwise seen from outside.
Mesh uv_sphere(const Eigen::Vector3f& centre, float radius, int rings = 48, int segments = 96) {
  std::vector<float> vertices = {centre.x(), centre.y() + radius, centre.z()};
  for (int r = 1; r < rings; ++r) {
    const double polar = M_PI * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double azimuth = 2 * M_PI * s / segments;
      vertices.push_back(centre.x() + radius * std::sin(polar) * std::sin(azimuth));
      vertices.push_back(centre.y() + radius * std::cos(polar));
      vertices.push_back(centre.z() + radius * std::sin(polar) * std::cos(azimuth));
    }
  }
  vertices.insert(vertices.end(), {centre.x(), centre.y() - radius, centre.z()});
  const int64_t south = static_cast<int64_t>(vertices.size() / 3) - 1;
  const auto ring_vertex = [&](int r, int s) { return 1 + (r - 1) * segments + s % segments; };
  std::vector<int64_t> faces;
  for (int s = 0; s < segments; ++s) {
    faces.insert(faces.end(), {0, ring_vertex(1, s), ring_vertex(1, s + 1)});
    faces.insert(faces.end(), {south, ring_vertex(rings - 1, s + 1), ring_vertex(rings - 1, s)});
  }
  for (int r = 1; r + 1 < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const int64_t a = ring_vertex(r, s), b = ring_vertex(r, s + 1);
      const int64_t c = ring_vertex(r + 1, s), d = ring_vertex(r + 1, s + 1);
      faces.insert(faces.end(), {a, c, d, a, d, b});
    }
  }
  return Mesh{torch::tensor(vertices).reshape({-1, 3}),
              torch::tensor(faces, torch::kInt64).reshape({-1, 3}), {}};
}

// Flat white object on black: each pixel's value is its coverage (0..255).
RenderOptions silhouette_options(int width, int height) {
  RenderOptions options;
  options.width = width;
  options.height = height;
  options.supersampling = 4;
  options.base_color = {255, 255, 255};
  options.background_top = options.background_bottom = {0, 0, 0};
  options.ambient = 1;
  options.diffuse = 0;
  options.specular = 0;
  return options;
}

struct Coverage {
  double area = 0;  // in pixels
  double centre_x = 0, centre_y = 0;
  int top_row = -1;  // first row with any coverage
};

Coverage measure(const Image& image) {
  Coverage c;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const double w = image.pixel(x, y)[0] / 255.0;
      if (w > 0 && c.top_row < 0) c.top_row = y;
      c.area += w;
      c.centre_x += w * (x + 0.5);
      c.centre_y += w * (y + 0.5);
    }
  }
  c.centre_x /= c.area;
  c.centre_y /= c.area;
  return c;
}

Rgb8 at(const Image& image, int x, int y) {
  const uint8_t* p = image.pixel(x, y);
  return {p[0], p[1], p[2]};
}

TEST(Render, SphereSilhouetteIsTheCentredProjectedDisk) {
  const Eigen::Vector3f centre(2.0f, 1.0f, -3.0f);
  const float radius = 0.5f;
  const Mesh sphere = uv_sphere(centre, radius);
  const auto options = silhouette_options(240, 240);
  const Image image = render_mesh(sphere, options);
  ASSERT_EQ(image.width, 240);
  ASSERT_EQ(image.height, 240);

  // The sphere's outline in a pinhole camera looking at its centre is a
  // circle of angular radius asin(r / d).
  const PinholeCamera camera = frame_camera(bounding_box(sphere), options.view, options.width, options.height,
                                            options.vertical_fov_degrees, options.margin);
  const double distance = (camera.centre() - centre.cast<double>()).norm();
  const double tan_half_fov_y = std::tan(options.vertical_fov_degrees * M_PI / 360);
  EXPECT_NEAR(camera.intrinsic(1, 1), 0.5 * options.height / tan_half_fov_y, 1e-9);
  const double radius_pixels = std::tan(std::asin(radius / distance)) / tan_half_fov_y * options.height / 2;
  const Coverage c = measure(image);
  EXPECT_NEAR(c.area / (M_PI * radius_pixels * radius_pixels), 1.0, 0.01);
  EXPECT_NEAR(c.centre_x, 120.0, 0.5);
  EXPECT_NEAR(c.centre_y, 120.0, 0.5);
  // Anti-aliasing: the outline has partially covered pixels.
  int partial = 0;
  for (uint8_t value : image.rgb) partial += value > 10 && value < 245;
  EXPECT_GT(partial, 3 * 2 * M_PI * radius_pixels * 0.5);
}

TEST(Render, FramingFitsATallBoxToTheMargin) {
  // A 1.7 m tall, thin box (like a standing body) in a landscape picture.
  const auto corners = torch::tensor({-0.1f, 0.0f, -0.1f, 0.1f, 0.0f, -0.1f, -0.1f, 1.7f, -0.1f,
                                      0.1f, 1.7f, -0.1f, -0.1f, 0.0f, 0.1f, 0.1f, 0.0f, 0.1f,
                                      -0.1f, 1.7f, 0.1f, 0.1f, 1.7f, 0.1f})
                           .reshape({8, 3});
  const auto faces = torch::tensor({0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                    2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5},
                                   torch::kInt64)
                       .reshape({12, 3});
  auto options = silhouette_options(300, 200);
  options.margin = 0.1;
  const Coverage c = measure(render_mesh(Mesh{corners, faces, {}}, options));
  // The nearest top corners touch the upper margin; the box stays centred.
  EXPECT_NEAR(c.top_row, 0.1 * 200, 1.5);
  EXPECT_NEAR(c.centre_x, 150.0, 0.5);
  EXPECT_NEAR(c.centre_y, 100.0, 1.0);
}

// Two triangles facing +Z: a large blue one at z = -0.5 and a smaller red
// one in front of it at z = +0.5, listed in `order`.
Mesh two_triangles(bool red_first) {
  const auto vertices = torch::tensor({-1.0f, -1.0f, -0.5f, 1.0f, -1.0f, -0.5f, 0.0f, 1.0f, -0.5f,
                                       -0.3f, -0.3f, 0.5f, 0.3f, -0.3f, 0.5f, 0.0f, 0.3f, 0.5f})
                            .reshape({6, 3});
  auto faces = torch::tensor({0, 1, 2, 3, 4, 5}, torch::kInt64).reshape({2, 3});
  if (red_first) faces = faces.flip(0);
  auto colors = torch::zeros({6, 3}, torch::kUInt8);
  colors.slice(0, 0, 3).select(1, 2).fill_(255);
  colors.slice(0, 3, 6).select(1, 0).fill_(255);
  return Mesh{vertices, faces, colors};
}

TEST(Render, NearTriangleCoversFarOneWhateverTheOrder) {
  RenderOptions options;
  options.width = options.height = 64;
  const Image image = render_mesh(two_triangles(false), options);
  const Rgb8 centre = at(image, 32, 34);
  EXPECT_GT(centre[0], 2 * centre[2]) << "centre should be red";
  const PinholeCamera camera = frame_camera(bounding_box(two_triangles(false)), options.view, 64, 64,
                                            options.vertical_fov_degrees, options.margin);
  // A point of the blue triangle outside the red one.
  const Eigen::Vector2d blue_pixel = camera.project(Eigen::Vector3d(-0.6, -0.8, -0.5));
  const Rgb8 blue = at(image, static_cast<int>(std::lround(blue_pixel.x())), static_cast<int>(std::lround(blue_pixel.y())));
  EXPECT_GT(blue[2], 2 * blue[0]) << "outside the red triangle the blue one shows";
  EXPECT_EQ(image.rgb, render_mesh(two_triangles(true), options).rgb);
}

TEST(Render, ViewsFollowTheAxisConventions) {
  // Red where z > 0 (the front) or, in the second sphere, where x > 0 (the
  // body's left); blue elsewhere.
  Mesh sphere = uv_sphere(Eigen::Vector3f::Zero(), 1.0f, 16, 32);
  const auto paint = [&](int axis) {
    const auto positive = sphere.vertices.select(1, axis) > 0;
    auto colors = torch::zeros({sphere.num_vertices(), 3}, torch::kUInt8);
    colors.select(1, 0).masked_fill_(positive, 255);
    colors.select(1, 2).masked_fill_(positive.logical_not(), 255);
    return colors;
  };
  RenderOptions options;
  options.width = options.height = 32;
  const auto red_in_centre = [&] {
    const Rgb8 c = at(render_mesh(sphere, options), 16, 16);
    EXPECT_NE(c[0] > c[2], c[2] > c[0]);
    return c[0] > c[2];
  };
  sphere.colors = paint(2);
  options.view = view_angles(View::Front);
  EXPECT_TRUE(red_in_centre());
  options.view = view_angles(View::Back);
  EXPECT_FALSE(red_in_centre());
  sphere.colors = paint(0);
  options.view = view_angles(View::Side);
  EXPECT_TRUE(red_in_centre());
}

TEST(Render, GridCellsAreSingleRendersWithSharedFraming) {
  const Mesh small = uv_sphere(Eigen::Vector3f::Zero(), 0.5f, 8, 16);
  const Mesh large = uv_sphere(Eigen::Vector3f(0, 0.5f, 0), 1.0f, 8, 16);
  RenderOptions options;
  options.width = 40;
  options.height = 30;
  options.supersampling = 2;
  const auto views = turntable_views(3);
  const Image grid = render_grid({small, large}, views, options);
  ASSERT_EQ(grid.width, 120);
  ASSERT_EQ(grid.height, 60);

  BoundingBox both = bounding_box(small);
  both.extend(bounding_box(large));
  RenderOptions cell = options;
  cell.framing = both;
  cell.view = views[2];
  Image expected = render_mesh(small, cell);
  Image actual(40, 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x)
      std::copy_n(grid.pixel(80 + x, y), 3, actual.pixel(x, y));
  EXPECT_EQ(actual.rgb, expected.rgb);
  // The shared framing shows the small sphere smaller than framed alone.
  auto alone = silhouette_options(40, 30);
  auto shared = alone;
  shared.framing = both;
  EXPECT_LT(measure(render_mesh(small, shared)).area,
            0.6 * measure(render_mesh(small, alone)).area);
}

TEST(Render, BadInputThrows) {
  const Mesh sphere = uv_sphere(Eigen::Vector3f::Zero(), 1.0f, 4, 8);
  RenderOptions options;
  options.width = options.height = 16;
  EXPECT_THROW(render_mesh(Mesh{}, options), Error);
  EXPECT_THROW(render_mesh(Mesh{sphere.vertices, torch::zeros({0, 3}, torch::kInt64), {}},
                           options),
               Error);
  Mesh broken = sphere;
  broken.vertices = sphere.vertices.clone();
  broken.vertices[3][1] = std::nanf("");
  testing::expect_error([&] { render_mesh(broken, options); }, {"render_mesh", "vertices"});
  Mesh wrong_colors = sphere;
  wrong_colors.colors = torch::zeros({2, 3}, torch::kUInt8);
  EXPECT_THROW(render_mesh(wrong_colors, options), Error);
  wrong_colors.colors = torch::zeros({sphere.num_vertices(), 3});
  testing::expect_error([&] { render_mesh(wrong_colors, options); }, {"colors", "uint8"});
  RenderOptions bad = options;
  bad.supersampling = 0;
  EXPECT_THROW(render_mesh(sphere, bad), Error);
  bad = options;
  bad.view.elevation_degrees = 90;
  EXPECT_THROW(render_mesh(sphere, bad), Error);
  bad = options;
  bad.width = 0;
  EXPECT_THROW(render_mesh(sphere, bad), Error);
  testing::expect_error([] { parse_view("top"); }, {"top", "three-quarter"});
  EXPECT_THROW(render_grid({}, {ViewAngles{}}, options), Error);
  EXPECT_THROW(render_grid({sphere}, {}, options), Error);
}

}  // namespace
}  // namespace fskin
