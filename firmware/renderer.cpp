#include "firmware/renderer.h"

#include <glm/glm.hpp>

#include "firmware/raster.h"
#include "firmware/sampling.h"
#include "firmware/surface.h"
#include "hwmodel/interface/ray.h"

namespace rtu::fw {

namespace {

using V = glm::vec3;
using hw::cmd::RayType;

constexpr float kInvPi = 0.318309886183790671538f;
constexpr float kInf = __builtin_inff();

V vec(const F3& f) {
  return V(f.x, f.y, f.z);
}

// Cosine-weighted direction around unit n: a point of the unit disk by rejection (no trigonometry in the
// firmware), lifted to the hemisphere.
V cosine_direction(const V& n, Rng& rng) {
  float x, y, r2;
  int tries = 0;
  do {
    x = 2.0f * rng.next() - 1.0f;
    y = 2.0f * rng.next() - 1.0f;
    r2 = x * x + y * y;
  } while (r2 >= 1.0f && ++tries < 64);
  if (r2 >= 1.0f) x = y = r2 = 0.0f;
  const float z = glm::sqrt(glm::max(0.0f, 1.0f - r2));
  // Orthonormal basis around n (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
  const float s = n.z >= 0.0f ? 1.0f : -1.0f;
  const float a = -1.0f / (s + n.z), b = n.x * n.y * a;
  const V t(1.0f + s * n.x * n.x * a, s * b, -s * n.x);
  const V u(b, s + n.y * n.y * a, -n.y);
  return glm::normalize(x * t + y * u + z * n);
}

struct Path {
  V throughput;
  uint32_t pixel;
  uint32_t sample;
  uint32_t count_emission;  // 1 after the camera or a specular bounce: emitters hit now are not lit by NEE
};
static_assert(sizeof(Path) == 24);

struct Pending {  // a shadow or occlusion ray's contribution, added when it reaches its target
  V radiance;
  uint32_t pixel;
};
static_assert(sizeof(Pending) == 16);

// Ray types of the bounce rays, in their TRACE order.
constexpr RayType kBounceTypes[] = {RayType::kReflection, RayType::kRefraction, RayType::kDiffuse};
constexpr int kNumBounceTypes = 3;
// The segments of a bounce's ray buffer, in their TRACE order: primary rays, then the bounce types.
constexpr RayType kSegmentTypes[kNumBounceTypes + 1] = {RayType::kPrimary, RayType::kReflection,
                                                        RayType::kRefraction, RayType::kDiffuse};

class Renderer {
 public:
  Renderer(Hal& hal, Ring& ring, const RenderJob& job, const ShadingTables& tables, const hw::AnyHitStage* stage,
           const RaySortJob* sort, RenderStats& st)
      : m_hal(hal), m_ring(ring), m_job(job), m_tables(tables), m_stage(stage), m_sort(sort), m_st(st) {}

  Status run(Arena& arena);

 private:
  // The batch's working buffers in the arena (device addresses), as allocate() sizes them.
  struct Buffers {
    uint64_t batch = 0;                   // paths per batch
    bool hybrid = false, jitter = false;  // primary hits rasterized; with jittered samples' offsets
    uint64_t paths = 0, next_paths = 0, rays = 0, next_rays = 0, hits = 0, types = 0, offsets = 0;
  };
  // The current ray buffer by type (kSegmentTypes): rays [begin[t], begin[t] + count[t]).
  struct Segments {
    uint32_t begin[kNumBounceTypes + 1];
    uint32_t count[kNumBounceTypes + 1];
  };

