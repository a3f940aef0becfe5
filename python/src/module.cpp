// The Python bindings of libfskin (`import fskin`): thin wrappers, no
// algorithm of their own, one file per family (bindings.h). Tensors are the
// caller's torch tensors (the same LibTorch underneath), so results join the
// caller's autograd graph: the deformer's roots carry the implicit gradient
// (SNARF eq. 14 / Fast-SNARF eq. 17) to the posed points, the bone transforms
// and the skinning grid. fskin::Error becomes fskin.Error (a RuntimeError)
// with fskin's message. Loading the module also registers fskin's ops in
// PyTorch's dispatcher (torch.ops.fskin.*).
#include "bindings.h"
#include "fskin/core/error.h"
#include "fskin/version.h"

PYBIND11_MODULE(_fskin, m) {
  namespace python = fskin::python;
  m.doc() = "fskin: differentiable forward skinning (SNARF, Fast-SNARF, INS) in C++, from Python";
  m.attr("__version__") = FSKIN_VERSION;
  pybind11::register_exception<fskin::Error>(m, "Error", PyExc_RuntimeError);
  // Classes before the functions whose signatures name them.
  python::bind_body(m);
  python::bind_geometry(m);
  python::bind_import(m);
  python::bind_ops(m);
  python::bind_deformers(m);
  python::bind_invertible(m);
  python::bind_training(m);
  python::bind_inference(m);
  python::bind_avatars(m);
  python::bind_system(m);
}
