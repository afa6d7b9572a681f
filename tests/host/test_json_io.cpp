// JSON input (host/io/json_io.h): parse_json_limited builds the document nlohmann's own parser builds, members in
// file order, in time about proportional to the text however many keys an object has. The depth limit and the
// refusals of nested input: test_nesting.cpp.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>

#include "host/io/error.h"
#include "host/io/json_io.h"
#include "tests/common/test_util.h"
#include "tests/host/error_checks.h"

using namespace rtu;
namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

// A random document: objects of distinct keys (some with escapes and non-ASCII), arrays, and every scalar kind
// (negative integers, unsigned beyond int64, finite doubles of any exponent, strings, booleans, null).
Json random_value(std::mt19937_64& g, int depth) {
  const int kind = int(g() % (depth >= 5 ? 6 : 8));
  switch (kind) {
    case 0:
      return nullptr;
    case 1:
      return bool(g() & 1);
    case 2:
      return int64_t(g());  // any sign
    case 3:
      return uint64_t(g()) | (uint64_t(1) << 63);  // beyond int64
    case 4: {
      double d;
      do {
        const uint64_t bits = g();
        std::memcpy(&d, &bits, sizeof d);
      } while (!std::isfinite(d));
      return d;
    }
    case 5:
      return std::string("s\"\\\n\t\xc3\xa9\xe2\x82\xac") + std::to_string(g() % 1000);
    case 6: {
      Json a = Json::array();
      for (int i = int(g() % 6); i > 0; --i) a.push_back(random_value(g, depth + 1));
      return a;
    }
    default: {
      Json o = Json::object();
      for (int i = int(g() % 7); i > 0; --i) {
        const std::string key =
            (g() & 1 ? "k\\\"\xc3\xa9" : "k") + std::to_string(o.size()) + "_" + std::to_string(g() % 100);
        o[key] = random_value(g, depth + 1);
      }
      return o;
    }
  }
}

// Both parsers on a text nlohmann accepts: the same value, and the same text again (dump tells 1 from 1.0 and
// keeps member order, which == on numbers of different kinds would not); or one of the two refusals nlohmann does
// not make (a duplicate key, nesting past the limit). Returns whether the values were compared.
bool check_same_as_nlohmann(const std::string& text, const std::string& name) {
  CAPTURE(name);
  const Json theirs = Json::parse(text, nullptr, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  Json ours;
  const std::string error = error_of([&] { ours = host::parse_json_limited(text, name); }, "");
  if (!error.empty()) {
    INFO(error);
    CHECK((test::contains(error, ": duplicate key '") || test::contains(error, "nested deeper than 64")));
    return false;
  }
  CHECK(ours == theirs);
  CHECK(ours.dump() == theirs.dump());
  return true;
}

}  // namespace

TEST_CASE("parse_json_limited builds what nlohmann's parser builds: the repository's JSON and random documents",
          "[scene]") {
  size_t files = 0;
  for (const char* dir : {"scenes", "tests/fuzz/corpus/scene_file"}) {
    const fs::path d = fs::path(RTU_SOURCE_DIR) / dir;
    if (!fs::exists(d)) continue;
    for (const auto& e : fs::directory_iterator(d)) {
      std::ifstream in(e.path(), std::ios::binary);
      const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      // The corpus holds broken files on purpose: compare the ones nlohmann accepts.
      const bool valid = Json::accept(text, /*ignore_comments=*/true);
      if (valid) files += check_same_as_nlohmann(text, e.path().string());
    }
  }
  CHECK(files >= 5);
  std::mt19937_64 g(20261207);
  for (int i = 0; i < 400; ++i) {
    const Json v = random_value(g, 0);
    // Compact, indented, and with comments around it.
    CHECK(check_same_as_nlohmann(v.dump(), "random " + std::to_string(i)));
    CHECK(check_same_as_nlohmann("/* head */\n" + v.dump(int(g() % 4)) + " // tail\n",
                                 "random indented " + std::to_string(i)));
  }
}

TEST_CASE("parse_json_limited: an object of 200,000 keys is read in file order, a duplicate among them refused",
          "[limits][scene]") {
  constexpr size_t kKeys = 200000;  // nlohmann's own builder looks each key up among those before: minutes
  std::string text = "{\"prototypes\": {";
  for (size_t i = 0; i < kKeys; ++i)
    text += (i ? ", \"p" : "\"p") + std::to_string(kKeys - 1 - i) + "\": " + std::to_string(i);
  const Json j = host::parse_json_limited(text + "}}", "in.json");
  const Json& p = j.at("prototypes");
  REQUIRE(p.size() == kKeys);
  size_t i = 0, in_order = 0;
  for (const auto& [key, value] : p.items()) {  // file order: p199999 first, values counting up
    in_order += key == "p" + std::to_string(kKeys - 1 - i) && value.get<size_t>() == i;
    ++i;
  }
  CHECK(in_order == kKeys);
  CHECK(p.at("p0").get<size_t>() == kKeys - 1);  // lookup by key still works
  CHECK(test::contains(error_of([&] { host::parse_json_limited(text + ", \"p7\": 1}}", "in.json"); }, ""),
                       "in.json: duplicate key 'prototypes.p7'"));
}
