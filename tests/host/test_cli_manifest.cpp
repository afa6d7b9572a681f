// rtusim end to end: sweep manifests and their point files: content keys, shards in any order and at once, resume
// after a kill, collect, and keys that keep points of other builds, inputs or settings apart.
#include <catch2/catch.hpp>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/jobs/sweep.h"
#include "tests/host/cli_checks.h"

namespace fs = std::filesystem;
using namespace rtu::test;

namespace {

// The keys of a manifest's points, in order.
std::vector<std::string> manifest_keys(const fs::path& m) {
  std::vector<std::string> keys;
  const std::vector<std::string> lines = read_lines(m);
  for (const std::string& line : lines)
    if (!line.empty() && line[0] != '#') keys.push_back(line.substr(0, line.find('\t')));
  return keys;
}

size_t point_files(const fs::path& dir, size_t* temporary = nullptr) {
  size_t n = 0, tmp = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(".tmp-", 0) == 0)
      ++tmp;
    else if (e.path().extension() == ".json")
      ++n;
  }
  if (temporary) *temporary = tmp;
  return n;
}

}  // namespace

TEST_CASE("sweep manifests: content keys, shards in any order, eight writers, resume, collect", "[cli][sweep]") {
  const fs::path d = temp_dir("cli_manifest");
  fs::remove_all(d / "res");
  const std::string grid =
      "sweep --scene builtin:seed --formats default,compact --set cache_kib=16,64 --rays 400 --image-width 0 ";
  const std::string whole = (d / "whole.csv").string(), m = (d / "m.txt").string(), res = (d / "res").string(),
                    all = (d / "all.csv").string();
  fs::remove(whole);
  REQUIRE(run_rtusim(grid + "--out " + whole).status == 0);
  Run r = run_rtusim(grid + "--write-manifest " + m);
  INFO(r.output);
  REQUIRE(r.status == 0);
  const std::vector<std::string> keys = manifest_keys(m);
  REQUIRE(keys.size() == 4);
  // Three shards, last first, then the collected table equals the single run's (wall times aside).
  for (const char* shard : {"3/3", "1/3", "2/3"})
    REQUIRE(run_rtusim("sweep --manifest " + m + " --results " + res + " --shard " + shard).status == 0);
  REQUIRE(point_files(res) == 4);
  r = run_rtusim("sweep --collect " + res + " --manifest " + m + " --out " + all);
  INFO(r.output);
  REQUIRE(r.status == 0);
  check_same_rows(read_lines(all), read_lines(whole));
  CHECK(read_lines(all + ".provenance.csv").size() == 5);
  // Resume: nothing runs again. A point whose file is gone (a task killed before its rename leaves at most a
  // temporary file, which nothing reads) runs alone.
  r = run_rtusim("sweep --manifest " + m + " --results " + res);
  CHECK(r.output.find("4 points in this shard (1/1), 0 run, 4 already") != std::string::npos);
  fs::remove(fs::path(res) / (keys[1] + ".json"));
  std::ofstream(fs::path(res) / (".tmp-" + keys[1] + "-killed")) << "{\"key\": \"" << keys[1];
  r = run_rtusim("RTU_SHARD=1/1", "sweep --manifest " + m + " --results " + res + " --shard auto");
  INFO(r.output);
  CHECK(r.output.find("1 run, 3 already") != std::string::npos);
  REQUIRE(run_rtusim("sweep --collect " + res + " --manifest " + m + " --out " + all).status == 0);
  check_same_rows(read_lines(all), read_lines(whole));
  // A missing point: collect names it and fails.
  fs::remove(fs::path(res) / (keys[2] + ".json"));
  r = run_rtusim("sweep --collect " + res + " --manifest " + m + " --out " + all);
  CHECK(r.status == 2);
  CHECK(r.output.find("1 of 4 points have no file") != std::string::npos);
  CHECK(r.output.find(keys[2]) != std::string::npos);
  // Eight writers of the same manifest into one folder at once: every point once, whole.
  fs::remove_all(res);
  std::string eight;
  for (int i = 0; i < 8; ++i)
    eight +=
        std::string(RTUSIM_EXE) + " sweep --manifest " + m + " --results " + res + " --threads 1 >/dev/null & ";
  REQUIRE(run_process(eight + "wait").status == 0);
  size_t tmp = 0;
  CHECK(point_files(res, &tmp) == 4);
  CHECK(tmp == 0);
  REQUIRE(run_rtusim("sweep --collect " + res + " --manifest " + m + " --out " + all).status == 0);
  check_same_rows(read_lines(all), read_lines(whole));
}

