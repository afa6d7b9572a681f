// Shared pieces of the rtusim subcommands: options every tracing command takes, scene loading, progress,
// statistics as JSON.
#pragma once

#include <CLI/CLI.hpp>
#include <chrono>
#include <nlohmann/json.hpp>
#include <string>

#include "host/scene.h"
#include "hwmodel/float_tracer.h"

namespace rtu::host::cmd {

using Json = nlohmann::ordered_json;

struct AccelOptions {
  int bvh_width = 4;
  int leaf_size = 8;
  std::string accel = "auto";
  hw::TracerOptions tracer() const;
};

void add_accel_options(CLI::App& app, AccelOptions& o);

class Stopwatch {
 public:
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
  }

 private:
  std::chrono::steady_clock::time_point m_start = std::chrono::steady_clock::now();
};

Json bvh_json(const hw::FloatTracer& t);
Json traversal_json(const hw::TraversalStats& s);
void write_json(const std::string& path, const Json& j);

void add_info(CLI::App& app);
void add_rays(CLI::App& app);
void add_trace(CLI::App& app);
void add_demo(CLI::App& app);

}  // namespace rtu::host::cmd
