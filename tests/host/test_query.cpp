// rtusim query and its job (host/jobs/query.h): point files (PLY ascii and binary, CSV) and generators, the
// answers the same on the fixed and timed units and on any number of threads, timing's cycles, and refusals of bad
// files and options.
#include <catch2/catch.hpp>

#include <algorithm>

#include <fstream>

#include "host/devices/device_settings.h"
#include "host/io/error.h"
#include "host/io/point_io.h"
#include "host/jobs/join.h"
#include "host/jobs/query.h"
#include "tests/host/cli_checks.h"

using namespace rtu;
using hw::Vec3;

namespace {

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

}  // namespace

TEST_CASE("point files: PLY ascii and binary, CSV, round trips and malformed files", "[queries][io]") {
  const test::TempDir d("points");
  const std::vector<Vec3> pts = host::points_from_spec("clustered:500", 3);
  for (const char* name : {"p.ply", "p.csv"}) {
    const std::string path = (d.path / name).string();
    host::write_points(path, pts);
    REQUIRE(host::read_points(path) == pts);  // floats printed with 9 digits round-trip
  }
  // An ascii PLY with other properties around x, y, z (double), a face element after the vertices, CRLF lines.
  const std::string ascii = (d.path / "a.ply").string();
  write_text(ascii,
             "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nelement vertex 2\r\nproperty uchar red\r\n"
             "property double x\r\nproperty double y\r\nproperty double z\r\nproperty float nx\r\n"
             "element face 0\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
             "255 1.5 -2 3 0.5\r\n0 4 5 6.25 1\r\n");
  CHECK(host::read_points(ascii) == std::vector<Vec3>{Vec3(1.5f, -2.0f, 3.0f), Vec3(4.0f, 5.0f, 6.25f)});
  const auto refused = [&](const std::string& name, const std::string& text, const std::string& words) {
    const std::string path = (d.path / name).string();
    write_text(path, text);
    INFO(name);
    CHECK_THROWS_WITH(host::read_points(path), Catch::Contains(words));
  };
  refused("n.ply", "plx\n", "not a PLY file");
  refused("f.ply", "ply\nformat binary_big_endian 1.0\nelement vertex 1\nend_header\n", "binary_big_endian");
  refused("h.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "without end_header");
  refused("x.ply",
          "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
          "without x, y and z");
  refused("c.ply",
          "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\n"
          "property float z\nend_header\n0123456789ab",
          "more than its");
  refused("s.ply",
          "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
          "end_header\n1 2 3\n          \n",
          "vertex 1: malformed line");
  refused("i.ply",
          "ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty float y\nproperty float z\n"
          "end_header\n1 2 3\n",
          "of type int");
  refused("inf.csv", "x,y,z\n1,2,3\n1e39,0,0\n", "not finite");
  refused("bad.csv", "x,y,z\n1,2,3\n1;2;3\n", "bad.csv:3");
  refused("empty.csv", "x,y,z\n", "no points");
  refused("p.xyz", "1 2 3\n", "unknown point file");
  CHECK_THROWS_WITH(host::read_points((d.path / "missing.ply").string()), Catch::Contains("not found"));
  CHECK_THROWS_WITH(host::points_from_spec("uniform:0", 1), Catch::Contains("1..2^27"));
  CHECK_THROWS_WITH(host::points_from_spec("uniform:12x", 1), Catch::Contains("uniform:N"));
}

TEST_CASE("query job: the same answers on the fixed and timed units and any thread count, cycles for each",
          "[queries][timing]") {
  host::QueryJobOptions o;
  o.points = host::points_from_spec("clustered:20000", 1);
  o.queries = host::points_from_spec("uniform:3000", 2);
  o.radius = 1.5f;
  o.format = hw::format_preset("default");
  o.timing = hw::timing_preset("rdna2");
  for (const hw::PointQuery what :
       {hw::PointQuery{hw::PointQuery::kRadius, 8}, hw::PointQuery{hw::PointQuery::kCount, 0},
        hw::PointQuery{hw::PointQuery::kNearest, 3}}) {
    o.what = what;
    o.timed = false;
    o.threads = 1;
    const host::QueryJobResult a = host::run_query_job(o);
    o.threads = 3;
    const host::QueryJobResult b = host::run_query_job(o);
    o.timed = true;
    const host::QueryJobResult t = host::run_query_job(o);
    for (size_t i = 0; i < a.answers.size(); ++i) {
      REQUIRE(a.answers[i].ids == b.answers[i].ids);
      REQUIRE(a.answers[i].ids == t.answers[i].ids);
      REQUIRE(a.answers[i].count == t.answers[i].count);
    }
    CHECK(a.stats.candidates == t.stats.candidates);
    CHECK(t.cycles > 0);
    // Each candidate's distance check is one shader round trip.
    CHECK(t.timing.any_hit_requests == t.stats.candidates);
    CHECK(t.stats.results > 0);
  }
  CHECK(host::query_json(o, host::run_query_job(o))["queries_per_clock"].get<double>() > 0.0);
  // RTNN's reordering: the queries in Morton order (a permutation, codes not decreasing), the same answers in the
  // input's order on both units, the same work in another order.
  const std::vector<uint32_t> order = host::morton_query_order(o.queries);
  std::vector<uint32_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (uint32_t i = 0; i < sorted.size(); ++i) REQUIRE(sorted[i] == i);
  o.what = hw::PointQuery{hw::PointQuery::kRadius, 8};
  for (const bool timed : {false, true}) {
    o.timed = timed;
    o.morton_order = false;
    const host::QueryJobResult in = host::run_query_job(o);
    o.morton_order = true;
    const host::QueryJobResult m = host::run_query_job(o);
    for (size_t i = 0; i < in.answers.size(); ++i) {
      REQUIRE(in.answers[i].ids == m.answers[i].ids);
      REQUIRE(in.answers[i].count == m.answers[i].count);
    }
    CHECK(in.stats.candidates == m.stats.candidates);
    CHECK(in.stats.nodes_visited == m.stats.nodes_visited);
    if (timed) CHECK(host::query_json(o, m)["order"] == "morton");
  }
}

TEST_CASE("rtusim query: answers, figures and refusals", "[queries][cli]") {
  const test::TempDir d("query");
  const std::string pts = (d.path / "p.ply").string(), out = (d.path / "a.csv").string(),
                    json = (d.path / "a.json").string();
  host::write_points(pts, host::points_from_spec("uniform:2000", 4));
  REQUIRE_RTUSIM_OK(r, "query --points " + pts + " --queries uniform:300 --radius 6 --device timed --out " + out +
                           " --json " + json);
  CHECK(test::contains(r.output, "queries a clock"));
  const nlohmann::json j = test::read_json(json);
  CHECK(j["queries"] == 300);
  CHECK(j["results"].get<uint64_t>() > 300);
  CHECK(test::read_lines(out).size() == 1 + j["results"].get<size_t>());  // no query over the bound of 64
  test::check_refused({{"query --points uniform:10 --radius 0", "radius"},
                       {"query --points uniform:10 --radius 1 --kind nearest", "--k"},
                       {"query --points uniform:10 --radius 1 --k 3", "--kind nearest only"},
                       {"query --points uniform:10 --radius 1 --kind count --max-results 3", "--kind radius only"},
                       {"query --points uniform:10 --radius 1 --device float", "float"},
                       {"query --points nosuch.ply --radius 1", "not found"},
                       {"query --points uniform:10 --radius 1 --set nosuchkey=1 --device timed", "nosuchkey"}});
}

TEST_CASE("rtusim join: pairs from CSV files equal the join functions' on both units, and refusals",
          "[queries][join][cli]") {
  const test::TempDir d("join");
  const std::string segs = (d.path / "a.csv").string(), probes = (d.path / "b.csv").string(),
                    polys = (d.path / "p.csv").string(), pts = (d.path / "q.csv").string(),
                    out = (d.path / "pairs.csv").string(), json = (d.path / "j.json").string();
  const std::vector<hw::Segment2> a = host::segments_from_spec("random:3000", 1),
                                  b = host::segments_from_spec("random:500", 2);
  {
    std::ofstream fa(segs), fb(probes);
    fa << "x0,y0,x1,y1\n";
    for (const hw::Segment2& s : a) fa << s.a.x << ',' << s.a.y << ',' << s.b.x << ',' << s.b.y << '\n';
    for (const hw::Segment2& s : b) fb << s.a.x << ',' << s.a.y << ',' << s.b.x << ',' << s.b.y << '\n';
  }
  // The files as written (6 significant digits) are what rtusim reads: read them back for the expected pairs.
  const std::vector<hw::Segment2> ra = host::segments_from_spec(segs, 0), rb = host::segments_from_spec(probes, 0);
  hw::QueryStats s;
  const auto want = hw::segment_join(ra, rb, hw::format_preset("default"), 1, s);
  REQUIRE(!want.empty());
  for (const char* device : {"fixed", "timed"}) {
    REQUIRE_RTUSIM_OK(r, "join --segments " + segs + " --probes " + probes + " --device " + device + " --out " +
                             out + " --json " + json);
    const std::vector<std::string> lines = test::read_lines(out);
    REQUIRE(lines.size() == want.size() + 1);
    for (size_t i = 0; i < want.size(); ++i)
      REQUIRE(lines[i + 1] == std::to_string(want[i].first) + "," + std::to_string(want[i].second));
    CHECK(test::read_json(json)["pairs"] == want.size());
  }
  CHECK(test::read_json(json)["cycles"].get<uint64_t>() > 0);
  {
    std::ofstream fp(polys), fq(pts);
    fp << "polygon,x,y\n0,0,0\n0,4,0\n0,4,4\n0,0,4\n1,2,2\n1,6,2\n1,6,6\n";
    fq << "x,y\n1,1\n3,3\n5,5\n4,1\n9,9\n";
  }
  REQUIRE_RTUSIM_OK(p, "join --polygons " + polys + " --points " + pts + " --out " + out);
  // (1,1) in the square; (3,3) in the square and on the triangle's edge y = x; (5,5) on that edge too; (4,1) on
  // the square's edge; (9,9) in neither: boundaries count as inside.
  CHECK(test::read_lines(out) == std::vector<std::string>{"point,polygon", "0,0", "1,0", "1,1", "2,1", "3,0"});
  {
    std::ofstream bad((d.path / "bad.csv").string());
    bad << "x0,y0,x1,y1\n1,2,3,4\n1,2,3\n";
    std::ofstream two((d.path / "two.csv").string());
    two << "0,0,0\n0,1,1\n";
  }
  test::check_refused(
      {{"join --segments random:10", "both --segments and --probes"},
       {"join --segments random:10 --probes random:10 --points uniform:3", "or --polygons"},
       {"join --segments " + (d.path / "bad.csv").string() + " --probes random:3", "bad.csv:3"},
       {"join --polygons " + (d.path / "two.csv").string() + " --points uniform:3", "fewer than 3"},
       {"join --segments random:0 --probes random:3", "random:N"}});
}

TEST_CASE("query job on a chip: the same answers, the units share the work and the memory",
          "[queries][timing][chip]") {
  host::QueryJobOptions o;
  o.points = host::points_from_spec("uniform:20000", 1);
  o.queries = host::points_from_spec("uniform:20000", 2);
  o.radius = 2.0f;
  o.format = hw::format_preset("default");
  o.timed = true;
  o.timing = hw::timing_preset("rdna2");
  const host::QueryJobResult one = host::run_query_job(o);
  o.timing = host::timing_config_from("rdna2-chip", {"units=8"});
  const host::QueryJobResult chip = host::run_query_job(o), again = host::run_query_job(o);
  for (size_t i = 0; i < one.answers.size(); ++i) REQUIRE(chip.answers[i].ids == one.answers[i].ids);
  CHECK(chip.stats.candidates == one.stats.candidates);
  CHECK(chip.timing.any_hit_requests == one.timing.any_hit_requests);
  CHECK(chip.cycles == again.cycles);
  // Eight units finish far sooner than one, but not eight times as soon (waves, the shared L2 and DRAM).
  CHECK(chip.cycles * 2 < one.cycles);
  CHECK(chip.cycles * 8 > one.cycles);
}
