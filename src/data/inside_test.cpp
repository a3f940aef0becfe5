// Inside test by ray casting with signed crossings and a vote.
//
// Why this is right:
// - Closed meshes, including several closed parts that overlap (a body built
//   from separate limbs, a jacket over a torso): along any ray from p, the sum
//   over crossings of sign(n . d) (+1 where the ray leaves a part through a
//   face whose outward normal n points along the ray direction d, -1 where it
//   enters) is the winding number of the surface around p, whatever the ray
//   direction. It counts how many parts contain p, so "winding != 0" is the
//   union of the parts. Plain parity (odd number of crossings) would call the
//   overlap of two parts outside; the signed count does not. Using != 0 rather
//   than >= 1 also accepts a mesh that is consistently inside-out.
// - Open meshes (holes, as in scans): a ray that escapes through a hole misses
//   one crossing and gets the wrong winding number, but only the rays that pass
//   through the hole do. Casting kRays rays in fixed, well-spread directions and
//   taking the majority makes a point near a hole wrong only when most of its
//   rays leave through that hole, i.e. when the hole covers most of what the
//   point "sees", which does not happen for holes that are small against the
//   body (scan gaps at the soles, neck or wrists). The same vote absorbs rays
//   that graze an edge or a vertex and count a crossing twice or not at all
//   (Embree's triangle test is not watertight).
// The directions are fixed (not random) so occupancy is deterministic, and
// not aligned with the axes, along which modelled meshes often have edges.
#include "fskin/data/inside_test.h"

#include <ATen/Parallel.h>
#include <torch/torch.h>

#include <array>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

#ifdef FSKIN_WITH_EMBREE
#include <embree3/rtcore.h>
#endif

namespace fskin {

bool inside_test_available() {
#ifdef FSKIN_WITH_EMBREE
  return true;
#else
  return false;
#endif
}

#ifdef FSKIN_WITH_EMBREE

namespace {

// kRays directions on a Fibonacci spiral over the sphere (evenly spread),
// rotated off the coordinate axes.
std::array<std::array<float, 3>, InsideTest::kRays> ray_directions() {
  std::array<std::array<float, 3>, InsideTest::kRays> dirs{};
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < InsideTest::kRays; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / InsideTest::kRays;
    const double r = std::sqrt(1.0 - z * z);
    const double phi = golden * i + 0.3;
    dirs[i] = {static_cast<float>(r * std::cos(phi)), static_cast<float>(z),
               static_cast<float>(r * std::sin(phi))};
  }
  return dirs;
}

// What the occlusion filter accumulates along one ray. Embree passes our
// context back to the filter; the RTCIntersectContext must come first.
struct CrossingContext {
  RTCIntersectContext embree;
  const float* face_normals;  // [F, 3] unnormalised outward normals
  int winding = 0;
  // Embree may report a triangle more than once per ray; count each once.
  static constexpr int kMaxHits = 64;
  unsigned hits[kMaxHits];
  int num_hits = 0;
};

void count_crossing(const RTCFilterFunctionNArguments* args) {
  auto* ctx = reinterpret_cast<CrossingContext*>(args->context);
  args->valid[0] = 0;  // reject every hit so traversal visits all of them
  const unsigned prim = RTCHitN_primID(args->hit, args->N, 0);
  for (int i = 0; i < ctx->num_hits; ++i)
    if (ctx->hits[i] == prim) return;
  if (ctx->num_hits < CrossingContext::kMaxHits) ctx->hits[ctx->num_hits++] = prim;
  const float* n = ctx->face_normals + 3 * static_cast<size_t>(prim);
  const float dot = n[0] * RTCRayN_dir_x(args->ray, args->N, 0) +
                    n[1] * RTCRayN_dir_y(args->ray, args->N, 0) +
                    n[2] * RTCRayN_dir_z(args->ray, args->N, 0);
  if (dot > 0) ++ctx->winding;        // leaving a part
  else if (dot < 0) --ctx->winding;   // entering a part
}

void check_device(RTCDevice device, const char* what) {
  const RTCError error = rtcGetDeviceError(device);
  FSKIN_CHECK(error == RTC_ERROR_NONE, "Embree failed in {} (error code {})", what,
              static_cast<int>(error));
}

}  // namespace