  void plan_ray_types();
  Status allocate(Arena& arena, Buffers& buf);
  void start_paths(const Buffers& buf, uint64_t first, uint32_t n);
  Status render_batch(const Buffers& buf, uint64_t first);
  Status trace_segments(const Buffers& buf, const Segments& seg, uint32_t depth);
  uint32_t shade_bounce(const Buffers& buf, uint32_t n, uint32_t depth, uint32_t (&count)[kNumBounceTypes]);
  Status trace_shadows(uint32_t depth);
  uint32_t group_by_type(const Buffers& buf, uint32_t staged, const uint32_t (&count)[kNumBounceTypes],
                         Segments& seg);
  Status trace(uint64_t rays, uint64_t hits, uint32_t n, bool any_hit, RayType type, uint32_t bounce) {
    if (n == 0) return Status::kOk;
    m_st.rays[uint32_t(type)] += n;
    ++m_st.traces;
    return m_ring.submit(hw::cmd::trace(rays, hits, n, any_hit, type, uint8_t(bounce > 255 ? 255 : bounce)));
  }
  // A TRACE of n rays at device address `rays`, their hits to `hits`. With sorting, the rays' sorted copy at
  // sorted place `place` is traced instead, and unsort_hits() puts its hits back at `hits` after the fence.
  Status trace_rays(uint64_t rays, uint64_t hits, uint32_t n, bool any_hit, RayType type, uint32_t bounce,
                    uint32_t place) {
    if (!m_sort || n < 2) return trace(rays, hits, n, any_hit, type, bounce);
    m_sorter.sort(at<const hw::Ray>(m_hal, rays), n, place, type);
    m_unsort[m_num_unsort++] = Unsort{hits, n, place};
    return trace(m_sorter.ray_addr(place), m_sorter.hit_addr(place), n, any_hit, type, bounce);
  }
  // After the fence: the sorted TRACEs' hits back in their rays' order.
  void unsort_hits() {
    for (uint32_t i = 0; i < m_num_unsort; ++i)
      m_sorter.unsort(at<hw::Hit>(m_hal, m_unsort[i].hits), m_unsort[i].n, m_unsort[i].place);
    m_num_unsort = 0;
  }
  void add(uint32_t pixel, const V& radiance) {
    float* fb = at<float>(m_hal, m_job.framebuffer) + uint64_t(pixel) * 3;
    fb[0] += radiance.x * m_inv_spp;
    fb[1] += radiance.y * m_inv_spp;
    fb[2] += radiance.z * m_inv_spp;
  }
  // Offset of a spawned ray's origin from hit point p (ray origin o), per component, in the sign of the normal's
  // component (after Waechter and Binder, "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing
  // Gems, 2019): each coordinate moves by offset_abs + offset_rel * max(|p_i|, |o_i|), the size of its own
  // rounding error, so a component near 0 is not pushed by the ulps of a large one.
  V offset(const V& p, const V& o, const V& n) const {
    V e;
    for (int i = 0; i < 3; ++i)
      e[i] = (m_job.offset_abs + m_job.offset_rel * glm::max(glm::abs(p[i]), glm::abs(o[i]))) * n[i];
    return e;
  }
  hw::Ray camera_ray(uint32_t pixel, uint32_t sample) const;
  // Shades one hit: adds emission, queues shadow/occlusion rays, writes the bounce ray (returns its type index
  // in kBounceTypes, or -1 when the path ends).
  int shade(const hw::Ray& ray, const hw::Hit& hit, Path& path, uint32_t depth, hw::Ray& next);

