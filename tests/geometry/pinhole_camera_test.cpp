#include "fskin/geometry/pinhole_camera.h"

#include <cmath>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/export/render.h"
#include "test_util.h"

namespace fskin {
namespace {

PinholeCamera ring_camera(double azimuth, double elevation, int width, int height) {
  BoundingBox box;
  box.extend(Eigen::Vector3f(-0.4f, 0.0f, -0.2f));
  box.extend(Eigen::Vector3f(0.5f, 1.7f, 0.3f));
  return frame_camera(box, ViewAngles{azimuth, elevation}, width, height, 30, 0.05);
}

TEST(PinholeCamera, FramedCamerasLookAtTheBoxFromTheirAngle) {
  for (const double azimuth : {0.0, 37.0, 180.0, 290.0}) {
    const int width = 160, height = 120;
    const auto camera = ring_camera(azimuth, 15, width, height);
    camera.validate("test");
    // The box's centre projects to the picture's centre; the eye lies on the
    // ray of the view's angles (azimuth 0 = on +Z, the front).
    const Eigen::Vector3d centre(0.05, 0.85, 0.05);
    const Eigen::Vector2d middle = camera.project(centre);
    EXPECT_NEAR(middle.x(), 0.5 * (width - 1), 1e-4) << azimuth;
    EXPECT_NEAR(middle.y(), 0.5 * (height - 1), 1e-4) << azimuth;
    const Eigen::Vector3d to_eye = (camera.centre() - centre).normalized();
    const double a = azimuth * M_PI / 180, e = 15 * M_PI / 180;
    EXPECT_TRUE(to_eye.isApprox(Eigen::Vector3d(std::sin(a) * std::cos(e), std::sin(e), std::cos(a) * std::cos(e)), 1e-5));
    EXPECT_TRUE(camera.forward().isApprox(-to_eye, 1e-5));
    EXPECT_NEAR(camera.down().y(), -std::cos(e), 1e-5);  // +Y is up in the picture
    EXPECT_NEAR(camera.intrinsic(0, 0), camera.intrinsic(1, 1), 1e-9);  // square pixels
  }
}

TEST(PinholeCamera, SupersamplingKeepsEveryPointInItsPlace) {
  auto camera = ring_camera(60, 10, 64, 48);
  camera.intrinsic(0, 1) = 0.3;  // skew and an off-centre principal point too
  camera.intrinsic(0, 2) += 5;
  const auto fine = camera.supersampled(3);
  EXPECT_EQ(fine.width, 192);
  EXPECT_EQ(fine.height, 144);
  for (const Eigen::Vector3d point : {Eigen::Vector3d(0.1, 0.9, 0.0), Eigen::Vector3d(-0.3, 0.2, 0.25)}) {
    // Pixel u of the coarse picture covers [u - 0.5, u + 0.5); fine pixels 3u - 1 .. 3u + 1.
    const Eigen::Vector2d coarse = camera.project(point), finer = fine.project(point);
    EXPECT_NEAR(finer.x(), 3 * (coarse.x() + 0.5) - 0.5, 1e-9);
    EXPECT_NEAR(finer.y(), 3 * (coarse.y() + 0.5) - 0.5, 1e-9);
  }
}

TEST(PinholeCamera, CroppingKeepsTheRaysAndShiftsThePixels) {
  const auto camera = ring_camera(60, 10, 64, 48);
  const auto box = camera.cropped(10, 5, 40, 30);
  EXPECT_EQ(box.width, 30);
  EXPECT_EQ(box.height, 25);
  for (const Eigen::Vector3d point : {Eigen::Vector3d(0.1, 0.9, 0.0), Eigen::Vector3d(-0.3, 0.2, 0.25)}) {
    const Eigen::Vector2d whole = camera.project(point), part = box.project(point);
    EXPECT_NEAR(part.x(), whole.x() - 10, 1e-9);
    EXPECT_NEAR(part.y(), whole.y() - 5, 1e-9);
  }
  EXPECT_TRUE(box.centre().isApprox(camera.centre()));
  testing::expect_error([&] { camera.cropped(10, 5, 70, 30); }, {"crop box", "64 x 48"});
  testing::expect_error([&] { camera.cropped(10, 5, 10, 30); }, {"crop box"});
}

TEST(PinholeCamera, OrbitingTurnsTheWorldAboutTheVerticalThroughThePivot) {
  const auto camera = ring_camera(0, 0, 64, 64);
  const Eigen::Vector3d pivot(0.05, 0.85, 0.05), point(0.3, 1.2, 0.1);
  const double angle = 0.7;
  // The orbited camera sees `point` where the original sees it turned by `angle` about +Y through the pivot.
  const Eigen::Vector3d d = point - pivot;
  const Eigen::Vector3d turned =
      pivot + Eigen::Vector3d(std::cos(angle) * d.x() + std::sin(angle) * d.z(), d.y(),
                              -std::sin(angle) * d.x() + std::cos(angle) * d.z());
  EXPECT_TRUE(camera.orbited(angle, pivot).project(point).isApprox(camera.project(turned), 1e-9));
  EXPECT_TRUE(camera.orbited(2 * M_PI, pivot).extrinsic.isApprox(camera.extrinsic, 1e-9));
  EXPECT_NEAR((camera.orbited(1.0, pivot).centre() - pivot).norm(), (camera.centre() - pivot).norm(), 1e-9);
}

TEST(PinholeCamera, RaysPassThroughTheProjectedPoints) {
  const auto pinhole = ring_camera(60, -10, 64, 64);
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
  auto camera = ring_camera(0, 0, 32, 32);
  auto scaled = camera;
  scaled.extrinsic.topLeftCorner<3, 3>() *= 2;
  testing::expect_error([&] { scaled.validate("cameras.npz: camera 3"); }, {"cameras.npz: camera 3", "rotation"});
  auto bad_focal = camera;
  bad_focal.intrinsic(0, 0) = -5;
  testing::expect_error([&] { bad_focal.validate("cam"); }, {"cam", "focal"});
  auto skewed = camera;
  skewed.intrinsic(0, 1) = 1e3;
  testing::expect_error([&] { skewed.validate("cam"); }, {"cam", "skew"});
}

TEST(PinholeCamera, FromMatricesReadsTensorsRowMajorAndValidates) {
  const auto camera = ring_camera(0.7, 0.2, 64, 48);
  auto k = torch::empty({3, 3}, torch::kFloat32), e = torch::empty({4, 4}, torch::kFloat64);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) k[r][c] = camera.intrinsic(r, c);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) e[r][c] = camera.extrinsic(r, c);
  const auto read = PinholeCamera::from_matrices(k, e.t().contiguous().t(), 64, 48, "cam");  // strided too
  EXPECT_TRUE(read.intrinsic.isApprox(camera.intrinsic, 1e-6));
  EXPECT_TRUE(read.extrinsic.isApprox(camera.extrinsic, 1e-12));
  EXPECT_EQ(read.width, 64);
  testing::expect_error([&] { PinholeCamera::from_matrices(k, e.narrow(0, 0, 3), 64, 48, "render"); },
                        {"render: extrinsic", "[4, 4]"});
  testing::expect_error([&] { PinholeCamera::from_matrices(k, e * 2, 64, 48, "render"); }, {"render"});
  testing::expect_error([&] { PinholeCamera::from_matrices(k.to(torch::kInt64), e, 64, 48, "render"); },
                        {"render: intrinsic", "floating"});
}

}  // namespace
}  // namespace fskin
