#pragma once
// Triangle mesh files: PLY (read: ascii and binary in either byte order; write:
// binary little-endian) and OBJ (read and write), with optional per-vertex colours
// (PLY red/green/blue, OBJ "v x y z r g b"). Polygons are fan-triangulated. Errors
// name the file and the problem: missing file, bad header, truncated data, faces
// with fewer than 3 vertices, face index out of range, NaN/inf coordinates.
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
