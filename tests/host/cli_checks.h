// Shared by the end-to-end tests of rtusim (test_cli*.cpp): running rtusim (run_process.h), scratch folders
// (test_util.h) and reading back the JSON it writes.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "host/io/json_io.h"
#include "tests/common/test_util.h"
#include "tests/host/run_process.h"

namespace rtu::test {

// rtusim's JSON read back through the depth-limited parser rtu reads JSON with (host/io/json_io.h): so every file
// these tests read also shows that rtusim writes nothing deeper than host::kMaxJsonDepth.
inline nlohmann::json read_json(const std::filesystem::path& p) {
  return rtu::host::read_json_file(p.string());
}

}  // namespace rtu::test