TEST_CASE("sweep point keys: a changed mesh or timing key changes exactly the points it touches", "[cli][sweep]") {
  const fs::path d = temp_dir("cli_keys");
  const fs::path mesh = d / "two.obj", copy = d / "copy.obj";
  auto write_mesh = [](const fs::path& p, const char* z) {
    std::ofstream f(p);
    f << "v 0 0 " << z << "\nv 1 0 0\nv 0 1 0\nv 1 1 1\nf 1 2 3\nf 2 4 3\n";
  };
  write_mesh(mesh, "0");
  write_mesh(copy, "0");
  auto keys_of = [&](const std::string& args) {
    const std::string m = (d / "m.txt").string();
    REQUIRE_RTUSIM_OK(r, "sweep " + args + " --rays 50 --image-width 0 --write-manifest " + m);
    return manifest_keys(m);
  };
  const std::string cfg = " --config rdna2 --set cache_kib=16,64";
  const std::vector<std::string> a = keys_of("--scene " + mesh.string() + " --scene builtin:seed" + cfg);
  REQUIRE(a.size() == 4);
  // The same content under another path: the same keys. A key computed twice: the same.
  CHECK(keys_of("--scene " + copy.string() + " --scene builtin:seed" + cfg) == a);
  // A preset's own value spelled out is the same configuration: listed once.
  const std::vector<std::string> same = keys_of("--scene builtin:seed --config rdna2,rdna2:cache_kib=64");
  CHECK(same.size() == 1);
  CHECK(same[0] == a[3]);
  // One timing value changed: only its points change.
  const std::vector<std::string> b =
      keys_of("--scene " + mesh.string() + " --scene builtin:seed --config rdna2 --set cache_kib=16,32");
  CHECK(b[0] == a[0]);
  CHECK(b[1] != a[1]);
  CHECK(b[2] == a[2]);
  CHECK(b[3] != a[3]);
  // The mesh changed: its points change, the built-in's do not; a manifest written before refuses to run them.
  const std::string m = (d / "before.txt").string();
  REQUIRE(run_rtusim("sweep --scene " + mesh.string() + cfg + " --rays 50 --image-width 0 --write-manifest " + m)
              .status == 0);
  write_mesh(mesh, "0.5");
  const std::vector<std::string> c = keys_of("--scene " + mesh.string() + " --scene builtin:seed" + cfg);
  CHECK(c[0] != a[0]);
  CHECK(c[1] != a[1]);
  CHECK(c[2] == a[2]);
  CHECK(c[3] == a[3]);
  const Run r = run_rtusim("sweep --manifest " + m + " --results " + (d / "res").string());
  CHECK(r.status == 2);
  CHECK(r.output.find("changed since the manifest was written") != std::string::npos);
  // Points listed by a script: the same point twice is one; a bad line is named.
  {
    std::ofstream f(d / "points.csv");
    f << "# scene,format,width,config\nbuiltin:seed,default,4,rdna2:cache_kib=16\n"
         "builtin:seed\tcompact\t8\trdna2-mem:ray_slots=8\nbuiltin:seed,default,4,rdna2:cache_kib=16\n";
  }
  REQUIRE_RTUSIM_OK(pts, "sweep --points " + (d / "points.csv").string() +
                             " --rays 50 --image-width 0 --write-manifest " + (d / "pm.txt").string());
  CHECK(manifest_keys(d / "pm.txt").size() == 2);
  CHECK(manifest_keys(d / "pm.txt")[0] == a[2]);  // the grid's builtin:seed, rdna2 with cache_kib 16
  {
    std::ofstream f(d / "points_bad.csv");
    f << "builtin:seed,default,3,rdna2\n";
  }
  const Run pb = run_rtusim("sweep --points " + (d / "points_bad.csv").string() +
                            " --rays 50 --image-width 0 --write-manifest " + (d / "pm.txt").string());
  CHECK(pb.status == 2);
  CHECK(pb.output.find("points_bad.csv:1") != std::string::npos);
  // A malformed manifest: a clear error.
  {
    std::ofstream f(d / "bad.txt");
    f << "# rtu sweep manifest 2\n# params\t--rays 10 --seed 1 --image-width 0\n# model\t0123456789abcdef\n"
         "# area\t0123456789abcdef0123456789abcdef\nnotakey\tbuiltin:seed\tdefault\t4\trdna2\n";
  }
  const Run bad =
      run_rtusim("sweep --manifest " + (d / "bad.txt").string() + " --results " + (d / "res").string());
  CHECK(bad.status == 2);
  CHECK(bad.output.find("not a point key") != std::string::npos);
}

