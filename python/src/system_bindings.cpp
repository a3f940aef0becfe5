// What this build of fskin has: OpenBLAS kernels, Embree, CUDA.
#include "bindings.h"

#include "fskin/core/device.h"
#include "fskin/data/inside_test.h"
#include "fskin/util/blas_kernels.h"

namespace fskin::python {

void bind_system(py::module_& m) {
  m.def("openblas_core", &fskin::openblas_core, "The kernels OpenBLAS runs (openblas_get_corename), or None");
  m.def("recommended_openblas_core", &fskin::openblas_core_setting,
        "The OPENBLAS_CORETYPE to start Python with where OpenBLAS fell back to its SSE3 kernels on a CPU with "
        "AVX2 / AVX-512 (the fskin CLI restarts itself with it), or None");
  m.def("built_with_embree", &fskin::inside_test_available, "Whether datasets can be built (Embree's inside test)");
  m.def("built_with_cuda", &fskin::built_with_cuda, "Whether the CUDA kernels are linked (device='cuda' works)");
}

}  // namespace fskin::python
