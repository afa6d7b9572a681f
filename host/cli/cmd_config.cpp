// rtusim config: print a timing preset with overrides as `key = value   # description` lines (and as JSON), or
// list the presets.
#include <algorithm>
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/error.h"

namespace rtu::host::cli {

namespace {

struct ConfigOptions {
  std::string preset = "rdna2", json;
  std::vector<std::string> sets;
  bool list = false;
};

void run_config(const ConfigOptions& o) {
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
      "what it means; or --list the presets");
  CLI::Option* list = sub->add_flag("--list", o->list, "list the presets with what each resembles");
  sub->add_option("--preset", o->preset, "timing preset (--list shows them)")
      ->capture_default_str()
      ->excludes(list);
  sub->add_option("--set", o->sets, "override one key: key=value (repeatable; applied in order, each checked)")
      ->excludes(list);
  sub->add_option("--json", o->json, "also write the configuration as JSON: {\"preset\": P, key: value, ...}")
      ->excludes(list);
  sub->callback([o] { run_config(*o); });
}

}  // namespace rtu::host::cli
