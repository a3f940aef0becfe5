// Voxel boxes, meshes, nearest vertices and the diffusion of weights into a grid.
#include "bindings.h"

#include "fmt/format.h"
#include "fskin/core/error.h"
#include "fskin/fields/preset_skinning_field.h"
#include "fskin/geometry/nearest_vertex.h"
#include "fskin/geometry/voxel_box.h"
#include "fskin/io/mesh_io.h"

namespace fskin::python {

void bind_geometry(py::module_& m) {
  py::class_<VoxelBox>(m, "VoxelBox", "The canonical box of a voxel skinning grid (docs/conventions.md)")
      .def_static(
          "fit",
          [](const torch::Tensor& points, int64_t longest_voxels, double padding) {
            return VoxelBox::fit(points, longest_voxels, padding);
          },
          py::arg("points"), py::arg("longest_voxels") = 32, py::arg("padding") = 0.05,
          "Box around points [N, 3]: `longest_voxels` along the longest side, near-cubic voxels")
      .def_static(
          "around",
          [](const torch::Tensor& points, std::tuple<int64_t, int64_t, int64_t> shape, double padding, double z_factor) {
            return VoxelBox::around(points, fskin::GridShape{std::get<0>(shape), std::get<1>(shape), std::get<2>(shape)},
                                    padding, z_factor);
          },
          py::arg("points"), py::arg("shape"), py::arg("padding") = 1.2, py::arg("z_factor") = 4.0,
          "The papers' box: offset -centre, scale 1 / (max extent / 2 * padding), times z_factor along z; "
          "shape (D, H, W)")
      .def_property_readonly("shape",
                             [](const VoxelBox& b) {
                               return py::make_tuple(b.shape.depth, b.shape.height, b.shape.width);
                             },
                             "Voxels along (z, y, x): (D, H, W)")
      .def_property_readonly(
          "offset", [](const VoxelBox& b) { return b.offset; },
          "(x, y, z) added to canonical points before scaling: grid coordinates u = (x + offset) * scale")
      .def_property_readonly(
          "scale", [](const VoxelBox& b) { return b.scale; }, "(x, y, z): u = (x + offset) * scale, in [-1, 1]")
      .def("contains", &VoxelBox::contains, py::arg("points"), "Whether points [..., 3] lie inside the box -> bool [...]")
      .def("voxel_centres", [](const VoxelBox& b) { return b.voxel_centres(); },
           "Canonical positions of the voxel centres [D, H, W, 3]")
      .def("__repr__",
           [](const VoxelBox& b) {
             return fmt::format("VoxelBox(shape=({}, {}, {}), offset=({:g}, {:g}, {:g}), scale=({:g}, {:g}, {:g}))",
                                b.shape.depth, b.shape.height, b.shape.width, b.offset[0], b.offset[1], b.offset[2],
                                b.scale[0], b.scale[1], b.scale[2]);
           },
           "VoxelBox(shape=(D, H, W), offset=(x, y, z), scale=(x, y, z))")
      .def(py::pickle(
          [](const VoxelBox& b) {
            return py::make_tuple(b.offset, b.scale, py::make_tuple(b.shape.depth, b.shape.height, b.shape.width));
          },
          [](const py::tuple& state) {
            FSKIN_CHECK(state.size() == 3, "VoxelBox: a pickled state has 3 parts, got {}", state.size());
            VoxelBox b;
            b.offset = state[0].cast<std::array<double, 3>>();
            b.scale = state[1].cast<std::array<double, 3>>();
            const auto shape = state[2].cast<std::tuple<int64_t, int64_t, int64_t>>();
            b.shape = fskin::GridShape{std::get<0>(shape), std::get<1>(shape), std::get<2>(shape)};
            b.validate("VoxelBox (unpickled)");
            return b;
          }));
  m.def(
      "diffuse_weights_to_grid",
      [](const torch::Tensor& vertices, const torch::Tensor& weights, const VoxelBox& box, int smoothing_iterations,
         double surface_band) {
        fskin::WeightDiffusionOptions o;
        o.smoothing_iterations = smoothing_iterations;
        o.surface_band = surface_band;
        return fskin::diffuse_weights_to_grid(vertices, weights, box, o)->grid_weights();
      },
      py::arg("vertices"), py::arg("weights"), py::arg("box"), py::arg("smoothing_iterations") = 10,
      py::arg("surface_band") = 1.0,
      "A body model's skinning weights [V, J] at its vertices [V, 3] as a voxel grid [D, H, W, J] over box: nearest "
      "vertex, then smoothing passes off the surface (fields/preset_skinning_field.h)");
  m.def(
      "write_mesh",
      [](const std::string& path, const torch::Tensor& vertices, const torch::Tensor& faces,
         const std::optional<torch::Tensor>& colors) {
        // Casts below would silently drop imaginary parts or round fractional indices.
        FSKIN_CHECK(vertices.is_floating_point(), "{}: vertices must be real floating point, got {}", path,
                    c10::toString(vertices.scalar_type()));
        FSKIN_CHECK(!faces.is_floating_point() && !faces.is_complex() && faces.scalar_type() != torch::kBool,
                    "{}: faces must be integer vertex indices, got {}", path, c10::toString(faces.scalar_type()));
        fskin::Mesh mesh{vertices.detach().to(torch::kCPU, torch::kFloat32).contiguous(),
                         faces.to(torch::kCPU, torch::kInt64).contiguous(),
                         colors ? colors->to(torch::kCPU, torch::kUInt8).contiguous() : torch::Tensor()};
        mesh.validate(path);
        fskin::io::write_mesh(path, mesh);
      },
      py::arg("path"), py::arg("vertices"), py::arg("faces"), py::arg("colors") = py::none(),
      "Write a mesh (vertices [V, 3], faces [F, 3], colours [V, 3] uint8) as .ply or .obj");
  m.def(
      "nearest_vertices",
      [](const torch::Tensor& points, const torch::Tensor& vertices) {
        const auto nearest = fskin::nearest_vertices(points, vertices);
        return py::make_tuple(nearest.index, nearest.distance);
      },
      py::arg("points"), py::arg("vertices"),
      "The nearest vertex of each point (k-d tree): points [Q, 3], vertices [V, 3] -> (index [Q] int64, "
      "distance [Q] float32)");
  m.def(
      "read_mesh",
      [](const std::string& path) {
        const auto mesh = fskin::io::read_mesh(path);
        return py::make_tuple(mesh.vertices, mesh.faces);
      },
      py::arg("path"), "Read a .ply or .obj mesh: (vertices [V, 3], faces [F, 3])");
}

}  // namespace fskin::python
