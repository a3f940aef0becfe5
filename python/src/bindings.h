#pragma once
// The Python module's families (python/src/*_bindings.cpp), each a function
// that adds its functions and classes to the module; module.cpp calls them.
// Bindings are thin: the library does the work (README "Layout").
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <torch/extension.h>

#include <optional>
#include <string>
#include <vector>

#include "fskin/data/pose_set.h"

namespace fskin::python {

namespace py = pybind11;

void bind_body(py::module_& m);        // BodyModel, built-in characters, pose generators
void bind_geometry(py::module_& m);    // VoxelBox, meshes, nearest vertices, weight diffusion
void bind_import(py::module_& m);      // rigged character files (fskin import)
void bind_ops(py::module_& m);         // the fused ops' typed wrappers (also torch.ops.fskin.*)
void bind_deformers(py::module_& m);   // FastSnarfDeformer, SnarfDeformer
void bind_invertible(py::module_& m);  // INS's Pin
void bind_training(py::module_& m);    // datasets, train, evaluate
void bind_inference(py::module_& m);   // Run: meshing, re-posing, animation, export
void bind_avatars(py::module_& m);     // image datasets and avatars
void bind_system(py::module_& m);      // build facts: OpenBLAS, Embree, CUDA

// An optional tensor argument as the library takes it (undefined when absent).
// Poses [N, J, 3] (and root translations [N, 3]) as a PoseSet for a model's
// joints; throws fskin::Error naming `what` on a wrong shape.
fskin::PoseSet pose_set(const torch::Tensor& poses, const std::optional<torch::Tensor>& trans,
                        const std::vector<std::string>& joint_names, const char* what);

inline torch::Tensor or_undefined(const std::optional<torch::Tensor>& t) { return t ? *t : torch::Tensor(); }

}  // namespace fskin::python
