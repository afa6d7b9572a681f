// Point files for neighbour queries (docs/file-formats.md, "Point files"): PLY point clouds (ascii or
// binary_little_endian; the vertex element's x, y, z, float or double; other properties and elements skipped) and
// CSV (x,y,z a line; a first line that is not numbers is a header). What `rtusim query` reads.
#pragma once

#include <string>
#include <vector>

#include "hwmodel/interface/vec.h"

namespace rtu::host {

// Throws Error naming the file and the problem: missing, unknown format, malformed header or line, a count the
// file's size cannot hold, a coordinate that is not finite or beyond 2^62.
std::vector<hw::Vec3> read_points(const std::string& path);
// CSV with the header "x,y,z" (floats printed to round-trip) or, for a .ply path, binary_little_endian PLY.
void write_points(const std::string& path, const std::vector<hw::Vec3>& points);

}  // namespace rtu::host
