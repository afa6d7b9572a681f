#include "host/io/ray_io.h"

#include <bit>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/limits.h"
#include "hwmodel/interface/commands.h"

namespace rtu::host {

static_assert(std::endian::native == std::endian::little, "ray and hit files are little-endian");

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// A file to read ("rb") or write ("wb"), checked first so that a directory or a missing folder is named as such.
File open_file(const std::string& path, const char* mode) {
  if (mode[0] == 'r')
    check_input_file(path);
  else
    check_output_file(path);
  File f(std::fopen(path.c_str(), mode));
  if (!f)
    throw Error(path + ": cannot open" + (mode[0] == 'r' ? "" : " for writing") + " (" + std::strerror(errno) +
                ")");
  return f;
}

// Memory a job needs per record read: a ray file is traced into as many 16-byte hits.
template <class T>
constexpr uint64_t kNeededPerRecord = sizeof(T) == sizeof(hw::Ray) ? sizeof(hw::Ray) + sizeof(hw::Hit) : sizeof(T);

template <class T>
std::vector<T> read_binary(const std::string& path, const char* what) {
  File f = open_file(path, "rb");
  if (std::fseek(f.get(), 0, SEEK_END) != 0) throw Error(path + ": cannot seek");
  const long size = std::ftell(f.get());
  if (size < 0) throw Error(path + ": cannot tell its size");
  std::rewind(f.get());
  if (size % long(sizeof(T)) != 0) {
    throw Error(path + ": size " + std::to_string(size) + " bytes is not a multiple of " +
                std::to_string(sizeof(T)) + " (one " + what + "): truncated, or not a " + what + " file");
  }
  check_memory(path + ": " + std::to_string(uint64_t(size) / sizeof(T)) + " " + what + "s",
               uint64_t(size) / sizeof(T) * kNeededPerRecord<T>);
  std::vector<T> out(size_t(size) / sizeof(T));
  if (!out.empty() && std::fread(out.data(), sizeof(T), out.size(), f.get()) != out.size())
    throw Error(path + ": read error");
  return out;
}

template <class T>
void write_binary(const std::string& path, const std::vector<T>& v) {
  File f = open_file(path, "wb");
  if (!v.empty() && std::fwrite(v.data(), sizeof(T), v.size(), f.get()) != v.size())
    throw Error(path + ": write error");
  if (std::fflush(f.get()) != 0) throw Error(path + ": write error");
}

// Splits a CSV line into exactly n numeric fields (strtof: accepts inf and nan).
// Field u32_index, if any, is an unsigned 32-bit integer stored to *u32.
bool parse_fields(const std::string& line, float* out, int n, int u32_index = -1, uint32_t* u32 = nullptr) {
  const char* p = line.c_str();
  for (int i = 0; i < n; ++i) {
    while (*p == ' ' || *p == '\t') ++p;
    char* end = nullptr;
    if (i == u32_index) {
      errno = 0;
      const unsigned long long x = std::strtoull(p, &end, 10);
      if (end == p || errno != 0 || x > 0xFFFFFFFFull) return false;
      *u32 = uint32_t(x);
    } else {
      out[i] = std::strtof(p, &end);
      if (end == p) return false;
    }
    p = end;
    while (*p == ' ' || *p == '\t' || *p == '\r') ++p;
    if (i + 1 < n) {
      if (*p != ',') return false;
      ++p;
    }
  }
  return *p == '\0';
}

std::string csv_float(float x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", double(x));  // 9 significant digits round-trip a float
  return buf;
}

// The shortest CSV line of a record ("0,0,0,0,0,0,0,0\n" for a ray) bounds the records a file can hold.
template <class T, class F>
void read_csv(const std::string& path, const char* header, uint64_t min_line, F&& on_line) {
  check_input_file(path);
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
  std::error_code ec;
  const uint64_t size = std::filesystem::file_size(path, ec);
  if (!ec)
    check_memory(path + ": up to " + std::to_string(size / min_line) + " records",
                 size / min_line * kNeededPerRecord<T>);
  std::string line;
  if (!std::getline(in, line)) throw Error(path + ": empty file (expected the header '" + header + "')");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line != header) throw Error(path + ": line 1: expected the header '" + std::string(header) + "'");
  size_t n = 1;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line == "\r") continue;
    if (!on_line(line)) throw Error(path + ": line " + std::to_string(n) + ": expected " + header);
  }
}

}  // namespace

