#pragma once
// fskin's operators live in PyTorch's dispatcher, as torchvision's do: each op
// file declares its schema in a TORCH_LIBRARY_FRAGMENT(fskin, ...) and
// registers its kernels by dispatch key (CPU, CUDA when built with it,
// Autograd for the differentiable ones). The C++ API calls the op through the
// dispatcher, so C++, Python (torch.ops.fskin.*), TorchScript and other
// extensions reach the same kernels.
//
// The registrations sit in the op's own .cpp, next to its C++ entry point:
// fskin is a static library, and the linker keeps a translation unit only
// when something references it; a registration-only file would be dropped.
#include <ATen/core/dispatch/Dispatcher.h>

namespace fskin {

// The typed handle of fskin::<name>, looked up once per call site (callers
// keep it in a function-local static).
template <typename Signature>
c10::TypedOperatorHandle<Signature> fskin_operator(const char* qualified_name) {
  return c10::Dispatcher::singleton().findSchemaOrThrow(qualified_name, "").template typed<Signature>();
}

}  // namespace fskin
