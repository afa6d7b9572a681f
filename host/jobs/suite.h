// The benchmark scene suite: a manifest (scenes/suite.json) that names scenes and says what makes each hard.
// `rtusim sweep --suite`, `rtusim report --suite`, `rtusim info --suite` and bench/scene_suite.sh read it.
//
// Manifest schema (scenes/README.md, "The benchmark suite"): a JSON object with an optional "description" and
// "scenes", an array of objects with
//   "name"         required, unique, letters, digits, '_', '-', '.';
//   "scene"        required, a scene spec as load_scene takes it (builtin:NAME, a .json scene file or a mesh
//                  file); a relative file path is relative to the manifest's folder;
//   "hard_because" required, non-empty: what makes the scene hard for the unit;
//   "source"       optional: where its file comes from (a Debian package, a script that extracts it).
// Unknown keys, duplicate names, unknown built-in scenes and wrong types are errors naming the manifest and the
// entry. A scene whose file is missing is not an error: it is skipped, with the reason (check_suite).
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace rtu::host {

struct SuiteEntry {
  std::string name;
  std::string scene;  // the spec, relative paths resolved against the manifest's folder
  std::string hard_because;
  std::string source;  // empty when not given
};

struct Suite {
  std::string path;  // the manifest
  std::string description;
  std::vector<SuiteEntry> entries;  // in manifest order
};

// Reads and checks a manifest. Throws Error naming `path` and the problem.
Suite load_suite(const std::string& path);

struct SuiteSkip {
  SuiteEntry entry;
  std::string reason;  // e.g. "missing file /x/y.off (from: Debian libcgal-demo, scripts/cgal_meshes.sh)"
};

struct SuiteCheck {
  std::vector<SuiteEntry> available;  // in manifest order
  std::vector<SuiteSkip> skipped;
};

// Splits the entries into those whose files exist (built-in scenes always do) and those skipped, with the
// reason: a missing file, or a path that is not a readable regular file. Loads nothing; a file that exists but
// does not parse fails later, where it is loaded, with load_scene's message.
SuiteCheck check_suite(const Suite& suite);

// The scene specs of a suite's available entries, in manifest order, for the jobs that take a list of scenes;
// `warn` (may be empty) is called once per skipped entry with a line naming it and the reason.
std::vector<std::string> suite_scenes(const std::string& manifest,
                                      const std::function<void(const std::string&)>& warn = {});

}  // namespace rtu::host
