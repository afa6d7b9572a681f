#include "host/io/pipeline_trace.h"

#include <charconv>
#include <fstream>
#include <set>
#include <utility>

#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/stats_json.h"

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

void write_pipeline_trace(const std::string& path, const hw::PipelineTrace& trace,
                          const hw::MemoryTimeline* timeline) {
  // Streamed, an event at a time: a JSON document of every span would take about a kilobyte per span (1.5 GB for
  // a million), where the spans themselves take 32 bytes (at most max_spans of them).
  std::ofstream out = open_output(path);
  out << "{\n  \"traceEvents\": [";
  bool first = true;
  auto emit = [&](const Json& e) {
    out << (first ? "\n    " : ",\n    ") << e.dump();
    first = false;
  };
  // A process per unit (a track group in Perfetto), a thread per ray slot.
  for (const hw::PipelineTrace::Span& s : trace.spans)
    emit({{"name", s.what},
          {"ph", "X"},
          {"ts", s.start},
          {"dur", s.end - s.start},
          {"pid", s.unit},
          {"tid", s.slot}});
  std::set<std::pair<uint32_t, uint32_t>> used;  // (unit, slot) with a span, named once each
  for (const hw::PipelineTrace::Span& s : trace.spans) used.insert({s.unit, s.slot});
  uint32_t last_unit = ~0u;
  for (const auto& [unit, slot] : used) {
    if (unit != last_unit)
      emit({{"name", "process_name"},
            {"ph", "M"},
            {"pid", unit},
            {"args", {{"name", "unit " + std::to_string(unit)}}}});
    last_unit = unit;
    emit({{"name", "thread_name"},
          {"ph", "M"},
          {"pid", unit},
          {"tid", slot},
          {"args", {{"name", "ray slot " + std::to_string(slot)}}}});
  }
  // The memory's bandwidth as counter tracks (bytes per cycle over each bin inside the window), in a process of
  // its own after the units'.
  if (timeline) {
    const uint32_t pid = used.empty() ? 0 : used.rbegin()->first + 1;
    emit({{"name", "process_name"}, {"ph", "M"}, {"pid", pid}, {"args", {{"name", "memory (shared)"}}}});
    const double bin = double(timeline->bin_cycles);
    for (const auto& [name, series] :
         {std::pair<const char*, const std::vector<uint64_t>*>{"DRAM bytes per cycle", &timeline->dram_bytes},
          {"L2 bytes per cycle", &timeline->l2_bytes}}) {
      for (size_t i = 0; i < series->size(); ++i) {
        const uint64_t t = uint64_t(i) * timeline->bin_cycles;
        if (t + timeline->bin_cycles <= trace.from || t >= trace.to) continue;
        emit({{"name", name},
              {"ph", "C"},
              {"ts", t},
              {"pid", pid},
              {"args", {{"bytes_per_cycle", double((*series)[i]) / bin}}}});
      }
    }
  }
  const Json other = {{"time_unit", "1 us in the viewer = 1 cycle"},
                      {"window", {trace.from, trace.to}},
                      {"spans", trace.spans.size()}};
  out << "\n  ],\n  \"displayTimeUnit\": \"ns\",\n  \"otherData\": " << other.dump() << "\n}\n";
  finish_output(out, path);
}

}  // namespace rtu::host
