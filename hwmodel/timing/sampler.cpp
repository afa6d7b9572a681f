#include "hwmodel/timing/sampler.h"

#include <algorithm>
#include <cmath>

#include "hwmodel/numeric/rng.h"

namespace rtu::hw {

double SampleStats::ci95() const {
  return 1.96 * std::sqrt(variance);
}

size_t sample_step(double fraction) {
  return fraction > 0.0 ? size_t(std::llround(1.0 / fraction)) : 1;
}

size_t packet_step(size_t n, size_t unit_rays, size_t k, size_t per_unit) {
  const size_t U = unit_rays;
  if (k < 2 || (n > U && (n - 1) / U >= 10 * k)) return k;
  const size_t k10 = n <= U ? 0 : (n - 1) / U / 10;
  return k10 * U >= 2 * per_unit ? k10 : 1;
}

uint64_t packet_draw(uint64_t seed, uint64_t packet) {
  return splitmix64(seed + 0x9E3779B97F4A7C15ull * packet);
}

std::vector<size_t> probe_rays(size_t n, size_t stride, uint64_t draw) {
  // At random within its block, not at its start: a fixed place probes the same image columns in every row when a
  // row is a multiple of the stride, and those columns' work need not be the image's.
  const size_t probes = (n + stride - 1) / stride;
  std::vector<size_t> probed(probes);
  for (size_t q = 0; q < probes; ++q) {
    const size_t first = q * stride, len = std::min(stride, n - first);
    probed[q] = len == 1 ? first : first + size_t(splitmix64(draw ^ (0xD1B54A32D192ED03ull * (q + 1))) % len);
  }
  return probed;
}

std::vector<Stratum> choose_strata(const std::vector<double>& aux, const std::vector<uint8_t>& tests_prims,
                                   size_t k, uint64_t draw) {
  const size_t last = aux.size() - 1;
  std::vector<Stratum> strata;
  std::vector<size_t> without, with;
  for (size_t j = 1; j < last; ++j) (tests_prims[j] ? with : without).push_back(j);
  if (without.size() >= 2 * k && with.size() >= 2 * k) {
    // Neyman's allocation with costs: n_h ~ N_h S_h / sqrt(c_h); with a unit's spread S_h and its simulation cost
    // c_h both following its work (mean x_h), n_h ~ N_h sqrt(x_h) = sqrt(N_h X_h).
    double x_without = 0.0, x_with = 0.0;
    for (size_t j : without) x_without += aux[j];
    for (size_t j : with) x_with += aux[j];
    const double share_without = std::sqrt(double(without.size()) * x_without),
                 share_with = std::sqrt(double(with.size()) * x_with);
    const size_t total = std::max<size_t>(4, size_t(std::llround(double(last - 1) / double(k))));
    const size_t n0 = std::clamp<size_t>(
        size_t(std::llround(double(total) * share_without / (share_without + share_with))), 2, total - 2);
    const size_t take[2] = {std::min(n0, without.size()), std::min(total - n0, with.size())};
    strata.resize(2);
    strata[0].units = std::move(without);
    strata[1].units = std::move(with);
    for (size_t h = 0; h < 2; ++h) {
      Stratum& st = strata[h];
      const double step = double(st.units.size()) / double(take[h]);
      const double from = double(splitmix64(draw + h + 1) >> 11) * 0x1p-53 * step;  // in [0, step)
      for (size_t i = 0; i < take[h]; ++i)
        st.picked.push_back(st.units[std::min(st.units.size() - 1, size_t(from + double(i) * step))]);
    }
  } else {
    strata.resize(1);
    for (size_t j = 1; j < last; ++j) strata[0].units.push_back(j);
    for (size_t j = 1 + (draw >> 32) % k; j < last; j += k) strata[0].picked.push_back(j);
  }
  return strata;
}

double jackknife_ratio_variance(const std::vector<double>& c, const std::vector<double>& x) {
  const size_t m = c.size();
  if (m < 2) return 0.0;
  double sum_c = 0.0, sum_x = 0.0;
  for (size_t q = 0; q < m; ++q) {
    sum_c += c[q];
    sum_x += x[q];
  }
  const double ratio = sum_x > 0.0 ? sum_c / sum_x : 0.0;
  // The ratio recomputed with each pair left out.
  double sum_r = 0.0, sum_r2 = 0.0;
  for (size_t q = 0; q < m; ++q) {
    const double rest = sum_x - x[q];
    const double r = rest > 0.0 ? (sum_c - c[q]) / rest : ratio;
    sum_r += r;
    sum_r2 += r * r;
  }
  const double spread = std::max(0.0, sum_r2 - sum_r * sum_r / double(m));  // sum of (r_(q) - mean)^2
  return (double(m) - 1) / double(m) * spread;
}

CycleEstimate estimate_cycles(const std::vector<Stratum>& strata, const std::vector<double>& aux, double exact) {
  CycleEstimate e;
  e.cycles = exact;
  for (const Stratum& st : strata) {
    const double m = double(st.measured_c.size()), M = double(st.units.size());
    double sum_c = 0.0, sum_x = 0.0, total = 0.0;
    for (size_t q = 0; q < st.picked.size(); ++q) {
      sum_c += st.measured_c[q];
      sum_x += aux[st.picked[q]];
    }
    for (size_t j : st.units) total += aux[j];
    const double ratio = sum_x > 0.0 ? sum_c / sum_x : 0.0;
    e.cycles += ratio * total;
    std::vector<double> x;
    for (size_t j : st.picked) x.push_back(aux[j]);
    e.variance += jackknife_ratio_variance(st.measured_c, x) * total * total * std::max(0.0, 1.0 - m / M);
    // The probe's error in the work's total: each unit not measured carries its own, whose variance the measured
    // units show (their probe value against their exact one); the estimate scales it by the ratio.
    if (m > 0) e.variance += ratio * ratio * (M - m) * (st.probe_error2 / m);
  }
  return e;
}

double student_t975(size_t df) {
  // Student's t distribution, two-sided 95% (the 0.975 quantile), for 1 .. 30 degrees of freedom.
  static constexpr double kT[] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
                                  2.201,  2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
                                  2.080,  2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042};
  if (df == 0) return kT[0];
  return df <= 30 ? kT[df - 1] : 1.96;
}

