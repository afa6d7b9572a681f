// Ray and hit files: round trips, CSV and binary, and bad input.
#include <catch2/catch.hpp>

#include <unistd.h>
#include <cstring>

#include <filesystem>
#include <fstream>
#include <limits>

#include "host/io/error.h"
#include "host/io/ray_io.h"
#include "host/scene/ray_gen.h"
#include "tests/common/test_util.h"

using namespace rtu;
namespace fs = std::filesystem;

using rtu::test::temp_dir;

namespace {

void write_text(const fs::path& p, const std::string& s) {
  std::ofstream(p, std::ios::binary) << s;
}

}  // namespace

TEST_CASE("ray files round-trip bit-exactly in binary and CSV", "[io]") {
  const fs::path dir = temp_dir("ray_io");
  std::vector<hw::Ray> rays = host::incoherent_rays(hw::Aabb{hw::Vec3(-3.0f), hw::Vec3(5.0f)}, 1000, 3);
  rays[0].tmax = 1.25e-7f;
  rays[1].dir = hw::Vec3(-0.0f, 0.0f, 1.0f);
  for (const char* name : {"r.bin", "r.csv"}) {
    host::write_rays((dir / name).string(), rays);
    const std::vector<hw::Ray> back = host::read_rays((dir / name).string());
    REQUIRE(back.size() == rays.size());
    CHECK(std::memcmp(back.data(), rays.data(), rays.size() * sizeof(hw::Ray)) == 0);
  }
  CHECK(fs::file_size(dir / "r.bin") == rays.size() * 32);
}

TEST_CASE("hit files round-trip, misses as +inf and 0xFFFFFFFF", "[io]") {
  const fs::path dir = temp_dir("ray_io");
  const std::vector<hw::Hit> hits = {hw::Hit{}, hw::Hit{1.5f, 7, 0.25f, 0.5f},
                                     hw::Hit{3.0e-5f, 0xFFFFFFFEu, 0.1f, 0.2f}};
  for (const char* name : {"h.bin", "h.csv"}) {
    host::write_hits((dir / name).string(), hits);
    const std::vector<hw::Hit> back = host::read_hits((dir / name).string());
    REQUIRE(back.size() == hits.size());
    CHECK(std::memcmp(back.data(), hits.data(), hits.size() * sizeof(hw::Hit)) == 0);
  }
  std::ifstream in(dir / "h.csv");
  std::string header, miss;
  std::getline(in, header);
  std::getline(in, miss);
  CHECK(header == "t,prim,u,v");
  CHECK(miss == "inf,4294967295,0,0");
}

TEST_CASE("bad ray files give errors naming the file and the problem", "[io]") {
  const fs::path dir = temp_dir("ray_io");
  auto expect = [](const fs::path& p, const std::string& words) {
    try {
      host::read_rays(p.string());
      FAIL("no error for " << p);
    } catch (const host::Error& e) {
      const std::string msg = e.what();
      INFO(msg);
      CHECK(msg.find(p.filename().string()) != std::string::npos);
      CHECK(msg.find(words) != std::string::npos);
    }
  };
  struct Bad {
    const char* name;
    std::string text;
    const char* words;
  };
  for (const Bad& b : {Bad{"odd.bin", std::string(33, 'x'), "not a multiple of 32"},
                       Bad{"truncated.bin", std::string(32 * 5 - 7, '\0'), "truncated"},
                       Bad{"noheader.csv", "1,2,3,0,1,0,0,inf\n", "header"},
                       Bad{"short.csv", "ox,oy,oz,tmin,dx,dy,dz,tmax\n1,2,3,0,1,0,0,inf\n1,2,3,0,1,0\n", "line 3"},
                       Bad{"junk.csv", "ox,oy,oz,tmin,dx,dy,dz,tmax\n1,2,x,0,1,0,0,inf\n", "line 2"},
                       Bad{"extra.csv", "ox,oy,oz,tmin,dx,dy,dz,tmax\n1,2,3,0,1,0,0,inf,9\n", "line 2"},
                       Bad{"empty.csv", "", "empty"}}) {
    write_text(dir / b.name, b.text);
    expect(dir / b.name, b.words);
  }
  expect(dir / "missing.bin", "missing.bin: file not found");
  // An empty binary file is zero rays, not an error.
  write_text(dir / "empty.bin", "");
  CHECK(host::read_rays((dir / "empty.bin").string()).empty());
}

TEST_CASE("NaN rays survive the file round trip, to be rejected at ray setup", "[io]") {
  const fs::path dir = temp_dir("ray_io");
  write_text(dir / "nan.csv", "ox,oy,oz,tmin,dx,dy,dz,tmax\nnan,0,0,0,1,0,0,inf\n0,0,0,0,0,0,0,inf\n");
  const std::vector<hw::Ray> rays = host::read_rays((dir / "nan.csv").string());
  REQUIRE(rays.size() == 2);
  CHECK(hw::validate_ray(rays[0]) == hw::RayStatus::kNanOrigin);
  CHECK(hw::validate_ray(rays[1]) == hw::RayStatus::kZeroDirection);
}

TEST_CASE("primary rays: count, unit directions, center ray looks at the target", "[io]") {
  host::Camera cam;
  cam.position = hw::Vec3(0, 0, 5);
  cam.look_at = hw::Vec3(0, 0, 0);
  cam.width = 4;
  cam.height = 3;
  const std::vector<hw::Ray> rays = host::primary_rays(cam, 5, 3);
  REQUIRE(rays.size() == 15);
  for (const hw::Ray& r : rays) CHECK(glm::length(r.dir) == Approx(1.0f).epsilon(1e-6));
  CHECK(rays[7].dir.x == Approx(0.0f).margin(1e-7));  // center pixel of 5x3
  CHECK(rays[7].dir.z == Approx(-1.0f));
  CHECK(rays[0].dir.x < 0.0f);  // top left
  CHECK(rays[0].dir.y > 0.0f);
  CHECK(host::primary_rays(cam, uint64_t(1000)).size() == 1000);
  CHECK(host::primary_rays(cam, uint64_t(1)).size() == 1);
}

TEST_CASE("incoherent rays are deterministic per seed and stay in the bounds", "[io]") {
  const hw::Aabb b{hw::Vec3(-1, 2, 3), hw::Vec3(4, 5, 6)};
  const auto a = host::incoherent_rays(b, 5000, 9), c = host::incoherent_rays(b, 5000, 9);
  const auto d = host::incoherent_rays(b, 5000, 10);
  CHECK(std::memcmp(a.data(), c.data(), a.size() * sizeof(hw::Ray)) == 0);
  CHECK(std::memcmp(a.data(), d.data(), a.size() * sizeof(hw::Ray)) != 0);
  hw::Vec3 mean(0.0f);
  for (const hw::Ray& r : a) {
    REQUIRE(b.contains(hw::Aabb{r.origin, r.origin}));
    REQUIRE(glm::length(r.dir) == Approx(1.0f).epsilon(1e-5));
    mean += r.dir;
  }
  // Uniform directions: the mean of 5000 unit vectors has standard deviation 1/sqrt(3*5000) ~ 0.008 per axis.
  CHECK(glm::length(mean / 5000.0f) < 0.05f);
}
