// INS's pose-conditioned invertible network.
#include "bindings.h"

#include "fskin/core/device.h"
#include "fskin/invertible/pin.h"
#include "fskin/ops/pin_pass.h"

namespace fskin::python {
namespace {

// INS's pose-conditioned invertible network (INS eq. 13-14) driven by pose
// embeddings the caller computes: differentiable in the points, the embedding
// and its parameters (torch.optim on parameters()); fused() is the inference
// kernel (ops/pin_pass.h), no gradients.
class PyPin {
 public:
  PyPin(int64_t num_layers, int64_t embedding_dim, int64_t space_hidden_dim, int64_t space_layers,
        int64_t map_hidden_dim, int64_t map_hidden_layers, bool linear_output, double first_omega,
        double hidden_omega)
      : pin_(options(num_layers, embedding_dim, space_hidden_dim, space_layers, map_hidden_dim, map_hidden_layers,
                     linear_output, first_omega, hidden_omega)) {}

  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& embedding) {
    return pin_->forward_embedded(x, embedding);
  }
  torch::Tensor inverse(const torch::Tensor& y, const torch::Tensor& embedding) {
    return pin_->inverse_embedded(y, embedding);
  }
  torch::Tensor fused(const torch::Tensor& x, const torch::Tensor& embedding, bool inverse) {
    torch::NoGradGuard no_grad;
    return fskin::fused_pin_pass(*pin_, x, embedding, inverse);
  }
  py::tuple fused_arguments(const torch::Tensor& embedding) {
    auto arguments = fskin::fused_pin_arguments(*pin_, embedding);
    return py::make_tuple(arguments.packed, arguments.shape);
  }
  std::vector<torch::Tensor> parameters() { return pin_->parameters(); }
  void to(const std::string& target) {
    if (target == "float32" || target == "float64") {
      pin_->to(target == "float64" ? torch::kFloat64 : torch::kFloat32);
      return;
    }
    pin_->to(fskin::parse_device(target, "Pin.to"));
  }

 private:
  static fskin::PinOptions options(int64_t num_layers, int64_t embedding_dim, int64_t space_hidden_dim,
                                   int64_t space_layers, int64_t map_hidden_dim, int64_t map_hidden_layers,
                                   bool linear_output, double first_omega, double hidden_omega) {
    fskin::PinOptions o;
    o.num_layers = num_layers;
    o.own_pose_encoder = false;
    o.coupling.embedding_dim = embedding_dim;
    o.coupling.space_hidden_dim = space_hidden_dim;
    o.coupling.space_layers = space_layers;
    o.coupling.space_linear_output = linear_output;
    o.coupling.first_omega = first_omega;
    o.coupling.hidden_omega = hidden_omega;
    o.coupling.map_hidden_dim = map_hidden_dim;
    o.coupling.map_hidden_layers = map_hidden_layers;
    o.validate();
    return o;
  }
  fskin::Pin pin_;
};

}  // namespace

void bind_invertible(py::module_& m) {
  py::class_<PyPin>(m, "Pin",
                    "INS's pose-conditioned invertible network (eq. 13-14) over pose embeddings [B, E] the caller "
                    "computes; identity at initialisation")
      .def(py::init<int64_t, int64_t, int64_t, int64_t, int64_t, int64_t, bool, double, double>(),
           py::arg("num_layers") = 6, py::arg("embedding_dim") = 16, py::arg("space_hidden_dim") = 32,
           py::arg("space_layers") = 2, py::arg("map_hidden_dim") = 8, py::arg("map_hidden_layers") = 2,
           py::arg("linear_output") = true, py::arg("first_omega") = 30.0, py::arg("hidden_omega") = 30.0,
           "num_layers coupling layers over pose embeddings of embedding_dim; each a SIREN over space "
           "(space_hidden_dim x space_layers, first / hidden omega) and a map MLP (map_hidden_dim x "
           "map_hidden_layers) (INS eq. 13-14)")
      .def("forward", &PyPin::forward, py::arg("x"), py::arg("embedding"), py::call_guard<py::gil_scoped_release>(),
           "PIN(x [B, N, 3], z [B, E]) -> [B, N, 3], differentiable")
      .def("inverse", &PyPin::inverse, py::arg("y"), py::arg("embedding"), py::call_guard<py::gil_scoped_release>(),
           "PIN^-1(y, z), differentiable")
      .def("fused", &PyPin::fused, py::arg("x"), py::arg("embedding"), py::arg("inverse") = false,
           py::call_guard<py::gil_scoped_release>(),
           "The fused inference kernel (float32, no gradients): the same map in one pass per point")
      .def("fused_arguments", &PyPin::fused_arguments, py::arg("embedding"),
           "(packed [B, P] float32, shape list) for torch.ops.fskin.pin_pass(points, packed, shape, inverse): the "
           "parameters folded with the pose embeddings [B, E] and the architecture")
      .def("parameters", &PyPin::parameters, "The network's parameters (tensors shared with it) for torch.optim")
      .def("to", &PyPin::to, py::arg("target"), "'float32', 'float64' or a device ('cpu', 'cuda')");
}

}  // namespace fskin::python
