// The benchmark suite's manifest (suite.h).
#include "host/jobs/suite.h"

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

#include "host/io/error.h"
#include "host/io/json_io.h"
#include "host/scene/scene.h"

namespace rtu::host {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

constexpr const char* kBuiltinPrefix = "builtin:";

bool valid_name(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  return true;
}

}  // namespace

Suite load_suite(const std::string& path) {
  const Json root = read_json_file(path);
  auto fail = [&](const std::string& where, const std::string& problem) {
    throw Error(path + ": " + (where.empty() ? "" : where + ": ") + problem);
  };
  if (!root.is_object()) fail("", std::string("expected a JSON object at the top level, got ") + root.type_name());
  Suite suite;
  suite.path = path;
  for (const auto& item : root.items()) {
    if (item.key() != "description" && item.key() != "scenes")
      fail("", "unknown key '" + item.key() + "' (allowed here: description, scenes)");
  }
  if (root.contains("description")) {
    if (!root["description"].is_string()) fail("description", "expected a string");
    suite.description = root["description"].get<std::string>();
  }
  if (!root.contains("scenes")) fail("", "missing key 'scenes' (an array of scene entries)");
  const Json& scenes = root["scenes"];
  if (!scenes.is_array()) fail("scenes", std::string("expected an array, got ") + scenes.type_name());
  if (scenes.empty()) fail("scenes", "the suite names no scene");

  std::set<std::string> builtins;
  for (const auto& [name, description] : builtin_scene_names()) builtins.insert(name);
  const fs::path base = fs::path(path).parent_path();
  std::set<std::string> names;
  for (size_t i = 0; i < scenes.size(); ++i) {
    const std::string where = "scenes[" + std::to_string(i) + "]";
    const Json& e = scenes[i];
    if (!e.is_object()) fail(where, std::string("expected an object, got ") + e.type_name());
    for (const auto& item : e.items()) {
      const std::string& k = item.key();
      if (k != "name" && k != "scene" && k != "hard_because" && k != "source")
        fail(where, "unknown key '" + k + "' (allowed here: name, scene, hard_because, source)");
    }
    auto text = [&](const char* key, bool required) -> std::string {
      if (!e.contains(key)) {
        if (required) fail(where, std::string("missing key '") + key + "'");
        return {};
      }
      if (!e[key].is_string())
        fail(where + "." + key, std::string("expected a string, got ") + e[key].type_name());
      const std::string s = e[key].get<std::string>();
      if (s.empty()) fail(where + "." + key, "must not be empty");
      return s;
    };
    SuiteEntry entry;
    entry.name = text("name", true);
    if (!valid_name(entry.name))
      fail(where + ".name", "'" + entry.name + "': use 1-64 letters, digits, '_', '-' or '.'");
    if (!names.insert(entry.name).second) fail(where + ".name", "duplicate name '" + entry.name + "'");
    entry.scene = text("scene", true);
    entry.hard_because = text("hard_because", true);
    entry.source = text("source", false);
    if (entry.scene.rfind(kBuiltinPrefix, 0) == 0) {
      const std::string spec = entry.scene.substr(std::char_traits<char>::length(kBuiltinPrefix));
      const std::string builtin = spec.substr(0, spec.find('?'));
      if (!builtins.count(builtin)) {
        std::string valid;
        for (const std::string& n : builtins) valid += (valid.empty() ? "" : ", ") + n;
        fail(where + ".scene", "unknown built-in scene '" + builtin + "' (valid: " + valid + ")");
      }
    } else if (fs::path(entry.scene).is_relative()) {
      entry.scene = (base / entry.scene).lexically_normal().string();
    }
    suite.entries.push_back(std::move(entry));
  }
  return suite;
}

SuiteCheck check_suite(const Suite& suite) {
  SuiteCheck check;
  for (const SuiteEntry& e : suite.entries) {
    std::string reason;
    if (e.scene.rfind(kBuiltinPrefix, 0) != 0) {
      std::error_code ec;
      const fs::file_status st = fs::status(e.scene, ec);
      if (!fs::exists(st))
        reason = "missing file " + e.scene;
      else if (!fs::is_regular_file(st))
        reason = e.scene + " is not a regular file";
      else if (!std::ifstream(e.scene, std::ios::binary))
        reason = "cannot read " + e.scene;
      if (!reason.empty() && !e.source.empty()) reason += " (from: " + e.source + ")";
    }
    if (reason.empty())
      check.available.push_back(e);
    else
      check.skipped.push_back({e, reason});
  }
  return check;
}

std::vector<std::string> suite_scenes(const std::string& manifest,
                                      const std::function<void(const std::string&)>& warn) {
  const SuiteCheck check = check_suite(load_suite(manifest));
  if (warn)
    for (const SuiteSkip& s : check.skipped) warn(manifest + ": skipping '" + s.entry.name + "': " + s.reason);
  std::vector<std::string> specs;
  for (const SuiteEntry& e : check.available) specs.push_back(e.scene);
  return specs;
}

}  // namespace rtu::host
