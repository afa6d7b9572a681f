// Shared by the end-to-end tests of rtusim (test_cli*.cpp, test_sweep_bytes.cpp): running rtusim
// (run_process.h), scratch folders (test_util.h) and reading back the JSON and CSV files it writes.
#pragma once

#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "host/io/json_io.h"
#include "tests/common/test_util.h"
#include "tests/host/run_process.h"

namespace rtu::test {

// rtusim's JSON read back through the depth-limited parser rtu reads JSON with (host/io/json_io.h): so every file
// these tests read also shows that rtusim writes nothing deeper than host::kMaxJsonDepth.
inline nlohmann::json read_json(const std::filesystem::path& p) {
  return rtu::host::read_json_file(p.string());
}

// The lines of a text file.
inline std::vector<std::string> read_lines(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

// A sweep CSV row without its next-to-last column, the point's wall time (the last is the model identity):
// everything else is deterministic.
inline std::string strip_time(const std::string& row) {
  const size_t model = row.rfind(',');
  if (model == std::string::npos || model == 0) return row;
  const size_t seconds = row.rfind(',', model - 1);
  return seconds == std::string::npos ? row : row.substr(0, seconds) + row.substr(model);
}

// Two sweep CSV files (as read_lines) hold the same rows under the same header, in any order and wall times
// aside: what shards merged give against the whole sweep.
inline void check_same_rows(std::vector<std::string> a, std::vector<std::string> b) {
  REQUIRE(a.size() == b.size());
  for (auto* v : {&a, &b}) {
    for (std::string& l : *v) l = strip_time(l);
    std::sort(v->begin() + 1, v->end());
  }
  CHECK(a == b);
}

// Runs rtusim with ARGS into the const Run named R and requires that it exits with status 0. R's output stays the
// INFO of every assertion after it in the scope, so that a later failure shows what rtusim said: a macro, since
// INFO lasts to the end of the scope it is written in.
#define REQUIRE_RTUSIM_OK(R, ARGS)                          \
  const ::rtu::test::Run R = ::rtu::test::run_rtusim(ARGS); \
  INFO(R.output);                                           \
  REQUIRE(R.status == 0)

// A command line rtusim must refuse, and words its message must hold.
struct Refusal {
  std::string args, words;
};

// Each case: rtusim exits with status 2, the status of bad input, and its output holds the case's words.
inline void check_refused(const std::vector<Refusal>& cases) {
  for (const Refusal& c : cases) {
    const Run r = run_rtusim(c.args);
    INFO(c.args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(c.words) != std::string::npos);
  }
}

// Each case: rtusim fails (a status other than 0) by exiting, not killed by a signal, and its output holds the
// case's words.
inline void check_failed(const std::vector<Refusal>& cases) {
  for (const Refusal& c : cases) {
    const Run r = run_rtusim(c.args);
    INFO(c.args << "\n" << r.output);
    CHECK(r.status != 0);
    CHECK(r.status < 128);  // not killed by a signal
    CHECK(r.output.find(c.words) != std::string::npos);
  }
}

}  // namespace rtu::test
