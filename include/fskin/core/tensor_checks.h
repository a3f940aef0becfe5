#pragma once
// Argument validation for tensors crossing the public API. Shapes are written
// with -1 for "any size", e.g. expect_shape(x, {-1, -1, 3}, "x_posed").
#include <torch/types.h>

#include <initializer_list>
#include <string>
#include <vector>

namespace fskin {

// Human-readable shape, e.g. "[8, 2000, 3]".
std::string shape_string(at::IntArrayRef shape);

// Throws fskin::Error unless `tensor` is defined and matches `expected` (-1 = any).
void expect_shape(const torch::Tensor& tensor, std::initializer_list<int64_t> expected,
                  const std::string& name);

// Throws fskin::Error if `tensor` holds NaN or +-inf; `name` says which input.
void expect_finite(const torch::Tensor& tensor, const std::string& name);
// The same for a CPU tensor; a CUDA tensor is not read back, since each read
// is a host synchronisation: on CUDA the callers fold the check into a read
// they make anyway (Deformer::forward).
void expect_finite_on_cpu(const torch::Tensor& tensor, const std::string& name);

// Throws fskin::Error unless `tensor` is floating point.
void expect_floating(const torch::Tensor& tensor, const std::string& name);

}  // namespace fskin
