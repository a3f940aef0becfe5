// broyden_lanes: validates the inputs, fills the raw lane views and
// dispatches on device and dtype.
#include "fskin/ops/broyden_lanes.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "ops/broyden_lanes/broyden_lanes_kernel.h"
#include "ops/common/run_on_device.h"

namespace fskin {

static_assert(kLaneActive == static_cast<uint8_t>(broyden::LaneState::Active) &&
                  kLaneConverged == static_cast<uint8_t>(broyden::LaneState::Converged) &&
                  kLaneFailed == static_cast<uint8_t>(broyden::LaneState::Failed),
              "BroydenLanes::state values must be the solver's LaneState");

namespace {

void check_lanes(const BroydenLanes& lanes, const char* op) {
  const int64_t P = lanes.x.size(0);
  expect_shape(lanes.x, {P, 3}, std::string(op) + ": lanes.x");
  expect_shape(lanes.inverse_jacobian, {P, 3, 3}, std::string(op) + ": lanes.inverse_jacobian");
  expect_shape(lanes.residual, {P, 3}, std::string(op) + ": lanes.residual");
  expect_shape(lanes.step, {P, 3}, std::string(op) + ": lanes.step");
  expect_shape(lanes.state, {P}, std::string(op) + ": lanes.state");
  expect_shape(lanes.iterations, {P}, std::string(op) + ": lanes.iterations");
  for (const auto* t : {&lanes.inverse_jacobian, &lanes.residual, &lanes.step}) {
    FSKIN_CHECK(t->scalar_type() == lanes.x.scalar_type() && t->is_contiguous() && t->device() == lanes.x.device(),
                "{}: lane tensors must be contiguous, of one dtype and on one device", op);
  }
  FSKIN_CHECK(lanes.x.is_contiguous() && lanes.state.scalar_type() == torch::kUInt8 &&
                  lanes.iterations.scalar_type() == torch::kUInt8,
              "{}: lanes.x must be contiguous and state / iterations uint8", op);
}

template <typename T>
broyden::LanesView<T> view_of(BroydenLanes& l) {
  return {l.x.data_ptr<T>(),        l.inverse_jacobian.data_ptr<T>(), l.residual.data_ptr<T>(), l.step.data_ptr<T>(),
          l.state.data_ptr<uint8_t>(), l.iterations.data_ptr<uint8_t>(), l.x.size(0)};
}

template <typename T>
broyden::SearchParams<T> params_of(const BroydenSearchOptions& o) {
  FSKIN_CHECK(o.max_iterations >= 0 && o.max_iterations <= 255,
              "broyden_lanes: max_iterations = {} must be in 0..255", o.max_iterations);
  FSKIN_CHECK(o.converge_sq > 0 && o.diverge_sq > o.converge_sq,
              "broyden_lanes: thresholds must satisfy 0 < converge_sq ({}) < diverge_sq ({})", o.converge_sq,
              o.diverge_sq);
  return {o.max_iterations, static_cast<T>(o.converge_sq), static_cast<T>(o.diverge_sq),
          static_cast<T>(o.denominator_eps), o.final_step};
}

}  // namespace

BroydenLanes start_broyden_lanes(const torch::Tensor& x0, const torch::Tensor& residual,
                                 const torch::Tensor& jacobian) {
  expect_shape(x0, {-1, 3}, "start_broyden_lanes: x0");
  const int64_t P = x0.size(0);
  expect_shape(residual, {P, 3}, "start_broyden_lanes: residual");
  expect_shape(jacobian, {P, 3, 3}, "start_broyden_lanes: jacobian");
  const auto dtype = x0.scalar_type();
  FSKIN_CHECK(dtype == torch::kFloat32 || dtype == torch::kFloat64, "start_broyden_lanes: x0 must be float32 or float64");
  FSKIN_CHECK(residual.device() == x0.device() && jacobian.device() == x0.device(),
              "start_broyden_lanes: all inputs must be on one device");
  BroydenLanes lanes;
  lanes.x = x0.detach().to(dtype).contiguous().clone();
  lanes.residual = residual.detach().to(dtype).contiguous().clone();
  lanes.inverse_jacobian = torch::empty({P, 3, 3}, lanes.x.options());
  lanes.step = torch::zeros({P, 3}, lanes.x.options());
  lanes.state = torch::empty({P}, lanes.x.options().dtype(torch::kUInt8));
  lanes.iterations = torch::empty({P}, lanes.state.options());
  if (P == 0) return lanes;
  const auto jac = jacobian.detach().to(dtype).contiguous();
  AT_DISPATCH_FLOATING_TYPES(dtype, "start_broyden_lanes", [&] {
    const auto v = view_of<scalar_t>(lanes);
    const scalar_t* j = jac.data_ptr<scalar_t>();
    run_on_device(
        lanes.x, "start_broyden_lanes", [&] { broyden::start_lanes_cpu(v, j); },
        [&](void* stream) { broyden::start_lanes_cuda(v, j, stream); });
  });
  return lanes;
}

torch::Tensor step_broyden_lanes(BroydenLanes& lanes, int iteration, const BroydenSearchOptions& options) {
  check_lanes(lanes, "step_broyden_lanes");
  FSKIN_CHECK(iteration >= 0, "step_broyden_lanes: iteration {} must be >= 0", iteration);
  if (lanes.x.size(0) > 0) {
    AT_DISPATCH_FLOATING_TYPES(lanes.x.scalar_type(), "step_broyden_lanes", [&] {
      const auto v = view_of<scalar_t>(lanes);
      const auto params = params_of<scalar_t>(options);
      run_on_device(
          lanes.x, "step_broyden_lanes", [&] { broyden::step_lanes_cpu(v, iteration, params); },
          [&](void* stream) { broyden::step_lanes_cuda(v, iteration, params, stream); });
    });
  }
  return (lanes.state == kLaneActive).nonzero().squeeze(1);
}

void update_broyden_lanes(BroydenLanes& lanes, const torch::Tensor& stepped, const torch::Tensor& residual,
                          const BroydenSearchOptions& options) {
  check_lanes(lanes, "update_broyden_lanes");
  expect_shape(stepped, {-1}, "update_broyden_lanes: stepped");
  expect_shape(residual, {stepped.size(0), 3}, "update_broyden_lanes: residual");
  FSKIN_CHECK(stepped.scalar_type() == torch::kInt64 && stepped.device() == lanes.x.device() &&
                  residual.device() == lanes.x.device(),
              "update_broyden_lanes: stepped must be int64 indices and residual on the lanes' device");
  if (stepped.numel() == 0) return;
  const auto index = stepped.contiguous();
  const auto r = residual.detach().to(lanes.x.scalar_type()).contiguous();
  AT_DISPATCH_FLOATING_TYPES(lanes.x.scalar_type(), "update_broyden_lanes", [&] {
    const auto v = view_of<scalar_t>(lanes);
    const int64_t* idx = index.data_ptr<int64_t>();
    const scalar_t* rp = r.data_ptr<scalar_t>();
    const auto eps = static_cast<scalar_t>(options.denominator_eps);
    run_on_device(
        lanes.x, "update_broyden_lanes", [&] { broyden::update_lanes_cpu(v, idx, rp, index.size(0), eps); },
        [&](void* stream) { broyden::update_lanes_cuda(v, idx, rp, index.size(0), eps, stream); });
  });
}

torch::Tensor rank_starts(const torch::Tensor& own_weights, int64_t count) {
  expect_shape(own_weights, {-1, -1}, "rank_starts: own_weights");
  const int64_t P = own_weights.size(0), S = own_weights.size(1);
  FSKIN_CHECK(S >= 1 && S <= broyden::kMaxRankedStarts, "rank_starts: {} starts, expected 1..{}", S,
              broyden::kMaxRankedStarts);
  FSKIN_CHECK(count >= 1 && count <= S, "rank_starts: count = {} must be in 1..{}", count, S);
  expect_floating(own_weights, "rank_starts: own_weights");
  const auto w = own_weights.detach().contiguous();
  auto out = torch::empty({P, count}, w.options().dtype(torch::kInt64));
  if (P == 0) return out;
  AT_DISPATCH_FLOATING_TYPES(w.scalar_type(), "rank_starts", [&] {
    const scalar_t* wp = w.data_ptr<scalar_t>();
    int64_t* op = out.data_ptr<int64_t>();
    const int s = static_cast<int>(S), c = static_cast<int>(count);
    run_on_device(
        w, "rank_starts", [&] { broyden::rank_starts_cpu(wp, P, s, c, op); },
        [&](void* stream) { broyden::rank_starts_cuda(wp, P, s, c, op, stream); });
  });
  return out;
}

}  // namespace fskin