bool is_csv_path(const std::string& path) {
  return path.size() >= 4 && path.compare(path.size() - 4, 4, ".csv") == 0;
}

std::vector<hw::Ray> read_rays(const std::string& path) {
  if (!is_csv_path(path)) return read_binary<hw::Ray>(path, "ray");
  std::vector<hw::Ray> rays;
  read_csv<hw::Ray>(path, kRayCsvHeader, 16, [&](const std::string& line) {
    float f[8];
    if (!parse_fields(line, f, 8)) return false;
    rays.push_back(hw::Ray{{f[0], f[1], f[2]}, f[3], {f[4], f[5], f[6]}, f[7]});
    return true;
  });
  return rays;
}

std::vector<hw::Hit> read_hits(const std::string& path) {
  if (!is_csv_path(path)) return read_binary<hw::Hit>(path, "hit");
  std::vector<hw::Hit> hits;
  read_csv<hw::Hit>(path, kHitCsvHeader, 8, [&](const std::string& line) {
    float f[4];
    uint32_t prim = 0;
    if (!parse_fields(line, f, 4, 1, &prim)) return false;
    hits.push_back(hw::Hit{f[0], prim, f[2], f[3]});
    return true;
  });
  return hits;
}

void write_rays(const std::string& path, const std::vector<hw::Ray>& rays) {
  if (!is_csv_path(path)) return write_binary(path, rays);
  std::ofstream out = open_output(path);
  out << kRayCsvHeader << '\n';
  for (const hw::Ray& r : rays) {
    out << csv_float(r.origin.x) << ',' << csv_float(r.origin.y) << ',' << csv_float(r.origin.z) << ','
        << csv_float(r.tmin) << ',' << csv_float(r.dir.x) << ',' << csv_float(r.dir.y) << ',' << csv_float(r.dir.z)
        << ',' << csv_float(r.tmax) << '\n';
  }
  finish_output(out, path);
}

void write_hits(const std::string& path, const std::vector<hw::Hit>& hits) {
  if (!is_csv_path(path)) return write_binary(path, hits);
  std::ofstream out = open_output(path);
  out << kHitCsvHeader << '\n';
  for (const hw::Hit& h : hits)
    out << csv_float(h.t) << ',' << h.prim << ',' << csv_float(h.u) << ',' << csv_float(h.v) << '\n';
  finish_output(out, path);
}

void write_hit_lists(const std::string& path, uint32_t k, const std::vector<hw::Hit>& lists,
                     const std::vector<uint64_t>& counts) {
  auto header = [&](size_t i) { return hw::cmd::hit_list_header(counts[i], k); };
  if (!is_csv_path(path)) {
    const size_t stride = size_t(hw::cmd::all_hits_list_bytes(k));
    std::vector<uint8_t> out(counts.size() * stride);
    const hw::Hit miss;
    for (size_t i = 0; i < counts.size(); ++i) {
      const hw::cmd::HitListHeader h = header(i);
      uint8_t* at = out.data() + i * stride;
      std::memcpy(at, &h, sizeof h);
      for (uint32_t j = 0; j < k; ++j)
        std::memcpy(at + 16 * (j + 1), j < h.kept ? &lists[i * k + j] : &miss, sizeof(hw::Hit));
    }
    return write_binary(path, out);
  }
  std::ofstream out = open_output(path);
  out << kHitListCsvHeader << '\n';
  for (size_t i = 0; i < counts.size(); ++i) {
    const hw::cmd::HitListHeader h = header(i);
    const std::string lead = std::to_string(i) + ',' + std::to_string(counts[i]) + ',' + std::to_string(h.kept) +
                             ',' + (h.flags ? "1" : "0") + ',';
    if (h.kept == 0) out << lead << ",,,,\n";
    for (uint32_t j = 0; j < h.kept; ++j) {
      const hw::Hit& x = lists[i * k + j];
      out << lead << j << ',' << csv_float(x.t) << ',' << x.prim << ',' << csv_float(x.u) << ',' << csv_float(x.v)
          << '\n';
    }
  }
  finish_output(out, path);
}

}  // namespace rtu::host
