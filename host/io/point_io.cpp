#include "host/io/point_io.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "host/io/error.h"
#include "host/io/files.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::host {

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

void check_point(const std::string& path, size_t i, const hw::Vec3& p) {
  for (int a = 0; a < 3; ++a)
    if (!(std::fabs(p[a]) <= hw::kMaxCoordinate))
      throw Error(path + ": point " + std::to_string(i) + " has a coordinate that is not finite or beyond 2^62");
}

// PLY's scalar types and their sizes.
int ply_size(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

std::vector<hw::Vec3> read_ply(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::getline(in, line);
  if (line != "ply" && line != "ply\r") throw Error(path + ": not a PLY file (no 'ply' line)");
  bool binary = false, in_vertex = false, seen_vertex = false;
  uint64_t count = 0, stride = 0;
  int offset[3] = {-1, -1, -1}, type_size[3] = {0, 0, 0}, column[3] = {-1, -1, -1}, props = 0;
  uint64_t before = 0;  // bytes of the elements before the vertices (binary): refused, for simplicity
  for (;;) {
    if (!std::getline(in, line)) throw Error(path + ": PLY header without end_header");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "end_header") break;
    if (word == "format") {
      std::string f;
      ls >> f;
      if (f == "binary_little_endian")
        binary = true;
      else if (f != "ascii")
        throw Error(path + ": PLY format '" + f + "' (ascii and binary_little_endian are read)");
    } else if (word == "element") {
      std::string name;
      uint64_t n = 0;
      if (!(ls >> name >> n)) throw Error(path + ": malformed PLY element line '" + line + "'");
      if (in_vertex || seen_vertex) {
        in_vertex = false;
        continue;  // elements after the vertices are not read
      }
      if (name == "vertex") {
        in_vertex = seen_vertex = true;
        count = n;
      } else if (n > 0) {
        before += n;
      }
    } else if (word == "property" && in_vertex) {
      std::string type, name;
      if (!(ls >> type >> name) || type == "list")
        throw Error(path + ": a list property in the PLY vertex element");
      const int size = ply_size(type);
      if (size == 0) throw Error(path + ": PLY property type '" + type + "'");
      const int axis = name == "x" ? 0 : name == "y" ? 1 : name == "z" ? 2 : -1;
      if (axis >= 0) {
        if (type != "float" && type != "float32" && type != "double" && type != "float64")
          throw Error(path + ": PLY coordinate " + name + " is of type " + type + " (float or double are read)");
        offset[axis] = int(stride);
        type_size[axis] = size;
        column[axis] = props;
      }
      stride += uint64_t(size);
      ++props;
    }
  }
  if (!seen_vertex) throw Error(path + ": PLY without a vertex element");
  for (int a = 0; a < 3; ++a)
    if (offset[a] < 0) throw Error(path + ": PLY vertex element without x, y and z");
  if (before > 0) throw Error(path + ": PLY elements before the vertex element (not read)");
  // The count must fit the file: binary stride bytes a point, ascii at least 2 bytes a property.
  const uint64_t left = uint64_t(std::filesystem::file_size(path)) - uint64_t(in.tellg());
  if (count > left / (binary ? stride : 2 * uint64_t(props)))
    throw Error(path + ": PLY declares " + std::to_string(count) + " vertices, more than its " +
                std::to_string(left) + " bytes can hold");
  std::vector<hw::Vec3> pts(count);
  std::vector<char> rec(stride);
  for (uint64_t i = 0; i < count; ++i) {
    if (binary) {
      if (!in.read(rec.data(), std::streamsize(stride)))
        throw Error(path + ": PLY ends within vertex " + std::to_string(i));
      for (int a = 0; a < 3; ++a) {
        if (type_size[a] == 4) {
          float v;
          std::memcpy(&v, rec.data() + offset[a], 4);
          pts[i][a] = v;
        } else {
          double v;
          std::memcpy(&v, rec.data() + offset[a], 8);
          pts[i][a] = float(v);
        }
      }
    } else {
      if (!std::getline(in, line)) throw Error(path + ": PLY ends within vertex " + std::to_string(i));
      std::istringstream ls(line);
      for (int c = 0; c < props; ++c) {
        double v;
        if (!(ls >> v))
          throw Error(path + ": PLY vertex " + std::to_string(i) + ": malformed line '" + line + "'");
        for (int a = 0; a < 3; ++a)
          if (column[a] == c) pts[i][a] = float(v);
      }
    }
    check_point(path, size_t(i), pts[i]);
  }
  return pts;
}

std::vector<hw::Vec3> read_csv(const std::string& path) {
  std::ifstream in(path);
  std::vector<hw::Vec3> pts;
  std::string line;
  for (size_t n = 1; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    double v[3];
    char c1 = 0, c2 = 0;
    std::istringstream ls(line);
    if (!(ls >> v[0] >> c1 >> v[1] >> c2 >> v[2]) || c1 != ',' || c2 != ',') {
      if (n == 1) continue;  // a header
      throw Error(path + ":" + std::to_string(n) + ": expected x,y,z, got '" + line + "'");
    }
    std::string rest;
    if (ls >> rest) throw Error(path + ":" + std::to_string(n) + ": more than x,y,z in '" + line + "'");
    pts.push_back(hw::Vec3(float(v[0]), float(v[1]), float(v[2])));
    check_point(path + ":" + std::to_string(n), pts.size() - 1, pts.back());
  }
  return pts;
}

}  // namespace

std::vector<hw::Vec3> read_points(const std::string& path) {
  check_input_file(path);
  std::vector<hw::Vec3> pts;
  if (ends_with(path, ".ply") || ends_with(path, ".PLY"))
    pts = read_ply(path);
  else if (ends_with(path, ".csv") || ends_with(path, ".CSV"))
    pts = read_csv(path);
  else
    throw Error(path + ": unknown point file (.ply or .csv)");
  if (pts.empty()) throw Error(path + ": no points");
  return pts;
}

void write_points(const std::string& path, const std::vector<hw::Vec3>& points) {
  std::ofstream out = open_output(path, std::ios::binary | std::ios::trunc);
  if (ends_with(path, ".ply")) {
    out << "ply\nformat binary_little_endian 1.0\nelement vertex " << points.size()
        << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    out.write(reinterpret_cast<const char*>(points.data()), std::streamsize(points.size() * sizeof(hw::Vec3)));
  } else {
    out << "x,y,z\n";
    char buf[64];
    for (const hw::Vec3& p : points) {
      std::snprintf(buf, sizeof buf, "%.9g,%.9g,%.9g\n", double(p.x), double(p.y), double(p.z));
      out << buf;
    }
  }
  finish_output(out, path);
}

}  // namespace rtu::host
