#include "firmware/ray_sort.h"

#include <glm/glm.hpp>

namespace rtu::fw {

namespace {

// x in [lo, lo + 1/inv) to an integer of `bits` bits: the cell of a grid of 2^bits over the interval, clamped at
// both ends (NaN to 0).
uint32_t quantize(float x, float lo, float inv, uint32_t bits) {
  const float t = (x - lo) * inv;
  if (!(t > 0.0f)) return 0;
  const uint32_t top = (1u << bits) - 1;
  const float cells = float(1u << bits);
  return t * cells >= float(top) ? top : uint32_t(t * cells);
}

// v's low `bits` bits spread to every `stride`-th bit (bit i to bit i * stride).
uint32_t spread(uint32_t v, uint32_t bits, uint32_t stride) {
  uint32_t out = 0;
  for (uint32_t i = 0; i < bits; ++i) out |= ((v >> i) & 1u) << (i * stride);
  return out;
}

uint32_t morton3(uint32_t x, uint32_t y, uint32_t z, uint32_t bits) {
  return (spread(x, bits, 3) << 2) | (spread(y, bits, 3) << 1) | spread(z, bits, 3);
}

struct Grid {  // the scene's bounds as a quantization box
  glm::vec3 lo, inv;
};

Grid grid_of(const RaySortJob& job) {
  Grid g{glm::vec3(job.lo.x, job.lo.y, job.lo.z), glm::vec3(0.0f)};
  const glm::vec3 hi(job.hi.x, job.hi.y, job.hi.z);
  for (int i = 0; i < 3; ++i) g.inv[i] = hi[i] > g.lo[i] ? 1.0f / (hi[i] - g.lo[i]) : 0.0f;
  return g;
}

uint32_t point_key(const Grid& g, const glm::vec3& p) {
  return morton3(quantize(p.x, g.lo.x, g.inv.x, 10), quantize(p.y, g.lo.y, g.inv.y, 10),
                 quantize(p.z, g.lo.z, g.inv.z, 10), 10);
}

}  // namespace

uint32_t ray_sort_key_bits(RaySortKey key) {
  switch (key) {
    case RaySortKey::kOrigin:
    case RaySortKey::kOriginDirection:
    case RaySortKey::kTermination:
      return 30;
    case RaySortKey::kDirection:
      return 29;
    case RaySortKey::kNone:
    default:
      return 0;
  }
}

uint32_t ray_sort_key(const RaySortJob& job, const hw::Ray& ray) {
  const Grid g = grid_of(job);
  const glm::vec3 o = ray.origin, d = ray.dir;
  const glm::vec3 a = glm::abs(d);
  const float l1 = a.x + a.y + a.z;
  switch (RaySortKey(job.key)) {
    case RaySortKey::kOrigin:
      return point_key(g, o);
    case RaySortKey::kDirection: {
      if (!(l1 > 0.0f)) return 0;
      const uint32_t octant = (d.x < 0.0f ? 4u : 0u) | (d.y < 0.0f ? 2u : 0u) | (d.z < 0.0f ? 1u : 0u);
      const uint32_t u = quantize(a.x / l1, 0.0f, 1.0f, 13), v = quantize(a.y / l1, 0.0f, 1.0f, 13);
      return (octant << 26) | (spread(u, 13, 2) << 1) | spread(v, 13, 2);
    }
    case RaySortKey::kOriginDirection: {
      // Five levels, coarse to fine; at each the origin's x, y, z bits, then the direction's.
      const glm::vec3 n = l1 > 0.0f ? d / l1 : glm::vec3(0.0f);  // components in [-1, 1]
      uint32_t q[6];
      for (int i = 0; i < 3; ++i) {
        q[i] = quantize(o[i], g.lo[i], g.inv[i], 5);
        q[3 + i] = quantize(n[i], -1.0f, 0.5f, 5);
      }
      uint32_t key = 0;
      for (int i = 0; i < 6; ++i) key |= spread(q[i], 5, 6) << (5 - i);
      return key;
    }
    case RaySortKey::kTermination: {
      const float len = glm::sqrt(glm::dot(d, d));
      if (!(len > 0.0f)) return point_key(g, o);
      const float t = glm::min(ray.tmax, job.distance / len);  // tmax may be +inf
      return point_key(g, o + t * d);
    }
    case RaySortKey::kNone:
    default:
      return 0;
  }
}

bool RaySorter::init(Hal& hal, Arena& arena, const RaySortJob& job, uint32_t capacity, SortStats& stats) {
  m_hal = &hal;
  m_job = &job;
  m_stats = &stats;
  m_capacity = capacity;
  const uint32_t bits = ray_sort_key_bits(RaySortKey(job.key));
  m_passes = (bits + job.radix_bits - 1) / job.radix_bits;
  const uint64_t n = capacity;
  m_rays = arena.alloc(n * sizeof(hw::Ray));
  m_hits = arena.alloc(n * sizeof(hw::Hit));
  const uint64_t perm = arena.alloc(n * 4), key_a = arena.alloc(n * 4), key_b = arena.alloc(n * 4);
  const uint64_t idx_b = arena.alloc(n * 4), hist = arena.alloc(uint64_t(4) << job.radix_bits);
  if (m_rays == Arena::kNull || m_hits == Arena::kNull || perm == Arena::kNull || key_a == Arena::kNull ||
      key_b == Arena::kNull || idx_b == Arena::kNull || hist == Arena::kNull)
    return false;
  m_perm = at<uint32_t>(hal, perm);
  m_key_a = at<uint32_t>(hal, key_a);
  m_key_b = at<uint32_t>(hal, key_b);
  m_idx_b = at<uint32_t>(hal, idx_b);
  m_hist = at<uint32_t>(hal, hist);
  return true;
}

void RaySorter::sort(const hw::Ray* rays, uint32_t n, uint32_t place, hw::cmd::RayType type) {
  // The pairs ping-pong between (key_a, perm) and (key_b, idx_b); an odd number of passes starts in the b
  // buffers, so that the last pass always lands in perm.
  uint32_t* keys[2] = {m_key_a, m_key_b};
  uint32_t* idx[2] = {m_perm + place, m_idx_b};
  int cur = m_passes % 2 == 1 ? 1 : 0;
  for (uint32_t i = 0; i < n; ++i) {
    keys[cur][i] = ray_sort_key(*m_job, rays[i]);
    idx[cur][i] = i;
  }
  const uint32_t radix = m_job->radix_bits, bins = 1u << radix, mask = bins - 1;
  for (uint32_t p = 0; p < m_passes; ++p) {
    const uint32_t shift = p * radix;
    for (uint32_t b = 0; b < bins; ++b) m_hist[b] = 0;
    for (uint32_t i = 0; i < n; ++i) ++m_hist[(keys[cur][i] >> shift) & mask];
    uint32_t sum = 0;
    for (uint32_t b = 0; b < bins; ++b) {
      const uint32_t c = m_hist[b];
      m_hist[b] = sum;
      sum += c;
    }
    const int nxt = 1 - cur;
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t dst = m_hist[(keys[cur][i] >> shift) & mask]++;
      keys[nxt][dst] = keys[cur][i];
      idx[nxt][dst] = idx[cur][i];
    }
    cur = nxt;
  }
  hw::Ray* sorted = at<hw::Ray>(*m_hal, ray_addr(place));
  for (uint32_t i = 0; i < n; ++i) sorted[i] = rays[m_perm[place + i]];
  ++m_stats->sorts;
  m_stats->rays += n;
  m_stats->passes += m_passes;
  m_stats->pass_rays += uint64_t(m_passes) * n;
  m_stats->by_type[uint32_t(type)] += n;
}

void RaySorter::unsort(hw::Hit* hits, uint32_t n, uint32_t place) {
  const hw::Hit* sorted = at<const hw::Hit>(*m_hal, hit_addr(place));
  for (uint32_t i = 0; i < n; ++i) hits[m_perm[place + i]] = sorted[i];
}

}  // namespace rtu::fw
