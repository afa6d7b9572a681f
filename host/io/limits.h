// The host's memory budget: inputs whose size alone would need more memory than the machine can give are
// refused with an Error naming the input, the estimate and the limit, before anything large is allocated (a
// clear message instead of std::bad_alloc or the kernel's OOM killer).
#pragma once

#include <cstdint>
#include <string>

namespace rtu::host {

// Bytes a job may use: RTU_MEMORY_LIMIT when set (a whole number of bytes, or with a K, M, G or T suffix, powers
// of 1024), else the smaller of MemAvailable (/proc/meminfo) and the address-space and data-segment limits
// (getrlimit), else no limit (UINT64_MAX). Throws Error for a malformed RTU_MEMORY_LIMIT.
uint64_t memory_limit();

// Throws Error("WHAT needs about N MiB ... above the memory limit of M MiB ...") when bytes > memory_limit().
void check_memory(const std::string& what, uint64_t bytes);

// The message for a std::bad_alloc no estimate foresaw, instead of its bare "std::bad_alloc": "WHAT: out of
// memory: the input needs more memory than the machine gives (the budget: RTU_MEMORY_LIMIT, ...); make it
// smaller". `what` names the input or the job.
std::string out_of_memory_message(const std::string& what);

// The whole text of the file at `path`, read after its size times `factor` (what its reader holds at once: the
// text, a copy being split into lines, the values parsed from it) passes check_memory. Throws Error naming the
// path for a missing file, a directory or anything else that is not a regular file, a file that cannot be read,
// and one too large for the budget ("PATH: reading a N MiB file needs about ...").
std::string read_file_limited(const std::string& path, uint64_t factor);

// Parses a size such as "4096", "512M", "2G" (powers of 1024); throws Error naming `what` otherwise.
uint64_t parse_size(const std::string& text, const std::string& what);

}  // namespace rtu::host
