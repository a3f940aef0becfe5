#include "fskin/radiance/pinhole_camera.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "test_util.h"

namespace fskin {
namespace {

Camera ring_camera(double azimuth, double elevation, double aspect) {
  BoundingBox box;
  box.extend(Eigen::Vector3f(-0.4f, 0.0f, -0.2f));
  box.extend(Eigen::Vector3f(0.5f, 1.7f, 0.3f));
  return frame_camera(box, ViewAngles{azimuth, elevation}, aspect, 30, 0.05);
}

TEST(PinholeCamera, ProjectsLikeTheMeshRenderer) {
  for (const double azimuth : {0.0, 37.0, 180.0, 290.0}) {
    const int width = 160, height = 120;
    const Camera camera = ring_camera(azimuth, 15, static_cast<double>(width) / height);
    const auto pinhole = PinholeCamera::from_render_camera(camera, width, height);
    pinhole.validate("test");
    for (const Eigen::Vector3f point : {Eigen::Vector3f(0.1f, 0.9f, 0.0f), Eigen::Vector3f(-0.3f, 0.2f, 0.25f),
                                        Eigen::Vector3f(0.45f, 1.6f, -0.15f)}) {
      // The renderer's pixel centres sit at u + 0.5, OpenCV's at u.
      const Eigen::Vector2f rendered = camera.to_pixel(camera.to_camera(point), width, height);
      const Eigen::Vector2d projected = pinhole.project(point.cast<double>());
      EXPECT_NEAR(projected.x(), rendered.x() - 0.5, 1e-3) << azimuth;
      EXPECT_NEAR(projected.y(), rendered.y() - 0.5, 1e-3) << azimuth;
    }
    const Camera back = pinhole.to_render_camera();
    EXPECT_TRUE(back.eye.isApprox(camera.eye, 1e-5f));
    EXPECT_TRUE(back.forward.isApprox(camera.forward, 1e-5f));
    EXPECT_NEAR(back.tan_half_fov_y, camera.tan_half_fov_y, 1e-9);
  }
}

TEST(PinholeCamera, RaysPassThroughTheProjectedPoints) {
  const auto pinhole = PinholeCamera::from_render_camera(ring_camera(60, -10, 1.0), 64, 64);
  const Eigen::Vector3d point(0.2, 1.1, -0.1);
  const Eigen::Vector2d pixel = pinhole.project(point);
  const auto [origins, directions] =
      camera_rays(pinhole, torch::tensor({static_cast<float>(pixel.x()), static_cast<float>(pixel.y())}).reshape({1, 2}));
  const Eigen::Vector3d o(origins[0][0].item<double>(), origins[0][1].item<double>(), origins[0][2].item<double>());
  const Eigen::Vector3d d(directions[0][0].item<double>(), directions[0][1].item<double>(),
                          directions[0][2].item<double>());
  EXPECT_NEAR(d.norm(), 1.0, 1e-6);
  // Distance of the point from the ray.
  const Eigen::Vector3d offset = point - o;
  EXPECT_LT((offset - offset.dot(d) * d).norm(), 1e-5);
  EXPECT_GT(offset.dot(d), 0);
}

TEST(PinholeCamera, PixelCentresRunRowByRow) {
  const auto centres = pixel_centres(3, 2);
  ASSERT_EQ(centres.sizes(), (std::vector<int64_t>{6, 2}));
  EXPECT_EQ(centres[1][0].item<float>(), 1.0f);
  EXPECT_EQ(centres[1][1].item<float>(), 0.0f);
  EXPECT_EQ(centres[4][0].item<float>(), 1.0f);
  EXPECT_EQ(centres[4][1].item<float>(), 1.0f);
}

TEST(PinholeCamera, RejectsMatricesThatAreNoCamera) {
  auto camera = PinholeCamera::from_render_camera(ring_camera(0, 0, 1.0), 32, 32);
  auto scaled = camera;
  scaled.extrinsic.topLeftCorner<3, 3>() *= 2;
  testing::expect_error([&] { scaled.validate("cameras.npz: camera 3"); }, {"cameras.npz: camera 3", "rotation"});
  auto bad_focal = camera;
  bad_focal.intrinsic(0, 0) = -5;
  testing::expect_error([&] { bad_focal.validate("cam"); }, {"cam", "focal"});
  auto skewed = camera;
  skewed.intrinsic(0, 1) = 3;
  testing::expect_error([&] { skewed.to_render_camera(); }, {"skew"});
}

}  // namespace
}  // namespace fskin