TEST_CASE("sweep manifests: a run killed with SIGKILL halfway leaves whole files, and the rerun redoes none",
          "[cli][sweep][scale]") {
  const fs::path d = temp_dir("cli_kill");
  fs::remove_all(d / "res");
  const std::string grid =
      "sweep --scene builtin:seed --formats default,compact,default:coord_bits=14 --bvh-width 2,4 --set "
      "cache_kib=16,64 --rays 20000 --image-width 0 ";
  const std::string m = (d / "m.txt").string(), res = (d / "res").string(), whole = (d / "whole.csv").string(),
                    all = (d / "all.csv").string();
  REQUIRE(run_rtusim(grid + "--write-manifest " + m).status == 0);
  const size_t points = manifest_keys(m).size();
  REQUIRE(points == 12);
  // The run in the background; once two points are complete, SIGKILL (no handler runs, no cleanup). The other ten
  // take hundreds of milliseconds more, far longer than the 10 ms poll.
  const Run k = run_process(std::string(RTUSIM_EXE) + " sweep --manifest " + m + " --results " + res +
                            " --threads 1 >/dev/null 2>&1 & pid=$!; n=0; "
                            "while [ \"$(ls " +
                            res +
                            "/*.json 2>/dev/null | wc -l)\" -lt 2 ] && [ $n -lt 6000 ]; do "
                            "sleep 0.01; n=$((n+1)); done; kill -9 $pid; wait $pid; echo \"killed $?\"");
  INFO(k.output);
  REQUIRE(k.output.find("killed 137") != std::string::npos);  // it was still running: 128 + SIGKILL
  size_t tmp = 0;
  const size_t complete = point_files(res, &tmp);
  CHECK(complete >= 2);
  CHECK(complete < points);
  CHECK(tmp <= 1);  // at most the point being written, under its temporary name
  for (const auto& e : fs::directory_iterator(res))
    if (e.path().extension() == ".json" && e.path().filename().string().rfind(".tmp-", 0) != 0)
      CHECK(read_json(e.path()).contains("row"));  // every visible point file is whole
  const Run r = run_rtusim("sweep --manifest " + m + " --results " + res + " --threads 1");
  INFO(r.output);
  CHECK(r.output.find(std::to_string(points - complete) + " run, " + std::to_string(complete) + " already") !=
        std::string::npos);
  REQUIRE(run_rtusim("sweep --collect " + res + " --manifest " + m + " --out " + all).status == 0);
  REQUIRE(run_rtusim(grid + "--threads 1 --out " + whole).status == 0);
  check_same_rows(read_lines(all), read_lines(whole));
}

namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary | std::ios::trunc) << text;
}

// The manifest's text with its header line "# NAME<TAB>..." given another value.
std::string with_header(const std::string& text, const std::string& name, const std::string& value) {
  const size_t at = text.find("# " + name + "\t");
  REQUIRE(at != std::string::npos);
  const size_t from = at + name.size() + 3, end = text.find('\n', from);
  return text.substr(0, from) + value + text.substr(end);
}

