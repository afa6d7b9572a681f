// rtusim config: print a timing preset with overrides as `key = value   # description` lines (and as JSON), or
// list the presets, or the statistics a timed run reports.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <tuple>

#include "host/cli/common.h"
#include "host/cost/cost_model.h"
#include "host/cost/timing_json.h"
#include "host/io/error.h"
#include "hwmodel/cost/energy_model.h"

namespace rtu::host::cli {

namespace {

struct ConfigOptions {
  std::string preset = "rdna2", json;  // --config (or its old name --preset)
  std::vector<std::string> sets;
  bool list = false, stats = false, energy = false;
};

// The energy model's figures for a configuration: technology, each unit's size and energy per issue with their
// sources, the energy of every other event, and the calibration against Horowitz.
void print_energy(const hw::TimingConfig& c) {
  const hw::Technology& t = hw::nangate45();
  const hw::CostInputs in = cost_inputs(c);
  const hw::EnergyReport e = hw::energy_report(hw::TimingStats{}, c, in);
  std::printf(
      "\n# energy and area estimate (docs/energy-model.md): %s, switching at %.2f V, %.3g pJ per gate "
      "transition, NAND2 %.3f um^2, utilization %.2f\n",
      t.name, t.vdd, t.pj_per_transition(), t.nand2_um2, t.utilization);
  for (const auto& [name, u, n, mm2] : {std::tuple{"box unit", in.box, c.box_units, e.area.box_mm2},
                                        std::tuple{"tri unit", in.tri, c.tri_units, e.area.tri_mm2}})
    std::printf("%-10s x%d: %.0f NAND2 eq each, %.3f mm^2 in all, %.2f pJ per test (%s)\n", name, n, u.nand2_eq,
                mm2, u.toggles_per_test * t.pj_per_transition(), u.source.c_str());
  std::printf("SRAM: cache %.3f mm^2, slots/stacks/queue %.3f mm^2; total area %.3f mm^2\n", e.area.cache_mm2,
              e.area.slots_mm2, e.area.total_mm2);
  std::printf("a ray slot: %.0f bits of state, %.0f bits a stack entry (%s)\n", in.slot_state_bits,
              in.stack_entry_bits, in.slot_source.c_str());
  for (const hw::EnergyEvent& ev : e.events)
    std::printf("%-12s %10.3f pJ each, counted in %-11s %s\n", ev.key, ev.pj_each, ev.unit, ev.description);
  const hw::MemoryType& m = hw::memory_type(c.memory_type);
  std::printf("memory %s: %.2f pJ/bit (%s)\n", m.name, m.pj_per_bit, m.source);
  std::printf("\n# calibration: reference operators by this model against Horowitz (ISSCC 2014, 45 nm)\n");
  for (const ReferenceOp& op : reference_ops(AreaTable::shipped(), ActivityTable::shipped())) {
    if (!op.measured) {
      std::printf("%-24s not in the shipped tables (bench/rtl_activity.sh); Horowitz %.2f pJ, %.0f um^2\n",
                  op.name.c_str(), op.horowitz_pj, op.horowitz_um2);
      continue;
    }
    std::printf("%-24s %.3f pJ (Horowitz %.2f, x%.2f), %.0f um^2 (Horowitz %.0f, x%.2f)\n", op.name.c_str(), op.pj,
                op.horowitz_pj, op.pj / op.horowitz_pj, op.area_um2, op.horowitz_um2,
                op.area_um2 / op.horowitz_um2);
  }
}

// The timed device's statistics: the report (the stats JSON's `timing` object) and the counters behind it.
void print_stats() {
  std::printf("# the stats JSON's timing object (also per ray type and per bounce), in its order\n");
  for (const hw::TimingStatValue& v : hw::timing_report_keys())
    std::printf("%-30s %-12s %s\n", v.key, v.unit, v.description);
  for (const EnergyKey& k : energy_json_keys())
    std::printf("%-30s %-12s %s\n", k.key.c_str(), k.unit.c_str(), k.description.c_str());
  std::printf(
      "%-30s %-12s %s\n", "units", "-",
      "a chip (units > 1), total only: per unit rays, box_tests, triangle_tests, utilization (box_units, "
      "triangle_units, ray_slots: of the unit's own), cache.hit_rate, l2.hit_rate, dram_bytes, stack_spills");
  std::printf("%-30s %-12s %s\n", "timeline.bin_cycles", "cycles",
              "total only, not under sampled timing: the width of the memory timeline's bins (from cycle 0 since "
              "bind; doubles to keep at most 4096 bins)");
  std::printf("%-30s %-12s %s\n", "timeline.dram_bytes", "bytes",
              "DRAM bytes per bin, by the cycle each transfer ends");
  std::printf("%-30s %-12s %s\n", "timeline.l2_bytes", "bytes",
              "L2 bytes per bin (line accesses x line bytes, stack words x 8), by request cycle");
  std::printf("%-30s %-12s %s\n", "notes", "-",
              "total only: what a reader of these figures should know, one sentence each (the summary prints "
              "them): slot time queued, cycles far above the bound, stack spills, a short packet, the sample");
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
  if (o.energy) print_energy(c);
  if (!o.json.empty()) write_json(o.json, timing_json(c));
}

}  // namespace

void add_config(CLI::App& app) {
  const auto [sub, o] = add_command<ConfigOptions>(
      app, "config",
      "Print the timing model's configuration: a preset with --set overrides, every key with its value and "
      "what it means; or --list the presets, or --stats the statistics a timed run reports",
      [](ConfigOptions& o, CLI::App& sub) {
        if (sub.count("--preset") > 0 && sub.count("--config") + sub.count("--list") + sub.count("--stats") > 0)
          throw CLI::ValidationError("--preset (the old name of --config) excludes --config, --list and --stats");
        run_config(o);
      });
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
  CLI::Option* energy = sub->add_flag(
      "--energy", o->energy,
      "also print the area and energy estimate of the configuration: each unit's size and energy per issue, "
      "SRAM, DRAM and leakage energies, and the calibration against Horowitz's 45 nm figures");
  // --list and --stats print no configuration: the options of one are refused with them.
  for (CLI::Option* opt : {config, set, json, energy}) opt->excludes(list)->excludes(stats);
}

}  // namespace rtu::host::cli
