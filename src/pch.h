// Precompiled header for fskin targets: only third-party headers that almost
// every translation unit needs and that are slow to parse.
#pragma once
#include <torch/torch.h>
#include <fmt/format.h>
#include <Eigen/Core>
#include <string>
#include <vector>