  Hal& m_hal;
  Ring& m_ring;
  const RenderJob& m_job;
  const ShadingTables& m_tables;
  const hw::AnyHitStage* m_stage;  // the any-hit stage (the rasterizer's alpha test too), or null
  const RaySortJob* m_sort;        // ray sorting's settings, or null: no sorting
  RenderStats& m_st;
  // Ray sorting: the sorter, and the sorted TRACEs whose hits go back after the next fence (at most one per
  // segment: four bounce ray types, or shadow and occlusion rays).
  struct Unsort {
    uint64_t hits;
    uint32_t n, place;
  };
  RaySorter m_sorter;
  Unsort m_unsort[kNumBounceTypes + 1] = {};
  uint32_t m_num_unsort = 0;
  float m_inv_spp = 1.0f;
  uint32_t m_shadow_slots = 0;  // shadow/occlusion rays per path vertex at most
  // Working buffers (device addresses) and the shadow queue of the current bounce.
  uint64_t m_shadow_rays = 0, m_shadow_hits = 0, m_pending = 0;
  uint32_t m_num_shadow = 0, m_num_occlusion = 0;
  uint32_t m_occlusion_base = 0;  // occlusion rays follow the shadow rays' region of the queue
  hw::Ray* m_srays = nullptr;
  Pending* m_spend = nullptr;
  const SurfaceRecord* m_surf = nullptr;
  const MaterialRecord* m_mat = nullptr;
  const LightRecord* m_light = nullptr;
};

hw::Ray Renderer::camera_ray(uint32_t pixel, uint32_t sample) const {
  const uint32_t x = pixel % m_job.width, y = pixel / m_job.width;
  float sx, sy;
  image_plane(m_job, x, y, sample_offset(m_job, pixel, sample), sx, sy);
  const V d = glm::normalize(vec(m_job.forward) + sx * vec(m_job.right) + sy * vec(m_job.up));
  return hw::Ray{vec(m_job.eye), 0.0f, d, kInf};
}

int Renderer::shade(const hw::Ray& ray, const hw::Hit& hit, Path& path, uint32_t depth, hw::Ray& next) {
  if (!hit.hit()) {
    add(path.pixel, path.throughput * vec(m_job.background));
    return -1;
  }
  if (hit.prim >= m_job.num_prims) return -1;  // the unit returned an index outside the scene: end the path
  const SurfaceRecord& s = m_surf[hit.prim];
  const MaterialRecord& m = m_mat[s.material < m_job.num_materials ? s.material : 0];
  // The base colour: the material's, times its texture's at the hit (triangles with texture coordinates).
  V color = vec(m.color);
  if (m.texture != 0 && s.kind == uint32_t(SurfaceKind::kTriangle)) {
    float texel[4];
    surface_texel(m_tables, hit.prim, hit.u, hit.v, texel);
    color *= V(texel[0], texel[1], texel[2]);
  }
  const V d = glm::normalize(ray.dir);
  const V p = ray.origin + hit.t * ray.dir;
  V n;
  if (s.kind == uint32_t(SurfaceKind::kTriangle))
    n = glm::cross(vec(s.b) - vec(s.a), vec(s.c) - vec(s.a));
  else if (s.kind == uint32_t(SurfaceKind::kSphere))
    n = p - vec(s.a);
  else if (s.kind == uint32_t(SurfaceKind::kCurve))
    n = p - (vec(s.a) + hit.u * (vec(s.b) - vec(s.a)));  // from the center of the sphere the hit lies on (u = s)
  else
    n = vec(s.a);
  const float nl = glm::length(n);
  n = nl > 0.0f ? n / nl : -d;
  const bool front = glm::dot(n, d) < 0.0f;
  const V nf = front ? n : -n;  // facing the incoming ray
  const V off = offset(p, ray.origin, nf);
  const V above = p + off, below = p - off;
  const float eps = glm::length(off);
  Rng rng = rng_for(m_job.seed, path.pixel, path.sample, depth + 1);
  const bool can_bounce = depth < m_job.max_depth;

  switch (MaterialKind(m.kind)) {
    case MaterialKind::kEmissive:
      if (path.count_emission) add(path.pixel, path.throughput * vec(m.emission));
      return -1;
    case MaterialKind::kMirror:
      if (!can_bounce) return -1;
      path.throughput *= color;
      path.count_emission = 1;
      next = hw::Ray{above, 0.0f, glm::reflect(d, nf), kInf};
      return 0;
    case MaterialKind::kGlass: {
      if (!can_bounce) return -1;
      const float ior = m.ior > 0.0f ? m.ior : 1.5f;
      const float n1 = front ? 1.0f : ior, n2 = front ? ior : 1.0f, eta = n1 / n2;
      const float cos_i = glm::min(1.0f, -glm::dot(d, nf));
      const float sin2_t = eta * eta * glm::max(0.0f, 1.0f - cos_i * cos_i);
      path.throughput *= color;
      path.count_emission = 1;
      float fresnel = 1.0f;  // total internal reflection
      float cos_t = 0.0f;
      if (sin2_t < 1.0f) {
        cos_t = glm::sqrt(1.0f - sin2_t);
        const float rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
        const float rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
        fresnel = 0.5f * (rs * rs + rp * rp);
      }
      if (rng.next() < fresnel) {
        next = hw::Ray{above, 0.0f, glm::reflect(d, nf), kInf};
        return 0;
      }
      next = hw::Ray{below, 0.0f, glm::normalize(eta * d + (eta * cos_i - cos_t) * nf), kInf};
      return 1;
    }
    case MaterialKind::kDiffuse:
    default:
      break;
  }

  // Diffuse: light from every light through a shadow ray, then indirect light or occlusion.
  const V brdf = color * kInvPi;
  for (uint32_t l = 0; l < m_job.num_lights; ++l) {
    const LightRecord& L = m_light[l];
    V q = vec(L.position), power = vec(L.power);
    float geometry = 1.0f;
    if (L.kind == uint32_t(LightKind::kArea)) {
      const V eu = vec(L.edge_u), ev = vec(L.edge_v);
      q += rng.next() * eu + rng.next() * ev;
      const V ln = glm::cross(eu, ev);
      const V to = q - above;
      const float dist2 = glm::dot(to, to), area = glm::length(ln);
      geometry = dist2 > 0.0f && area > 0.0f ? glm::abs(glm::dot(ln / area, to)) / glm::sqrt(dist2) * area : 0.0f;
    }
    const V to = q - above;
    const float dist2 = glm::dot(to, to);
    if (!(dist2 > 0.0f)) continue;
    const float dist = glm::sqrt(dist2);
    const float cos_s = glm::dot(nf, to) / dist;
    if (cos_s <= 0.0f || geometry <= 0.0f) continue;
    // The ray reaches t = 1 at the light; stop short of it so an area light's own triangles do not shadow it.
    const float tmax = 1.0f - 2.0f * eps / dist;
    if (tmax <= 0.0f) continue;
    m_srays[m_num_shadow] = hw::Ray{above, 0.0f, to, tmax};
    m_spend[m_num_shadow] = Pending{path.throughput * brdf * power * (cos_s * geometry / dist2), path.pixel};
    ++m_num_shadow;
  }
  if (m_job.flags & kRenderAo) {
    // Ambient occlusion: a cosine-distributed ray of length ao_distance; the ambient light (the background
    // radiance) arrives when it escapes: albedo / pi * (pi * ambient) per unoccluded sample.
    const uint32_t slot = m_occlusion_base + m_num_occlusion++;
    m_srays[slot] = hw::Ray{above, 0.0f, cosine_direction(nf, rng), m_job.ao_distance};
    m_spend[slot] = Pending{path.throughput * color * vec(m_job.background), path.pixel};
  }
  if ((m_job.flags & kRenderIndirect) && !(m_job.flags & kRenderAo) && can_bounce) {
    path.throughput *= color;
    path.count_emission = 0;
    next = hw::Ray{above, 0.0f, cosine_direction(nf, rng), kInf};
    return 2;
  }
  return -1;
}

// The ray types the scene needs, from its materials and lights, and the shadow slots per path.
void Renderer::plan_ray_types() {
  const RenderJob& j = m_job;
  bool diffuse = false, mirror = false, glass = false;
  for (uint32_t i = 0; i < j.num_materials; ++i) {
    diffuse |= m_mat[i].kind == uint32_t(MaterialKind::kDiffuse);
    mirror |= m_mat[i].kind == uint32_t(MaterialKind::kMirror);
    glass |= m_mat[i].kind == uint32_t(MaterialKind::kGlass);
  }
  const bool bounces = j.max_depth > 0;
  m_st.need_shadow = diffuse && j.num_lights > 0;
  m_st.need_reflection = bounces && (mirror || glass);
  m_st.need_refraction = bounces && glass;
  m_st.need_occlusion = diffuse && (j.flags & kRenderAo);
  m_st.need_diffuse = bounces && diffuse && (j.flags & kRenderIndirect) && !(j.flags & kRenderAo);
  m_shadow_slots = (m_st.need_shadow ? j.num_lights : 0) + (m_st.need_occlusion ? 1 : 0);
}

// The batch size: what the arena holds, per path: two path states, two ray buffers and a hit buffer, a type byte,
// and per shadow slot a ray, a hit and a pending contribution; hybrid mode with jittered samples adds each
// sample's offset in its pixel (the rasterizer's positions); ray sorting, per path, the sorted places of its
// bounce ray or its shadow slots, whichever are more, and once the digit histogram. Then the batch's buffers, the
// shadow queue and the sorter's in the arena; kNoMemory when they do not fit.
Status Renderer::allocate(Arena& arena, Buffers& buf) {
  const RenderJob& j = m_job;
  const uint32_t light_slots = m_st.need_shadow ? j.num_lights : 0;
  buf.jitter = buf.hybrid && j.spp > 1;
  const uint64_t per_path = 2 * sizeof(Path) + 2 * sizeof(hw::Ray) + sizeof(hw::Hit) + 1 +
                            uint64_t(m_shadow_slots) * (sizeof(hw::Ray) + sizeof(hw::Hit) + sizeof(Pending)) +
                            (buf.jitter ? sizeof(SampleOffset) : 0);
  const uint64_t sort_per_path = m_sort ? RaySorter::kBytesPerRay * (m_shadow_slots > 1 ? m_shadow_slots : 1) : 0;
  const uint64_t reserve = 1024 + (m_sort ? RaySorter::fixed_bytes(m_sort->radix_bits) : 0);
  const uint64_t room = arena.size() > arena.used() + reserve ? arena.size() - arena.used() - reserve : 0;
  uint64_t batch = room / (per_path + sort_per_path);
  if (batch > m_st.paths) batch = m_st.paths;
  if (batch > (1u << 18)) batch = 1u << 18;
  if (batch == 0) return Status::kNoMemory;
  buf.batch = batch;
  m_st.batch_paths = uint32_t(batch);
  buf.paths = arena.alloc(batch * sizeof(Path));
  buf.next_paths = arena.alloc(batch * sizeof(Path));
  buf.rays = arena.alloc(batch * sizeof(hw::Ray));
  buf.next_rays = arena.alloc(batch * sizeof(hw::Ray));
  buf.hits = arena.alloc(batch * sizeof(hw::Hit));
  buf.types = arena.alloc(batch, 1);
  const uint64_t shadow_n = batch * m_shadow_slots;
  m_occlusion_base = uint32_t(batch * light_slots);
  m_shadow_rays = arena.alloc(shadow_n * sizeof(hw::Ray) + 16);
  m_shadow_hits = arena.alloc(shadow_n * sizeof(hw::Hit) + 16);
  m_pending = arena.alloc(shadow_n * sizeof(Pending) + 16);
  buf.offsets = buf.jitter ? arena.alloc(batch * sizeof(SampleOffset)) : 0;
  if (buf.offsets == Arena::kNull) return Status::kNoMemory;
  if (buf.paths == Arena::kNull || buf.next_paths == Arena::kNull || buf.rays == Arena::kNull ||
      buf.next_rays == Arena::kNull || buf.hits == Arena::kNull || buf.types == Arena::kNull ||
      m_shadow_rays == Arena::kNull || m_shadow_hits == Arena::kNull || m_pending == Arena::kNull)
    return Status::kNoMemory;
  if (m_sort && !m_sorter.init(m_hal, arena, *m_sort, uint32_t(batch > shadow_n ? batch : shadow_n), m_st.sort))
    return Status::kNoMemory;
  m_st.sorted = m_sort != nullptr;
  m_srays = at<hw::Ray>(m_hal, m_shadow_rays);
  m_spend = at<Pending>(m_hal, m_pending);
  return Status::kOk;
}

// The n paths of a batch from path `first`: their camera rays, and in hybrid mode their primary hits from the
// rasterizer (the G-buffer is the primary hit buffer; the camera rays stay for shading, their origin and
// direction, but are not traced).
void Renderer::start_paths(const Buffers& buf, uint64_t first, uint32_t n) {
  const RenderJob& j = m_job;
  const uint32_t spp = j.spp ? j.spp : 1;
  Path* paths = at<Path>(m_hal, buf.paths);
  hw::Ray* rays = at<hw::Ray>(m_hal, buf.rays);
  for (uint32_t i = 0; i < n; ++i) {
    const uint64_t k = first + i;
    paths[i] = Path{V(1.0f), uint32_t(k / spp), uint32_t(k % spp), 1};
    rays[i] = camera_ray(paths[i].pixel, paths[i].sample);
  }
  if (!buf.hybrid) return;
  SampleOffset* offsets = buf.jitter ? at<SampleOffset>(m_hal, buf.offsets) : nullptr;
  if (offsets)
    for (uint32_t i = 0; i < n; ++i) offsets[i] = sample_offset(j, paths[i].pixel, paths[i].sample);
  rasterize(j, m_surf, offsets, first, n, at<hw::Hit>(m_hal, buf.hits), m_st.raster, m_stage);
  m_st.primary_rasterized += n;
}

// A bounce's TRACEs, one per segment of the ray buffer, and the fence after them.
Status Renderer::trace_segments(const Buffers& buf, const Segments& seg, uint32_t depth) {
  Status s = Status::kOk;
  uint32_t submitted = 0;
  for (int t = 0; t < kNumBounceTypes + 1; ++t) {
    s = trace_rays(buf.rays + uint64_t(seg.begin[t]) * sizeof(hw::Ray),
                   buf.hits + uint64_t(seg.begin[t]) * sizeof(hw::Hit), seg.count[t], false, kSegmentTypes[t],
                   depth, seg.begin[t]);
    if (s != Status::kOk) return s;
    submitted += seg.count[t];
  }
  if (submitted > 0 && (s = m_ring.sync()) != Status::kOk) return s;
  unsort_hits();
  return Status::kOk;
}

// Shades the n hits of a bounce: the bounce rays staged in next_rays / next_paths with their type, counted per
// type in `count`; shadow and occlusion rays queued. Returns how many were staged.
uint32_t Renderer::shade_bounce(const Buffers& buf, uint32_t n, uint32_t depth,
                                uint32_t (&count)[kNumBounceTypes]) {
  Path* paths = at<Path>(m_hal, buf.paths);
  Path* next_paths = at<Path>(m_hal, buf.next_paths);
  const hw::Ray* rays = at<const hw::Ray>(m_hal, buf.rays);
  hw::Ray* next_rays = at<hw::Ray>(m_hal, buf.next_rays);
  const hw::Hit* hits = at<const hw::Hit>(m_hal, buf.hits);
  uint8_t* types = at<uint8_t>(m_hal, buf.types);
  m_num_shadow = m_num_occlusion = 0;
  uint32_t staged = 0;
  for (uint32_t i = 0; i < n; ++i) {
    hw::Ray next{};
    const int t = shade(rays[i], hits[i], paths[i], depth, next);
    if (t < 0) continue;
    next_rays[staged] = next;
    next_paths[staged] = paths[i];
    types[staged] = uint8_t(t);
    ++count[t];
    ++staged;
  }
  return staged;
}

// Shadow and occlusion rays: any-hit TRACEs; the contributions of those that reach their target.
Status Renderer::trace_shadows(uint32_t depth) {
  if (m_num_shadow + m_num_occlusion == 0) return Status::kOk;
  Status s = Status::kOk;
  if ((s = trace_rays(m_shadow_rays, m_shadow_hits, m_num_shadow, true, RayType::kShadow, depth, 0)) !=
          Status::kOk ||
      (s = trace_rays(m_shadow_rays + uint64_t(m_occlusion_base) * sizeof(hw::Ray),
                      m_shadow_hits + uint64_t(m_occlusion_base) * sizeof(hw::Hit), m_num_occlusion, true,
                      RayType::kOcclusion, depth, m_occlusion_base)) != Status::kOk)
    return s;
  if ((s = m_ring.sync()) != Status::kOk) return s;
  unsort_hits();
  const hw::Hit* shits = at<const hw::Hit>(m_hal, m_shadow_hits);
  for (uint32_t i = 0; i < m_num_shadow; ++i)
    if (!shits[i].hit()) add(m_spend[i].pixel, m_spend[i].radiance);
  for (uint32_t i = m_occlusion_base; i < m_occlusion_base + m_num_occlusion; ++i)
    if (!shits[i].hit()) add(m_spend[i].pixel, m_spend[i].radiance);
  return Status::kOk;
}

// The staged rays grouped by type into the ray buffer (stable), the paths likewise; `seg` becomes the next
// bounce's segments (no primary rays). Returns the number of rays, `staged`.
uint32_t Renderer::group_by_type(const Buffers& buf, uint32_t staged, const uint32_t (&count)[kNumBounceTypes],
                                 Segments& seg) {
  Path* paths = at<Path>(m_hal, buf.paths);
  const Path* next_paths = at<const Path>(m_hal, buf.next_paths);
  hw::Ray* rays = at<hw::Ray>(m_hal, buf.rays);
  const hw::Ray* next_rays = at<const hw::Ray>(m_hal, buf.next_rays);
  const uint8_t* types = at<const uint8_t>(m_hal, buf.types);
  uint32_t begin[kNumBounceTypes] = {0, count[0], count[0] + count[1]};
  for (int t = 0; t < kNumBounceTypes; ++t) {
    seg.begin[t + 1] = begin[t];
    seg.count[t + 1] = count[t];
  }
  seg.count[0] = 0;
  for (uint32_t i = 0; i < staged; ++i) {
    const uint32_t dst = begin[types[i]]++;
    rays[dst] = next_rays[i];
    paths[dst] = next_paths[i];
  }
  return staged;
}

// One batch of paths from path `first`, bounce after bounce until no path continues.
Status Renderer::render_batch(const Buffers& buf, uint64_t first) {
  ++m_st.batches;
  uint32_t n = uint32_t(m_st.paths - first < buf.batch ? m_st.paths - first : buf.batch);
  start_paths(buf, first, n);
  Segments seg = {{0, 0, 0, 0}, {buf.hybrid ? 0u : n, 0, 0, 0}};
  const hw::Hit* hits = at<const hw::Hit>(m_hal, buf.hits);
  Status s = Status::kOk;
  for (uint32_t depth = 0; n > 0; ++depth) {
    ++m_st.bounces;
    if ((s = trace_segments(buf, seg, depth)) != Status::kOk) return s;
    if (depth == 0 && m_job.primary_hits != 0) {  // the primary hits, for comparing the two modes
      hw::Hit* out = at<hw::Hit>(m_hal, m_job.primary_hits) + first;
      for (uint32_t i = 0; i < n; ++i) out[i] = hits[i];
    }
    uint32_t count[kNumBounceTypes] = {0, 0, 0};
    const uint32_t staged = shade_bounce(buf, n, depth, count);
    if ((s = trace_shadows(depth)) != Status::kOk) return s;
    n = group_by_type(buf, staged, count, seg);
  }
  return Status::kOk;
}

Status Renderer::run(Arena& arena) {
  const RenderJob& j = m_job;
  m_surf = at<const SurfaceRecord>(m_hal, j.surfaces);
  m_mat = at<const MaterialRecord>(m_hal, j.materials);
  m_light = at<const LightRecord>(m_hal, j.lights);
  m_inv_spp = 1.0f / float(j.spp ? j.spp : 1);
  m_st.paths = uint64_t(j.width) * j.height * (j.spp ? j.spp : 1);

  plan_ray_types();
  Status s = m_ring.submit(hw::cmd::bind_scene(j.scene_image, j.scene_bytes));
  if (s != Status::kOk) return s;

  Buffers buf;
  buf.hybrid = (j.flags & kRenderHybrid) != 0;
  m_st.hybrid = buf.hybrid;
  if (buf.hybrid && (j.width > kMaxRasterSide || j.height > kMaxRasterSide)) return Status::kBadArgument;
  if ((s = allocate(arena, buf)) != Status::kOk) return s;

  float* fb = at<float>(m_hal, j.framebuffer);
  for (uint64_t i = 0; i < uint64_t(j.width) * j.height * 3; ++i) fb[i] = 0.0f;
  for (uint64_t first = 0; first < m_st.paths; first += buf.batch)
    if ((s = render_batch(buf, first)) != Status::kOk) return s;
  return Status::kOk;
}

}  // namespace

Status render(Hal& hal, Ring& ring, Arena& arena, uint64_t job_addr, RenderStats& stats) {
  stats = RenderStats{};
  const RenderJob& job = *at<const RenderJob>(hal, job_addr);
  if (job.width == 0 || job.height == 0 || job.num_materials == 0) return Status::kBadArgument;
  // The shading records the any-hit stage and the shading read; the texture and coordinate tables must lie in
  // device memory (texels are checked per lookup: ShadingTables::texture_of).
  const uint64_t mem = hal.mem_size();
  auto inside = [mem](uint64_t addr, uint64_t count, uint64_t size) {
    return count == 0 || (addr <= mem && count <= (mem - addr) / size);
  };
  if (!inside(job.surfaces, job.num_prims, sizeof(SurfaceRecord)) ||
      !inside(job.materials, job.num_materials, sizeof(MaterialRecord)) ||
      !inside(job.uvs, job.num_uvs, sizeof(UvRecord)) ||
      !inside(job.textures, job.num_textures, sizeof(TextureRecord)))
    return Status::kBadArgument;
  ShadingTables tables;
  tables.surfaces = at<const SurfaceRecord>(hal, job.surfaces);
  tables.num_prims = job.num_prims;
  tables.materials = at<const MaterialRecord>(hal, job.materials);
  tables.num_materials = job.num_materials;
  tables.uvs = job.num_uvs ? at<const UvRecord>(hal, job.uvs) : nullptr;
  tables.num_uvs = job.num_uvs;
  tables.textures = job.num_textures ? at<const TextureRecord>(hal, job.textures) : nullptr;
  tables.num_textures = job.num_textures;
  tables.mem = hal.mem();
  tables.mem_size = mem;
  // Ray sorting: its record follows the job; a key or digit width the sorter does not know is refused.
  const RaySortJob* sort = nullptr;
  if (job.flags & kRenderRaySort) {
    const uint64_t sort_addr = job_addr + sizeof(RenderJob);
    if (!inside(sort_addr, 1, sizeof(RaySortJob))) return Status::kBadArgument;
    sort = at<const RaySortJob>(hal, sort_addr);
    if (ray_sort_key_bits(RaySortKey(sort->key)) == 0 || sort->radix_bits < 1 || sort->radix_bits > 16)
      return Status::kBadArgument;
  }
  // The any-hit stage answers the unit while the job runs, when a material is alpha-masked.
  bool masked = false;
  for (uint32_t i = 0; i < job.num_materials; ++i)
    masked |= tables.materials[i].alpha_mode == uint32_t(AlphaMode::kMask);
  const AlphaStage stage(tables);
  if (masked) hal.set_any_hit(&stage);
  Renderer r(hal, ring, job, tables, masked ? &stage : nullptr, sort, stats);
  const Status st = r.run(arena);
  if (masked) hal.set_any_hit(nullptr);
  return st;
}

}  // namespace rtu::fw
