// Point files of `rtusim query` (host/io/point_io.cpp): the bytes as a PLY and as a CSV file. An accepted file's
// points are finite and within 2^62, round-trip through write_points bit for bit, and answer radius queries on the
// fixed unit: each point finds itself (distance 0), and the count of a query is at least its answer's size.
#include <algorithm>
#include <cmath>

#include "host/io/error.h"
#include "host/io/point_io.h"
#include "hwmodel/datapath/point_query.h"
#include "tests/fuzz/fuzz.h"

namespace rtu::fuzz {

namespace {

void check_points(const std::vector<hw::Vec3>& pts) {
  RTU_FUZZ_CHECK(!pts.empty());
  for (const hw::Vec3& p : pts)
    for (int a = 0; a < 3; ++a) RTU_FUZZ_CHECK(std::fabs(p[a]) <= hw::kMaxCoordinate);
  for (const char* name : {"w.ply", "w.csv"}) {
    const std::string path = scratch_file(name, nullptr, 0);
    host::write_points(path, pts);
    RTU_FUZZ_CHECK(host::read_points(path) == pts);
  }
  const std::vector<hw::Vec3> some(pts.begin(), pts.begin() + std::ptrdiff_t(std::min<size_t>(pts.size(), 256)));
  const hw::PointIndex index(some, 1.0f, hw::format_preset("default"));
  hw::QueryStats s;
  for (uint32_t i = 0; i < some.size(); ++i) {
    const hw::PointAnswer a = index.query(some[i], {hw::PointQuery::kRadius, 1024}, s);
    RTU_FUZZ_CHECK(std::binary_search(a.ids.begin(), a.ids.end(), i));
    RTU_FUZZ_CHECK(a.count >= a.ids.size());
  }
}

}  // namespace

int point_file(const uint8_t* data, size_t size) {
  init();
  for (const char* name : {"p.ply", "p.csv"}) {
    const std::string path = scratch_file(name, data, size);
    try {
      check_points(host::read_points(path));
    } catch (const host::Error&) {
    }
  }
  return 0;
}

}  // namespace rtu::fuzz

RTU_FUZZ_ENTRY(point_file)
