#include "host/io/files.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "host/io/error.h"

namespace rtu::host {

namespace {

// The system's reason for the last failed call, or "" when it left none.
std::string reason() {
  return errno != 0 ? std::string(" (") + std::strerror(errno) + ")" : std::string();
}

}  // namespace

void check_input_file(const std::string& path) {
  std::error_code ec;
  const std::filesystem::file_status st = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(st)) throw Error(path + ": file not found");
  if (std::filesystem::is_directory(st)) throw Error(path + ": is a directory, not a file");
  if (!std::filesystem::is_regular_file(st)) throw Error(path + ": not a regular file");
}

void check_output_file(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (path.empty()) throw Error("an empty file name (name a file to write)");
  if (fs::is_directory(path, ec)) throw Error(path + ": is a directory, not a file (name a file to write)");
  const fs::path folder = fs::path(path).parent_path();
  if (folder.empty()) return;
  const fs::file_status st = fs::status(folder, ec);
  if (!fs::exists(st)) throw Error(path + ": cannot write: the folder " + folder.string() + " does not exist");
  if (!fs::is_directory(st)) throw Error(path + ": cannot write: " + folder.string() + " is not a folder");
}

void check_output_files(std::initializer_list<std::string> paths) {
  for (const std::string& p : paths)
    if (!p.empty()) check_output_file(p);
}

std::ofstream open_output(const std::string& path, std::ios::openmode mode) {
  check_output_file(path);
  errno = 0;
  std::ofstream out(path, mode | std::ios::out);
  if (!out) throw Error(path + ": cannot open for writing" + reason());
  return out;
}

void finish_output(std::ofstream& out, const std::string& path) {
  errno = 0;
  if (!out.flush()) throw Error(path + ": write error" + reason());
}

}  // namespace rtu::host
