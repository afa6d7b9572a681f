#include "host/pipeline_trace.h"

#include <charconv>

#include "host/error.h"
#include "host/stats_json.h"

namespace rtu::host {

hw::PipelineTrace pipeline_trace_window(const std::string& window) {
  const size_t colon = window.find(':');
  uint64_t from = 0, to = 0;
  auto parse = [&](const std::string& t, uint64_t& v) {
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    return r.ec == std::errc() && r.ptr == t.data() + t.size() && !t.empty();
  };
  if (colon == std::string::npos || !parse(window.substr(0, colon), from) ||
      !parse(window.substr(colon + 1), to) || from >= to)
    throw Error("--trace-window: expected FROM:TO in cycles with FROM < TO, got '" + window + "'");
  hw::PipelineTrace trace;
  trace.from = from;
  trace.to = to;
  return trace;
}

void write_pipeline_trace(const std::string& path, const hw::PipelineTrace& trace) {
  Json events = Json::array();
  for (const hw::PipelineTrace::Span& s : trace.spans)
    events.push_back(
        {{"name", s.what}, {"ph", "X"}, {"ts", s.start}, {"dur", s.end - s.start}, {"pid", 0}, {"tid", s.slot}});
  std::vector<bool> used;  // slots with a span, named once each
  for (const hw::PipelineTrace::Span& s : trace.spans) {
    if (s.slot >= used.size()) used.resize(size_t(s.slot) + 1, false);
    used[s.slot] = true;
  }
  for (uint32_t k = 0; k < used.size(); ++k) {
    if (!used[k]) continue;
    events.push_back({{"name", "thread_name"},
                      {"ph", "M"},
                      {"pid", 0},
                      {"tid", k},
                      {"args", {{"name", "ray slot " + std::to_string(k)}}}});
  }
  Json j;
  j["traceEvents"] = events;
  j["displayTimeUnit"] = "ns";
  j["otherData"] = {{"time_unit", "1 us in the viewer = 1 cycle"},
                    {"window", {trace.from, trace.to}},
                    {"spans", trace.spans.size()}};
  write_json(path, j);
}

}  // namespace rtu::host
