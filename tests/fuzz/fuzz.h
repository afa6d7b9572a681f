// libFuzzer targets for rtu's untrusted inputs (docs/guide/hardening.md). Each target is a function of the input
// bytes that returns 0; expected rejections (host::Error, std::invalid_argument) are caught inside, any other
// exception or a broken invariant (RTU_FUZZ_CHECK) aborts, which libFuzzer records as a crash. The same functions
// run in the default and asan builds over the committed seed corpora and crash reproducers (test_fuzz_corpus.cpp),
// so every crash found stays a regression test.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "hwmodel/interface/ray.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::fuzz {

int scene_file(const uint8_t* data, size_t size);         // scene description files (JSON) and builtin: specs
int mesh_import(const uint8_t* data, size_t size);        // mesh files through Assimp, flat and nested formats
int ray_file(const uint8_t* data, size_t size);           // ray and hit files, binary and CSV, then traced
int command_processor(const uint8_t* data, size_t size);  // packets and register writes on the model unit
int device_image(const uint8_t* data, size_t size);       // scene images bound by BIND_SCENE (fixed and float)
int config(const uint8_t* data, size_t size);             // timing keys (--set), fixed-point format fields
int texture(const uint8_t* data, size_t size);     // PNG and JPEG textures, then alpha-tested on every device
int point_file(const uint8_t* data, size_t size);  // PLY and CSV point files of rtusim query, then queried

struct Target {
  const char* name;
  int (*run)(const uint8_t*, size_t);
};
inline constexpr Target kTargets[] = {{"scene_file", scene_file},     {"mesh_import", mesh_import},
                                      {"ray_file", ray_file},         {"command_processor", command_processor},
                                      {"device_image", device_image}, {"config", config},
                                      {"texture", texture},           {"point_file", point_file}};

// Once per process: RTU_MEMORY_LIMIT=256M and RTU_IMPORT_TIMEOUT=10 unless set (inputs asking for more are
// refused, as on a small machine), and a scratch directory for targets that read files.
void init();
// A file of the scratch directory holding these bytes; returns its path.
std::string scratch_file(const std::string& name, const uint8_t* data, size_t size);

// A tiny scene with every primitive kind: an icosphere (80 triangles), two spheres and a plane.
const hw::Geometry& tiny_geometry();
// n rays from a fixed generator around the bounds b (deterministic).
std::vector<hw::Ray> rays_around(const hw::Aabb& b, size_t n, uint64_t seed);

// Reads the input front to back; past the end every value is 0.
class Bytes {
 public:
  Bytes(const uint8_t* d, size_t n) : m_d(d), m_n(n) {}
  bool empty() const { return m_pos >= m_n; }
  size_t left() const { return m_pos < m_n ? m_n - m_pos : 0; }
  template <class T>
  T get() {
    T v{};
    const size_t k = std::min(sizeof v, left());
    if (k) std::memcpy(&v, m_d + m_pos, k);
    m_pos += sizeof v;
    return v;
  }

 private:
  const uint8_t* m_d;
  size_t m_n, m_pos = 0;
};

}  // namespace rtu::fuzz

#define RTU_FUZZ_CHECK(cond)                                                                       \
  do {                                                                                             \
    if (!(cond)) {                                                                                 \
      std::fprintf(stderr, "rtu fuzz: invariant broken: %s (%s:%d)\n", #cond, __FILE__, __LINE__); \
      std::abort();                                                                                \
    }                                                                                              \
  } while (0)

// The libFuzzer entry point of a target (only in the asan preset's fuzz_* executables).
#ifdef RTU_LIBFUZZER
#define RTU_FUZZ_ENTRY(fn)                                                  \
  extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) { \
    return rtu::fuzz::fn(data, size);                                       \
  }
#else
#define RTU_FUZZ_ENTRY(fn)
#endif
