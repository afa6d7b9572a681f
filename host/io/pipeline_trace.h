// The timed device's pipeline trace (hw::PipelineTrace) as a file: the cycle window to record, and the recorded
// spans written as a Chrome/Perfetto trace.
#pragma once

#include <string>

#include "hwmodel/device/timed_engine.h"

namespace rtu::host {

// An empty trace of the cycles FROM:TO (`window`, the timing model's cycles since the scene was bound); throws
// Error naming --trace-window for a malformed window or FROM >= TO.
hw::PipelineTrace pipeline_trace_window(const std::string& window);

// Chrome/Perfetto JSON of the trace's spans: a process per unit, a track per ray slot ("ts" and "dur" in cycles,
// shown as microseconds); with a timeline, the memory's DRAM and L2 bytes per cycle as counter tracks of their own
// process. Throws Error when the file cannot be written.
void write_pipeline_trace(const std::string& path, const hw::PipelineTrace& trace,
                          const hw::MemoryTimeline* timeline = nullptr);

}  // namespace rtu::host
