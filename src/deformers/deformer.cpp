#include "fskin/deformers/deformer.h"

#include <cmath>
#include <functional>

#include <c10/core/impl/LocalDispatchKeySet.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/ops/filter_duplicate_roots.h"
#include "fskin/ops/implicit_gradient.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/util/stopwatch.h"

namespace fskin {

namespace {

// Undoes prepare() however forward() leaves.
struct PreparedPose {
  std::function<void()> release;
  ~PreparedPose() { release(); }
};

// The search and the blend run in single or double precision: Broyden's
// updates and the inverse bones are not stable in half precision.
void expect_search_precision(const torch::Tensor& points, const std::string& name) {
  const auto dtype = points.scalar_type();
  FSKIN_CHECK(dtype == torch::kFloat32 || dtype == torch::kFloat64,
              "{}: points must be float32 or float64 (the search is not stable in lower precision; cast with "
              ".float()), got {}",
              name, c10::toString(dtype));
}

// Inside torch.autocast the blend's matrix products would drop to half /
// bfloat16 while the search's inputs stay float32: the deformer runs in its
// inputs' precision whatever the caller's autocast region says.
using NoAutocast = c10::impl::ExcludeDispatchKeyGuard;

}  // namespace

DeformerOptions DeformerOptions::snarf() {
  DeformerOptions o;
  o.max_iterations = 50;
  o.converge_sq = 1e-10;  // |r| < 1e-5
  o.diverge_sq = 1.0;     // |r| > 1
  o.denominator_eps = 1e-6;
  o.final_step = false;
  o.gradient = GradientMode::Exact;
  o.remove_duplicates = false;
  o.chunk_points = 1 << 14;  // the MLP keeps activations per (point, start)
  return o;
}

DeformerOptions DeformerOptions::fast_snarf() { return DeformerOptions{}; }

DeformerOptions DeformerOptions::scaled(double length_unit) const {
  FSKIN_CHECK(length_unit > 0 && std::isfinite(length_unit), "DeformerOptions::scaled: length unit {} must be > 0",
              length_unit);
  DeformerOptions o = *this;
  o.converge_sq *= length_unit * length_unit;
  o.diverge_sq *= length_unit * length_unit;
  o.duplicate_distance *= length_unit;
  return o;
}

Deformer::Deformer(DeformerOptions options) : options_(std::move(options)) {
  FSKIN_CHECK(options_.chunk_points >= 1, "Deformer: chunk_points must be >= 1");
  FSKIN_CHECK(options_.max_iterations >= 0 && options_.max_iterations <= 255,
              "Deformer: max_iterations = {} must be in 0..255", options_.max_iterations);
}

DeformerOutput Deformer::forward(const torch::Tensor& x_posed, const torch::Tensor& bones) {
  expect_shape(x_posed, {-1, -1, 3}, "Deformer::forward: x_posed");
  expect_shape(bones, {x_posed.size(0), field().num_bones(), 4, 4}, "Deformer::forward: bones");
  expect_floating(x_posed, "Deformer::forward: x_posed");
  expect_floating(bones, "Deformer::forward: bones");
  expect_search_precision(x_posed, "Deformer::forward: x_posed");
  const NoAutocast no_autocast(c10::autocast_dispatch_keyset);
  FSKIN_CHECK(bones.device() == x_posed.device(), "Deformer::forward: x_posed and bones on different devices");
  const int64_t B = x_posed.size(0), N = x_posed.size(1), J = bones.size(1);
  const bool cuda = x_posed.is_cuda();
  const auto bones_x = bones.to(x_posed.dtype());
  // The rigid inverses seed the search (SNARF eq. 7). On the CPU bad inputs
  // fail here; on CUDA their check joins the one read of the statistics at
  // the end, so the search queues without waiting for the host.
  torch::Tensor inverses, inputs_ok;
  if (cuda) {
    auto inverse = invert_transforms_on_device(bones_x.detach());
    inverses = inverse.inverse;
    inputs_ok = inverse.invertible & torch::isfinite(x_posed.detach()).all();
  } else {
    expect_finite(x_posed, "Deformer::forward: x_posed");
    expect_finite(bones, "Deformer::forward: bones");
    inverses = invert_transforms(bones_x.detach());  // throws on singular bones
  }
  const auto start_inverses = inverses.index_select(1, candidate_index(J, bones.device()));

  bool wants_grad = torch::GradMode::is_enabled() && (x_posed.requires_grad() || bones.requires_grad());
  wants_grad = wants_grad || (torch::GradMode::is_enabled() && field().requires_grad());

  DeformerOutput out;
  DeformerStats& st = out.stats;
  Stopwatch precompute(cuda);
  prepare(bones_x);
  PreparedPose prepared{[this] { release(); }};
  st.precompute_seconds = precompute.elapsed();

  // Without gradients the chunks go straight into preallocated outputs, so 1e7
  // points cost the output and one chunk's temporaries, not twice the output.
  const int64_t I = options_.start_bones.slots(J);
  std::vector<torch::Tensor> xs;
  if (!wants_grad) out.x_canonical = torch::empty({B, N, I, 3}, x_posed.options());
  out.valid = torch::empty({B, N, I}, x_posed.options().dtype(torch::kBool));
  // Summed on the device and read once at the end: no host sync per chunk.
  auto iteration_sum = torch::zeros({}, x_posed.options().dtype(torch::kFloat64));
  for (int64_t begin = 0; begin < N; begin += options_.chunk_points) {
    const int64_t n = std::min(options_.chunk_points, N - begin);
    const auto chunk = x_posed.narrow(1, begin, n);
    Stopwatch search_timer(cuda);
    SearchResult found = [&] {
      torch::NoGradGuard no_grad;
      return search(chunk.detach(), start_inverses,
                    wants_grad && options_.gradient == GradientMode::Approximate);
    }();
    st.search_seconds += search_timer.elapsed();
    iteration_sum += found.iterations.sum().to(torch::kFloat64);

    Stopwatch filter_timer(cuda);
    if (options_.root_box) found.valid &= options_.root_box->contains(found.x);
    if (options_.remove_duplicates) found.valid = filter_duplicate_roots(found.x, found.valid, options_.duplicate_distance);
    st.filter_seconds += filter_timer.elapsed();

    Stopwatch gradient_timer(cuda);
    if (wants_grad) {
      xs.push_back(attach_gradients(found, chunk));
    } else {
      out.x_canonical.narrow(1, begin, n).copy_(found.x.masked_fill_(found.valid.logical_not().unsqueeze(-1), 0));
    }
    st.gradient_seconds += gradient_timer.elapsed();
    out.valid.narrow(1, begin, n).copy_(found.valid);
  }
  if (wants_grad) {
    out.x_canonical = xs.empty() ? torch::zeros({B, 0, I, 3}, x_posed.options())
                                 : (xs.size() == 1 ? xs[0] : torch::cat(xs, 1));
  }
  st.points = B * N;
  st.candidates = out.valid.numel();
  // The one read back to the host: the statistics and, on CUDA, the inputs' check.
  const auto totals =
      torch::stack({out.valid.sum().to(torch::kFloat64), iteration_sum,
                    inputs_ok.defined() ? inputs_ok.to(torch::kFloat64) : torch::ones({}, iteration_sum.options())})
          .cpu();
  const double* t = totals.data_ptr<double>();
  if (t[2] == 0) {
    // Bad inputs on CUDA: the host checks name the problem.
    expect_finite(x_posed.cpu(), "Deformer::forward: x_posed");
    expect_finite(bones.cpu(), "Deformer::forward: bones");
    invert_transforms(bones_x.detach().cpu());
    fail("Deformer::forward: bones are not invertible");
  }
  if (st.points > 0) {
    st.mean_valid = t[0] / static_cast<double>(st.points);
    st.mean_iterations = t[1] / static_cast<double>(st.candidates);
  }
  return out;
}

const torch::Tensor& Deformer::candidate_index(int64_t num_bones, const torch::Device& device) {
  // Cached per (bones, device): building it on the host and copying it to a
  // GPU would wait for the GPU's queue on every call.
  auto candidates = options_.start_bones.candidates(num_bones);
  if (!candidate_index_.defined() || candidate_index_.device() != device || candidates != candidates_) {
    candidate_index_ = torch::tensor(candidates, torch::kInt64).to(device);
    candidates_ = std::move(candidates);
  }
  return candidate_index_;
}

torch::Tensor Deformer::attach_gradients(const SearchResult& found, const torch::Tensor& x_posed) {
  // Roots only where valid: no [N, I, 3, 3] for candidates that failed.
  const auto index = found.valid.nonzero();  // [M, 3] (b, n, i), sorted by b
  const auto roots = found.x.index({found.valid});
  const auto n_index = index.select(1, 1);
  const auto b_index = index.select(1, 0);
  const int64_t B = found.x.size(0);
  // Rows per frame in one read (nonzero sorts by b), not one per frame.
  const auto counts = torch::bincount(b_index, {}, B).cpu();
  const auto* count = counts.data_ptr<int64_t>();
  std::vector<torch::Tensor> residuals, jinvs;
  int64_t offset = 0;
  for (int64_t b = 0; b < B; ++b) {
    const int64_t rows = count[b];
    if (rows == 0) continue;
    const auto x_b = roots.narrow(0, offset, rows);
    const auto n_b = n_index.narrow(0, offset, rows);
    offset += rows;
    // r = d(x*) - x' with the graph of the field, the bones and x' (SNARF eq. 12).
    residuals.push_back(deform_prepared(b, x_b) - x_posed[b].index_select(0, n_b));
    if (options_.gradient == GradientMode::Exact) {
      const auto jac = spatial_jacobian(b, x_b);
      const auto [inv, info] = torch::linalg_inv_ex(jac);
      // A singular Jacobian has no implicit gradient: give those roots none.
      jinvs.push_back(inv.masked_fill((info != 0).view({-1, 1, 1}), 0));
    }
  }
  auto x_full = torch::zeros_like(found.x);
  if (residuals.empty()) return x_full;
  const auto residual = torch::cat(residuals, 0);
  const auto jinv = options_.gradient == GradientMode::Exact ? torch::cat(jinvs, 0)
                                                             : found.inverse_jacobian.index({found.valid});
  const auto x_valid = attach_implicit_gradient(roots, jinv, residual);
  return x_full.index_put({found.valid}, x_valid);
}

BroydenSearchOptions Deformer::search_options() const {
  BroydenSearchOptions o;
  o.max_iterations = options_.max_iterations;
  o.converge_sq = options_.converge_sq;
  o.diverge_sq = options_.diverge_sq;
  o.denominator_eps = options_.denominator_eps;
  o.final_step = options_.final_step;
  return o;
}

torch::Tensor Deformer::spatial_jacobian(int64_t b, const torch::Tensor& x) {
  torch::AutoGradMode enable(true);
  const auto xr = x.detach().requires_grad_(true);
  const auto y = deform_prepared(b, xr);
  std::vector<torch::Tensor> rows;
  for (int64_t k = 0; k < 3; ++k) {
    rows.push_back(torch::autograd::grad({y.select(1, k).sum()}, {xr}, {}, /*retain_graph=*/k < 2)[0]);
  }
  return torch::stack(rows, 1).detach();  // [M, 3 (output), 3 (input)]
}

torch::Tensor Deformer::deform(const torch::Tensor& x_canonical, const torch::Tensor& bones) {
  expect_shape(x_canonical, {-1, -1, 3}, "Deformer::deform: x_canonical");
  expect_shape(bones, {x_canonical.size(0), field().num_bones(), 4, 4}, "Deformer::deform: bones");
  expect_finite(bones, "Deformer::deform: bones");
  expect_search_precision(x_canonical, "Deformer::deform: x_canonical");
  const NoAutocast no_autocast(c10::autocast_dispatch_keyset);
  const auto bones_x = bones.to(x_canonical.dtype());
  const int64_t N = x_canonical.size(1);
  if (!torch::GradMode::is_enabled()) {
    prepare(bones_x);
    PreparedPose prepared{[this] { release(); }};
    auto out = torch::empty_like(x_canonical);
    for (int64_t b = 0; b < x_canonical.size(0); ++b) {
      for (int64_t begin = 0; begin < N; begin += options_.chunk_points) {
        const int64_t n = std::min(options_.chunk_points, N - begin);
        out[b].narrow(0, begin, n).copy_(deform_prepared(b, x_canonical[b].narrow(0, begin, n)));
      }
    }
    return out;
  }
  std::vector<torch::Tensor> out;
  for (int64_t begin = 0; begin < N || begin == 0; begin += options_.chunk_points) {
    const auto chunk = x_canonical.narrow(1, begin, std::min(options_.chunk_points, N - begin));
    out.push_back(linear_blend_skinning(chunk, field().weights(chunk).to(chunk.dtype()), bones_x));
    if (N == 0) break;
  }
  return out.size() == 1 ? out[0] : torch::cat(out, 1);
}

}  // namespace fskin
