#pragma once
// Triangle mesh files: PLY (ascii and binary little-endian read; binary write)
// and OBJ (read and write). Errors name the file and the problem: missing file,
// truncated data, non-triangular faces that cannot be triangulated, face index
// out of range, NaN/inf coordinates.
#include <string>

#include "fskin/geometry/mesh.h"

namespace fskin::io {

Mesh read_mesh(const std::string& path);  // by extension: .ply or .obj
void write_mesh(const std::string& path, const Mesh& mesh);  // atomically

Mesh read_ply(const std::string& path);
void write_ply(const std::string& path, const Mesh& mesh);
Mesh read_obj(const std::string& path);
void write_obj(const std::string& path, const Mesh& mesh);

}  // namespace fskin::io