// A point file with one field of its JSON, or one column of its row, changed.
void edit_point_file(const fs::path& p, const std::string& field, const std::string& value) {
  nlohmann::ordered_json j = rtu::host::read_json_file(p.string());
  j[field] = value;
  write_text(p, j.dump(1) + "\n");
}
void edit_point_row(const fs::path& p, size_t column, const std::string& value) {
  nlohmann::ordered_json j = rtu::host::read_json_file(p.string());
  std::vector<std::string> f;
  std::stringstream ss(j["row"].get<std::string>());
  for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
  REQUIRE(column < f.size());
  f[column] = value;
  std::string row;
  for (size_t i = 0; i < f.size(); ++i) row += (i ? "," : "") + f[i];
  j["row"] = row;
  write_text(p, j.dump(1) + "\n");
}

}  // namespace

TEST_CASE("sweep manifests: points of two builds never mix, the build's model identity is in every key",
          "[cli][sweep]") {
  const fs::path d = temp_dir("cli_builds");
  fs::remove_all(d / "res");
  const std::string m = (d / "m.txt").string(), res = (d / "res").string(), out = (d / "out.csv").string();
  REQUIRE(run_rtusim("sweep --scene builtin:seed --formats default,compact --rays 50 --image-width 0 "
                     "--write-manifest " +
                     m)
              .status == 0);
  // The header names the build (the identity rtusim --version prints) and the area table.
  const std::vector<std::string> lines = read_lines(m);
  REQUIRE(lines.size() == 6);
  CHECK(lines[0] == "# rtu sweep manifest 2");
  REQUIRE(lines[2].rfind("# model\t", 0) == 0);
  const std::string model = lines[2].substr(8);
  CHECK(model.size() == 16);
  CHECK(model.find_first_not_of("0123456789abcdef") == std::string::npos);
  CHECK(lines[3].rfind("# area\t", 0) == 0);
  const Run version = run_rtusim("--version");
  CHECK(version.output.find("(model " + model + ")") != std::string::npos);
  REQUIRE(run_rtusim("sweep --manifest " + m + " --results " + res).status == 0);
  REQUIRE(run_rtusim("sweep --collect " + res + " --manifest " + m + " --out " + out).status == 0);
  const std::vector<std::string> keys = manifest_keys(m);
  REQUIRE(keys.size() == 2);
  const std::vector<std::string> prov = read_lines(out + ".provenance.csv");
  REQUIRE(prov.size() == 3);
  CHECK(prov[0] == "key,version,model,host,threads,seconds");
  CHECK(prov[1].rfind(keys[0] + ",0.1.0," + model + ",", 0) == 0);

  // A manifest another build wrote: refused before any point runs, naming both builds.
  const std::string other = "00000000deadbeef";
  const std::string text = read_text(m);
  write_text(d / "other.txt", with_header(text, "model", other));
  Run r = run_rtusim("sweep --manifest " + (d / "other.txt").string() + " --results " + (d / "res2").string());
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(r.output.find("build of model " + other) != std::string::npos);
  CHECK(r.output.find("this is build " + model) != std::string::npos);
  CHECK((!fs::exists(d / "res2") || point_files(d / "res2") == 0));
  // A point file another build made, among this build's: collect refuses, naming both builds and the file.
  edit_point_file(fs::path(res) / (keys[1] + ".json"), "model", other);
  r = run_rtusim("sweep --collect " + res + " --manifest " + m + " --out " + out);
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(r.output.find(keys[1] + ".json was made by the rtu build of model " + other + ", the manifest by build " +
                      model) != std::string::npos);
}