ChipThinning chip_thinning(size_t waves, size_t units, size_t k, size_t burst_turns) {
  ChipThinning t;
  if (k < 2 || units == 0 || burst_turns == 0) return t;
  t.lead = kChipLeadTurns * units;
  t.trail = kChipTrailTurns * units;
  t.burst = burst_turns;
  t.tail = kChipTailTurns;
  t.warm = kChipWarmTurns;
  const std::string packet = "a packet of " + std::to_string(waves) + " waves on " + std::to_string(units) +
                             " units (a turn: a wave for each unit)";
  if (burst_turns < t.warm + t.tail) {
    t.why_not = "a burst of " + std::to_string(burst_turns) + " turns has no room for its warm-up and tail";
    return t;
  }
  if (waves <= t.lead + t.trail) {
    t.why_not = packet + " is no longer than its fill and drain (" + std::to_string(kChipLeadTurns) + " + " +
                std::to_string(kChipTrailTurns) + " turns), all of which are simulated";
    return t;
  }
  const size_t B = burst_turns * units, bursts = (waves - t.lead - t.trail) / B, measured = bursts / k;
  const size_t simulated = t.lead + t.trail + measured * (B + (t.warm + t.tail) * units);
  if (measured < kChipMinBursts) {
    t.why_not = packet + " holds " + std::to_string(bursts) + " bursts of " + std::to_string(burst_turns) +
                " turns between its fill and drain; at 1 in " + std::to_string(k) + " that measures " +
                std::to_string(measured) + ", fewer than the " + std::to_string(kChipMinBursts) +
                " an interval needs: a larger --sample, or longer packets (trace --packet-rays)";
    return t;
  }
  if (2 * simulated > waves) {
    t.why_not = packet + " at 1 in " + std::to_string(k) + " would simulate " + std::to_string(simulated) +
                " waves with the fill, drain, warm-ups and tails, over half of it: a smaller --sample thins it";
    return t;
  }
  t.sampled = true;
  return t;
}

CycleEstimate estimate_chip_cycles(const ChipSample& c, uint64_t start) {
  const size_t m = c.measured_c.size();
  double sum_c = 0.0, sum_a = 0.0;
  for (size_t q = 0; q < m; ++q) {
    sum_c += c.measured_c[q];
    sum_a += c.measured_a[q];
  }
  const double total = sum_a + c.skipped_work, ratio = sum_a > 0.0 ? sum_c / sum_a : 0.0;
  CycleEstimate e;
  e.cycles = double(c.lead_done - start) + ratio * total + double(c.end - c.mid_done);
  if (m > 1) {
    const double f = c.population > 0.0 ? c.sampled / c.population : 1.0;
    // A few bursts: the jackknife's variance has m - 1 degrees of freedom, so the interval takes Student's t
    // quantile, given as the variance scaled by (t / 1.96)^2 (ci95() is 1.96 sqrt(variance)).
    const double t = student_t975(m - 1) / 1.96;
    e.variance =
        jackknife_ratio_variance(c.measured_c, c.measured_a) * total * total * std::max(0.0, 1.0 - f) * t * t;
  }
  return e;
}

void account_slot_time(SlotTimeAccount& a, const std::vector<uint64_t>& done, const std::vector<uint64_t>& written,
                       const std::vector<uint64_t>& entered, size_t w, size_t unit_rays, size_t ray_slots) {
  const size_t U = unit_rays;
  const double per_ray = double(done[w + U - 1] - done[w - 1]) / double(U);
  // The unit's rays: slots take rays in order, each entering after the one before.
  std::vector<uint64_t> in_order(entered);
  std::sort(in_order.begin(), in_order.end());
  const uint64_t lo = in_order[w], hi = in_order[w + U - 1];
  std::array<double, kWarmupGrid.size()> after;  // the time w + U/2 rays take, for each w of the grid
  for (size_t g = 0; g < after.size(); ++g) after[g] = double(kWarmupGrid[g] * ray_slots + U / 2) * per_ray;
  for (size_t i = 0; i < written.size(); ++i) {
    if (entered[i] < lo || entered[i] > hi) continue;
    const double life = double(written[i] - entered[i]);
    a.held += life;
    for (size_t g = 0; g < after.size(); ++g) a.late[g] += std::max(0.0, life - after[g]);
  }
  a.rays += U;
}

size_t warmup_rays(const SlotTimeAccount& a, size_t ray_slots, size_t fixed) {
  constexpr double kShare = 0.005;
  constexpr uint64_t kSeen = 512;
  if (fixed > 0) return fixed;
  if (a.rays < kSeen) return 16 * ray_slots;
  for (size_t g = 0; g < kWarmupGrid.size(); ++g)
    if (a.late[g] <= kShare * a.held) return kWarmupGrid[g] * ray_slots;
  return kWarmupGrid.back() * ray_slots;
}

}  // namespace rtu::hw
