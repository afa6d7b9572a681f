#include "host/io/limits.h"

#include <sys/resource.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "host/io/error.h"
#include "host/io/files.h"

namespace rtu::host {

uint64_t parse_size(const std::string& text, const std::string& what) {
  auto bad = [&] {
    throw Error(what + ": '" + text + "' is not a size (bytes, or a number with K, M, G or T: powers of 1024)");
  };
  if (text.empty() || text[0] < '0' || text[0] > '9') bad();
  size_t used = 0;
  unsigned long long v = 0;
  try {
    v = std::stoull(text, &used);
  } catch (const std::exception&) {
    bad();
  }
  int shift = 0;
  if (used + 1 == text.size()) {
    switch (text[used]) {
      case 'K':
      case 'k':
        shift = 10;
        break;
      case 'M':
      case 'm':
        shift = 20;
        break;
      case 'G':
      case 'g':
        shift = 30;
        break;
      case 'T':
      case 't':
        shift = 40;
        break;
      default:
        bad();
    }
  } else if (used != text.size()) {
    bad();
  }
  if (shift > 0 && v > (UINT64_MAX >> shift)) bad();
  return uint64_t(v) << shift;
}

uint64_t memory_limit() {
  if (const char* env = std::getenv("RTU_MEMORY_LIMIT"); env && *env) return parse_size(env, "RTU_MEMORY_LIMIT");
  uint64_t limit = UINT64_MAX;
  std::ifstream meminfo("/proc/meminfo");
  std::string line;
  while (std::getline(meminfo, line)) {
    if (line.rfind("MemAvailable:", 0) != 0) continue;
    std::istringstream in(line.substr(13));
    uint64_t kib = 0;
    if (in >> kib && kib > 0) limit = kib * 1024;
    break;
  }
  for (int resource : {RLIMIT_AS, RLIMIT_DATA}) {
    rlimit rl{};
    if (getrlimit(resource, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && uint64_t(rl.rlim_cur) < limit)
      limit = uint64_t(rl.rlim_cur);
  }
  return limit;
}

void check_memory(const std::string& what, uint64_t bytes) {
  const uint64_t limit = memory_limit();
  if (bytes <= limit) return;
  auto size = [](uint64_t b) {  // rounded up: KiB below a MiB, else MiB
    return b < (uint64_t(1) << 20) ? std::to_string((b + 1023) >> 10) + " KiB"
                                   : std::to_string((b >> 20) + ((b & ((uint64_t(1) << 20) - 1)) != 0)) + " MiB";
  };
  throw Error(what + " needs about " + size(bytes) + " of memory, above the limit of " + size(limit) +
              " (RTU_MEMORY_LIMIT, else the memory available)");
}

std::string out_of_memory_message(const std::string& what) {
  return what +
         ": out of memory: the input needs more memory than the machine gives (the budget: RTU_MEMORY_LIMIT, else "
         "the memory available; docs/guide/hardening.md); make it smaller";
}

std::string read_file_limited(const std::string& path, uint64_t factor) {
  check_input_file(path);
  std::error_code ec;
  const uint64_t bytes = std::filesystem::file_size(path, ec);
  if (ec) throw Error(path + ": cannot read the file (" + ec.message() + ")");
  const uint64_t need = factor > 0 && bytes > UINT64_MAX / factor ? UINT64_MAX : bytes * factor;
  check_memory(path + ": reading a " + std::to_string(bytes >> 20) + " MiB file", need);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot read the file");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(path + ": cannot read the file");
  return text;
}

}  // namespace rtu::host
