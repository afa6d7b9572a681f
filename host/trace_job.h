// Tracing a whole ray set on the host: in chunks, with a progress line on a terminal, and a report of the
// rays the unit rejected.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "host/direct_device.h"

namespace rtu::host {

// A one-line progress display on stderr, only when stderr is a terminal.
class Progress {
 public:
  Progress(const char* what, uint64_t total);
  void update(uint64_t done);                            // "what: P% (done/total)"
  void update(uint64_t done, const std::string& where);  // "what: P% (where)"
  ~Progress();

 private:
  const char* m_what;
  uint64_t m_total;
  bool m_enabled;
};

int resolved_threads(int threads);

// Traces rays into hits (same size); returns the wall-clock seconds of tracing alone.
double trace_with_progress(const DirectDevice& device, const std::vector<hw::Ray>& rays,
                           std::vector<hw::Hit>& hits, bool any_hit, int threads, hw::TraversalStats& stats);

// Prints "N invalid rays ... the first is ray i (reason)" to `out` when the device rejected any ray.
void report_invalid_rays(const hw::TraversalStats& stats, std::FILE* out);

}  // namespace rtu::host