TEST_CASE("sweep: what determines a row is in its key or refused, and collect refuses what would mix",
          "[cli][sweep]") {
  const fs::path d = temp_dir("cli_mix");
  fs::remove_all(d / "res");
  const std::string grid = "sweep --scene builtin:seed --rays 50 --image-width 0 ";
  const std::string m = (d / "m.txt").string(), res = (d / "res").string(), out = (d / "out.csv").string();
  REQUIRE(run_rtusim(grid + "--write-manifest " + m).status == 0);
  const std::vector<std::string> keys = manifest_keys(m);
  REQUIRE(keys.size() == 1);

  // --area prices the points: another table gives other keys, and a run with another table than the manifest's
  // is refused.
  const std::string table = read_text(fs::path(RTU_SOURCE_DIR) / "bench/data/rtl_area.csv");
  const size_t comma = table.find(',', table.find('\n'));
  REQUIRE(comma != std::string::npos);
  // The first unit's cell count, another number.
  write_text(d / "area.csv", table.substr(0, comma + 1) + "1" + table.substr(comma + 1));
  const std::string am = (d / "am.txt").string();
  REQUIRE(run_rtusim(grid + "--area " + (d / "area.csv").string() + " --write-manifest " + am).status == 0);
  CHECK(manifest_keys(am).size() == 1);
  CHECK(manifest_keys(am) != keys);
  Run r = run_rtusim("sweep --manifest " + am + " --results " + (d / "ares").string());
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(r.output.find("give the run the --area the manifest was written with") != std::string::npos);
  CHECK(run_rtusim("sweep --manifest " + am + " --results " + (d / "ares").string() + " --area " +
                   (d / "area.csv").string())
            .status == 0);

  // A point's format and BVH width are --formats and --bvh-width; the timing keys of those names are refused.
  for (const auto& [args, option] : std::vector<std::pair<std::string, std::string>>{
           {"--set format=compact", "--formats compact"},
           {"--config rdna2:format=compact", "--formats compact"},
           {"--set bvh_width=8", "--bvh-width 8"},
           {"--config rdna2:cache_kib=16:bvh_width=2", "--bvh-width 2"}}) {
    for (const std::string& how :
         {"--out " + (d / "x.csv").string(), "--write-manifest " + (d / "x.txt").string()}) {
      const Run bad = run_rtusim(grid + args + " " + how);
      INFO(args << " " << how << ": " << bad.output);
      CHECK(bad.status == 2);
      CHECK(bad.output.find("(e.g. " + option + ")") != std::string::npos);
    }
  }

  REQUIRE(run_rtusim("sweep --manifest " + m + " --results " + res).status == 0);
  const fs::path point = fs::path(res) / (keys[0] + ".json");
  const std::string good = read_text(point);
  // A figure no measurement gives: collect refuses it, naming the column and the file.
  for (const char* bad : {"7", "nan", "-0.5"}) {
    edit_point_row(point, 8, bad);  // hit_agreement
    r = run_rtusim("sweep --collect " + res + " --manifest " + m + " --out " + out);
    INFO(bad << ": " << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(keys[0] + ".json:2: hit_agreement " + std::string(bad) + " is out of range") !=
          std::string::npos);
  }
  write_text(point, good);
  // A key listed twice (another spelling of the point would collect into one row where two were listed): refused,
  // naming both lines.
  const std::string text = read_text(m);
  write_text(d / "twice.txt", text + keys[0] + "\tbuiltin:seed\tdefault\t4\trdna2:cache_kib=64\n");
  r = run_rtusim("sweep --collect " + res + " --manifest " + (d / "twice.txt").string() + " --out " + out);
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(r.output.find("twice.txt:6: point " + keys[0]) != std::string::npos);
  CHECK(r.output.find("is listed already on line 5") != std::string::npos);
  r = run_rtusim("sweep --manifest " + (d / "twice.txt").string() + " --results " + res);
  CHECK(r.status == 2);
  CHECK(r.output.find("is listed already on line 5") != std::string::npos);
  // --out naming an input: the manifest, a point file (under another spelling too) or the manifest as the
  // provenance file: refused, the input untouched.
  for (const std::string& o : {m, (d / "." / "m.txt").string(), point.string(),
                               (fs::path(res) / ".." / "res" / (keys[0] + ".json")).string()}) {
    r = run_rtusim("sweep --collect " + res + " --manifest " + m + " --out " + o);
    INFO(o << ": " << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find("would overwrite the") != std::string::npos);
  }
  write_text(d / "m.csv.provenance.csv", text);
  r = run_rtusim("sweep --collect " + res + " --manifest " + (d / "m.csv.provenance.csv").string() + " --out " +
                 (d / "m.csv").string());
  CHECK(r.status == 2);
  CHECK(r.output.find("would overwrite the manifest") != std::string::npos);
  CHECK(read_text(m) == text);
  CHECK(read_text(point) == good);
  CHECK(run_rtusim("sweep --collect " + res + " --manifest " + m + " --out " + out).status == 0);
}
