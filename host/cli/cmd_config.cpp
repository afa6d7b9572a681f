// rtusim config: print a timing preset with overrides as `key = value   # description` lines (and as JSON), or
// list the presets, or the statistics a timed run reports.
#include <algorithm>
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/cost_model.h"
#include "host/error.h"

namespace rtu::host::cli {

namespace {

struct ConfigOptions {
  std::string preset = "rdna2", json;  // --config (or its old name --preset)
  std::vector<std::string> sets;
  bool list = false, stats = false;
};

// The timed device's statistics: the report (the stats JSON's `timing` object) and the counters behind it.
void print_stats() {
  std::printf("# the stats JSON's timing object (also per ray type and per bounce), in its order\n");
  for (const hw::TimingStatValue& v : hw::timing_report_keys())
    std::printf("%-30s %-12s %s\n", v.key, v.unit, v.description);
  for (const EnergyKey& k : energy_json_keys())
    std::printf("%-30s %-12s %s\n", k.key.c_str(), k.unit.c_str(), k.description.c_str());
  std::printf(
      "\n# the counters the timing model keeps (sampled timing: per-ray counters are scaled to the packet)\n");
  for (const hw::TimingCounter& c : hw::timing_counters())
    std::printf("%-30s %-12s %s%s\n", c.name, c.unit, c.description,
                c.scale == hw::SampleScale::kPacket ? " (set for the whole packet when sampled)" : "");
}

void run_config(const ConfigOptions& o) {
  if (o.stats) {
    print_stats();
    return;
  }
  if (o.list) {
    size_t w = 0;
    for (const std::string& n : hw::timing_preset_names()) w = std::max(w, n.size());
    for (const std::string& n : hw::timing_preset_names())
      std::printf("%-*s  %s\n", int(w), n.c_str(), hw::timing_preset_description(n).c_str());
    return;
  }
  const hw::TimingConfig c = timing_config_from(o.preset, o.sets);
  const std::vector<hw::TimingKey> keys = hw::timing_keys(c);
  size_t kw = 0, vw = 0;
  for (const hw::TimingKey& k : keys) {
    kw = std::max(kw, k.key.size());
    vw = std::max(vw, k.value.size());
  }
  std::string overrides;
  for (const std::string& s : o.sets) overrides += (overrides.empty() ? " with " : ", ") + s;
  std::printf("# timing configuration: preset %s%s\n", c.name.c_str(), overrides.c_str());
  for (const hw::TimingKey& k : keys)
    std::printf("%-*s = %-*s   # %s\n", int(kw), k.key.c_str(), int(vw), k.value.c_str(), k.description.c_str());
  if (!o.json.empty()) write_json(o.json, timing_json(c));
}

}  // namespace

void add_config(CLI::App& app) {
  auto o = std::make_shared<ConfigOptions>();
  CLI::App* sub = app.add_subcommand(
      "config",
      "Print the timing model's configuration: a preset with --set overrides, every key with its value and "
      "what it means; or --list the presets, or --stats the statistics a timed run reports");
  CLI::Option* list = sub->add_flag("--list", o->list, "list the presets with what each resembles");
  CLI::Option* stats =
      sub->add_flag("--stats", o->stats, "list the timed device's statistics: key, unit and meaning")
          ->excludes(list);
  // --config, as every other command names the timing preset; --preset is its old name, kept working but not
  // listed.
  CLI::Option* config = sub->add_option("--config", o->preset, "timing preset (--list shows them)")
                            ->check(CLI::IsMember(hw::timing_preset_names()))
                            ->capture_default_str();
  sub->add_option("--preset", o->preset, "the old name of --config")
      ->check(CLI::IsMember(hw::timing_preset_names()))
      ->group("");  // hidden; checked in the callback (an excludes() would name it in the others' help)
  CLI::Option* set = sub->add_option("--set", o->sets,
                                     "override one key: key=value (repeatable; applied in order, each checked)");
  CLI::Option* json =
      sub->add_option("--json", o->json, "also write the configuration as JSON: {\"preset\": P, key: value, ...}");
  // --list and --stats print no configuration: the options of one are refused with them.
  for (CLI::Option* opt : {config, set, json}) opt->excludes(list)->excludes(stats);
  sub->callback([o, sub] {
    if (sub->count("--preset") > 0 && sub->count("--config") + sub->count("--list") + sub->count("--stats") > 0)
      throw CLI::ValidationError("--preset (the old name of --config) excludes --config, --list and --stats");
    run_config(*o);
  });
}

}  // namespace rtu::host::cli