struct InsideTest::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  torch::Tensor face_normals;  // [F, 3] float32
  std::array<std::array<float, 3>, kRays> directions = ray_directions();

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

InsideTest::InsideTest(const Mesh& mesh) : impl_(std::make_unique<Impl>()) {
  mesh.validate("InsideTest mesh");
  FSKIN_CHECK(mesh.num_faces() > 0, "InsideTest: the mesh has no faces");
  const auto vertices = mesh.vertices.to(torch::kFloat32).contiguous();
  const auto faces = mesh.faces.to(torch::kInt64).contiguous();
  const auto corner = [&](int k) { return vertices.index_select(0, faces.select(1, k)); };
  impl_->face_normals =
      torch::cross(corner(1) - corner(0), corner(2) - corner(0), /*dim=*/1).contiguous();

  impl_->device = rtcNewDevice(nullptr);
  FSKIN_CHECK(impl_->device != nullptr, "Embree: could not create a device");
  impl_->scene = rtcNewScene(impl_->device);
  RTCGeometry geometry = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertex_buffer = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
      static_cast<size_t>(vertices.size(0))));
  auto* index_buffer = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
      static_cast<size_t>(faces.size(0))));
  check_device(impl_->device, "allocating the mesh buffers");
  std::copy_n(vertices.data_ptr<float>(), vertices.numel(), vertex_buffer);
  const int64_t* f = faces.data_ptr<int64_t>();
  for (int64_t i = 0; i < faces.numel(); ++i) index_buffer[i] = static_cast<unsigned>(f[i]);
  rtcSetGeometryOccludedFilterFunction(geometry, count_crossing);
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(impl_->scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  rtcCommitScene(impl_->scene);
  check_device(impl_->device, "building the ray-tracing hierarchy");
}

torch::Tensor InsideTest::contains(const torch::Tensor& points) const {
  expect_shape(points, {-1, 3}, "InsideTest points");
  const auto p = points.to(torch::kFloat32).contiguous();
  auto occupancy = torch::zeros({p.size(0)}, torch::kUInt8);
  const float* xyz = p.data_ptr<float>();
  uint8_t* out = occupancy.data_ptr<uint8_t>();
  const float* normals = impl_->face_normals.data_ptr<float>();
  const RTCScene scene = impl_->scene;
  const auto& directions = impl_->directions;
  at::parallel_for(0, p.size(0), 2048, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      int inside_votes = 0;
      for (const auto& d : directions) {
        CrossingContext ctx;
        rtcInitIntersectContext(&ctx.embree);
        ctx.face_normals = normals;
        RTCRay ray{};
        ray.org_x = xyz[3 * i];
        ray.org_y = xyz[3 * i + 1];
        ray.org_z = xyz[3 * i + 2];
        ray.dir_x = d[0];
        ray.dir_y = d[1];
        ray.dir_z = d[2];
        ray.tnear = 0.0f;
        ray.tfar = INFINITY;
        ray.mask = 0xFFFFFFFFu;
        rtcOccluded1(scene, &ctx.embree, &ray);
        inside_votes += ctx.winding != 0;
      }
      out[i] = static_cast<uint8_t>(2 * inside_votes > kRays);
    }
  });
  return occupancy;
}

#else  // FSKIN_WITH_EMBREE

struct InsideTest::Impl {};

InsideTest::InsideTest(const Mesh&) {
  fail("the inside test needs Embree 3, but fskin was built without Embree "
       "(install libembree-dev and re-run CMake)");
}

torch::Tensor InsideTest::contains(const torch::Tensor&) const {
  fail("the inside test needs Embree 3, but fskin was built without Embree");
}

#endif  // FSKIN_WITH_EMBREE

InsideTest::~InsideTest() = default;
InsideTest::InsideTest(InsideTest&&) noexcept = default;
InsideTest& InsideTest::operator=(InsideTest&&) noexcept = default;

}  // namespace fskin
