// Small helpers every test executable may use: scratch folders under the system's temporary folder and a
// substring test. Header-only, so that the fuzz targets (tests/fuzz) can use it without a library.
#pragma once

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <string>
#include <system_error>

namespace rtu::test {

// `part` occurs in `s`.
inline bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

// The folder rtu_test_NAME_PID under the system's temporary folder, left in place: the process's own (PID), shared
// by the tests of one NAME, which give their files distinct names. The first call for a NAME in a process empties
// it, since a folder of the same name may survive from an earlier process that had the same PID (a CI machine
// reuses PIDs across runs), and a test appending to or resuming from a stale file would then fail by luck.
inline std::filesystem::path temp_dir(const std::string& name) {
  static std::mutex lock;
  static std::set<std::string> seen;
  const std::filesystem::path d =
      std::filesystem::temp_directory_path() / ("rtu_test_" + name + "_" + std::to_string(::getpid()));
  const std::lock_guard<std::mutex> hold(lock);
  if (seen.insert(name).second) std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

// A fresh, empty folder rtu_test_NAME_PID_N (N counts the TempDirs of the process, so no two meet), removed with
// its contents when the TempDir goes out of scope.
struct TempDir {
  explicit TempDir(const std::string& name) : path(fresh(name)) {}
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  // The path of `file` in the folder.
  std::string file(const std::string& file) const { return (path / file).string(); }
  // Writes `text` to `file` in the folder (bytes as given) and returns its path.
  std::string write(const std::string& file, const std::string& text) const {
    std::ofstream(path / file, std::ios::binary) << text;
    return this->file(file);
  }

  const std::filesystem::path path;

 private:
  static std::filesystem::path fresh(const std::string& name) {
    static std::atomic<int> counter{0};
    const std::filesystem::path d =
        std::filesystem::temp_directory_path() /
        ("rtu_test_" + name + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
  }
};

}  // namespace rtu::test
