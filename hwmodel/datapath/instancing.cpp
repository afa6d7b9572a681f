#include "hwmodel/datapath/instancing.h"

#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "hwmodel/datapath/batch.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/traverse.h"

namespace rtu::hw {

bool Affine::is_identity() const {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      if (m[r][c] != (r == c ? 1.0f : 0.0f)) return false;
  return true;
}

Vec3 Affine::point(const Vec3& p) const {
  Vec3 o;
  for (int r = 0; r < 3; ++r)
    o[r] = float(double(m[r][0]) * p.x + double(m[r][1]) * p.y + double(m[r][2]) * p.z + double(m[r][3]));
  return o;
}

Vec3 Affine::vector(const Vec3& v) const {
  Vec3 o;
  for (int r = 0; r < 3; ++r) o[r] = float(double(m[r][0]) * v.x + double(m[r][1]) * v.y + double(m[r][2]) * v.z);
  return o;
}

bool invert(const Affine& a, AffineD& inv) {
  AffineD d;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) d.m[r][c] = a.m[r][c];
  return invert(d, inv);
}

bool invert(const AffineD& a, AffineD& inv) {
  double l[3][3], t[3];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(a.m[r][c])) return false;
    for (int c = 0; c < 3; ++c) l[r][c] = a.m[r][c];
    t[r] = a.m[r][3];
  }
  // Cofactors: inverse = adj(L) / det(L).
  const double c00 = l[1][1] * l[2][2] - l[1][2] * l[2][1];
  const double c01 = l[1][2] * l[2][0] - l[1][0] * l[2][2];
  const double c02 = l[1][0] * l[2][1] - l[1][1] * l[2][0];
  const double det = l[0][0] * c00 + l[0][1] * c01 + l[0][2] * c02;
  double rows = 1.0;
  for (int r = 0; r < 3; ++r) rows *= std::sqrt(l[r][0] * l[r][0] + l[r][1] * l[r][1] + l[r][2] * l[r][2]);
  if (!(std::fabs(det) > std::ldexp(rows, -40)) || !std::isfinite(det)) return false;
  const double id = 1.0 / det;
  double m[3][3];
  m[0][0] = c00 * id;
  m[1][0] = c01 * id;
  m[2][0] = c02 * id;
  m[0][1] = (l[0][2] * l[2][1] - l[0][1] * l[2][2]) * id;
  m[1][1] = (l[0][0] * l[2][2] - l[0][2] * l[2][0]) * id;
  m[2][1] = (l[0][1] * l[2][0] - l[0][0] * l[2][1]) * id;
  m[0][2] = (l[0][1] * l[1][2] - l[0][2] * l[1][1]) * id;
  m[1][2] = (l[0][2] * l[1][0] - l[0][0] * l[1][2]) * id;
  m[2][2] = (l[0][0] * l[1][1] - l[0][1] * l[1][0]) * id;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) inv.m[r][c] = m[r][c];
    inv.m[r][3] = -(m[r][0] * t[0] + m[r][1] * t[1] + m[r][2] * t[2]);
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(inv.m[r][c])) return false;
  }
  return true;
}

void InstanceSet::finish() {
  uint32_t tri = 0;
  for (Instance& in : instances) {
    in.tri_base = tri;
    tri += in.mesh < meshes.size() ? uint32_t(meshes[in.mesh].triangles.size()) : 0;
  }
  uint32_t sph = tri;
  for (Instance& in : instances) {
    in.sphere_base = sph;
    sph += in.mesh < meshes.size() ? uint32_t(meshes[in.mesh].spheres.size()) : 0;
  }
  uint32_t cur = sph;
  for (Instance& in : instances) {
    in.curve_base = cur;
    cur += in.mesh < meshes.size() ? uint32_t(meshes[in.mesh].curves.size()) : 0;
  }
}

bool similarity_scale(const Affine& a, double& scale) {
  // L L^T = s^2 I: rows of equal length, pairwise orthogonal, within 2^-20 of s^2 (float entries carry 2^-24).
  double g[3][3];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      g[r][c] = double(a.m[r][0]) * a.m[c][0] + double(a.m[r][1]) * a.m[c][1] + double(a.m[r][2]) * a.m[c][2];
  const double s2 = (g[0][0] + g[1][1] + g[2][2]) / 3.0;
  if (!(s2 > 0.0) || !std::isfinite(s2)) return false;
  const double tol = std::ldexp(s2, -20);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (!(std::fabs(g[r][c] - (r == c ? s2 : 0.0)) <= tol)) return false;
  scale = std::sqrt(s2);
  return true;
}

uint32_t InstanceSet::num_triangles() const {
  uint64_t n = 0;
  for (const Instance& in : instances) n += meshes[in.mesh].triangles.size();
  return uint32_t(std::min<uint64_t>(n, UINT32_MAX));
}

uint32_t InstanceSet::num_spheres() const {
  uint64_t n = 0;
  for (const Instance& in : instances) n += meshes[in.mesh].spheres.size();
  return uint32_t(std::min<uint64_t>(n, UINT32_MAX));
}

void InstanceSet::validate() const {
  uint64_t prims = 0;
  for (size_t m = 0; m < meshes.size(); ++m)
    if (!meshes[m].planes.empty())
      throw std::invalid_argument("instanced mesh " + std::to_string(m) +
                                  " has planes (planes are not instanced)");
  for (size_t i = 0; i < instances.size(); ++i) {
    const Instance& in = instances[i];
    const std::string who = "instance " + std::to_string(i);
    if (in.mesh >= meshes.size())
      throw std::invalid_argument(who + ": mesh " + std::to_string(in.mesh) + " out of range (" +
                                  std::to_string(meshes.size()) + " meshes)");
    AffineD inv;
    if (!invert(in.to_world, inv))
      throw std::invalid_argument(who + ": the transform is not finite or is singular");
    const Geometry& g = meshes[in.mesh];
    double scale;
    if ((!g.spheres.empty() || !g.curves.empty()) && !similarity_scale(in.to_world, scale))
      throw std::invalid_argument(who +
                                  ": spheres and curve segments may only be instanced with a similarity "
                                  "transform (rotation, uniform scale, translation): they would not stay round");
    prims += g.num_bounded();
    if (prims >= kMaxBvhPrims) throw std::invalid_argument("instances hold more than 2^27 - 1 primitives in all");
    if (g.num_bounded() == 0) continue;
    const Aabb b = world_bounds(uint32_t(i));
    for (int a = 0; a < 3; ++a)
      if (!(std::fabs(b.lo[a]) <= kMaxCoordinate && std::fabs(b.hi[a]) <= kMaxCoordinate))
        throw std::invalid_argument(who + ": world bounds beyond 2^62");
  }
  uint32_t tri = 0;
  for (const Instance& in : instances) {
    if (in.tri_base != tri) throw std::invalid_argument("instance bases not set (InstanceSet::finish)");
    tri += uint32_t(meshes[in.mesh].triangles.size());
  }
  uint32_t sph = tri, cur = num_triangles() + num_spheres();
  for (const Instance& in : instances) {
    if (in.sphere_base != sph || in.curve_base != cur)
      throw std::invalid_argument("instance bases not set (InstanceSet::finish)");
    sph += uint32_t(meshes[in.mesh].spheres.size());
    cur += uint32_t(meshes[in.mesh].curves.size());
  }
}

Aabb InstanceSet::world_bounds(uint32_t inst) const {
  const Instance& in = instances[inst];
  AffineD x;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) x.m[r][c] = in.to_world.m[r][c];
  return hw::world_bounds(meshes[in.mesh].bounds(), x);
}

Aabb world_bounds(const Aabb& ob, const AffineD& to_world) {
  Aabb w;
  if (ob.empty()) return w;
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = INFINITY;
    hi[a] = -INFINITY;
  }
  for (int k = 0; k < 8; ++k) {
    const double p[3] = {k & 1 ? ob.hi.x : ob.lo.x, k & 2 ? ob.hi.y : ob.lo.y, k & 4 ? ob.hi.z : ob.lo.z};
    for (int r = 0; r < 3; ++r) {
      const double x =
          to_world.m[r][0] * p[0] + to_world.m[r][1] * p[1] + to_world.m[r][2] * p[2] + to_world.m[r][3];
      lo[r] = std::min(lo[r], x);
      hi[r] = std::max(hi[r], x);
    }
  }
  double mag = 0.0;
  for (int a = 0; a < 3; ++a) mag = std::max({mag, std::fabs(lo[a]), std::fabs(hi[a])});
  const double pad = std::ldexp(mag, -20);
  for (int a = 0; a < 3; ++a) {
    w.lo[a] = std::nextafter(float(lo[a] - pad), -INFINITY);
    w.hi[a] = std::nextafter(float(hi[a] + pad), INFINITY);
  }
  return w;
}

Geometry InstanceSet::flatten(const std::vector<Plane>& planes) const {
  Geometry g;
  g.triangles.reserve(num_triangles());
  for (const Instance& in : instances) {
    const Affine& x = in.to_world;
    const bool id = x.is_identity();
    for (const Triangle& t : meshes[in.mesh].triangles)
      g.triangles.push_back(id ? t : Triangle{x.point(t.v0), x.point(t.v1), x.point(t.v2)});
  }
  bool any_non_opaque = false;
  for (const Geometry& m : meshes) any_non_opaque |= !m.non_opaque.empty();
  if (any_non_opaque) {
    g.non_opaque.reserve(g.triangles.size());
    for (const Instance& in : instances) {
      const Geometry& m = meshes[in.mesh];
      for (uint32_t j = 0; j < m.triangles.size(); ++j) g.non_opaque.push_back(m.opaque(j) ? 0 : 1);
    }
  }
  // Round primitives under a similarity: centers and end points placed, radii scaled (both rounded to nearest).
  // Each instance's scale, 0 for the identity (and for what validate() refuses: not a similarity).
  std::vector<double> scale(instances.size(), 0.0);
  for (size_t i = 0; i < instances.size(); ++i) {
    const Geometry& m = meshes[instances[i].mesh];
    if ((!m.spheres.empty() || !m.curves.empty()) && !instances[i].to_world.is_identity() &&
        !similarity_scale(instances[i].to_world, scale[i]))
      scale[i] = 0.0;
  }
  for (size_t i = 0; i < instances.size(); ++i) {
    const Affine& x = instances[i].to_world;
    const double k = scale[i];
    for (const Sphere& s : meshes[instances[i].mesh].spheres)
      g.spheres.push_back(k == 0.0 ? s : Sphere{x.point(s.center), float(k * s.radius)});
  }
  for (size_t i = 0; i < instances.size(); ++i) {
    const Affine& x = instances[i].to_world;
    const double k = scale[i];
    for (const CurveSegment& c : meshes[instances[i].mesh].curves)
      g.curves.push_back(
          k == 0.0 ? c : CurveSegment{x.point(c.p0), float(k * c.r0), x.point(c.p1), float(k * c.r1), c.flags});
  }
  g.planes = planes;
  return g;
}

Ray object_ray(const AffineD& x, const Ray& r) {
  Ray o = r;
  for (int k = 0; k < 3; ++k) {
    o.origin[k] = float(x.m[k][0] * r.origin.x + x.m[k][1] * r.origin.y + x.m[k][2] * r.origin.z + x.m[k][3]);
    o.dir[k] = float(x.m[k][0] * r.dir.x + x.m[k][1] * r.dir.y + x.m[k][2] * r.dir.z);
  }
  return o;
}

bool trace_instance_float(const FloatTracer& mesh, const Ray& o, const InstanceSet& set, uint32_t inst,
                          bool any_hit, const AnyHitStage* stage, Hit& closest, TraversalStats& s) {
  TraversalStats inner;
  const Hit h = mesh.trace(o, any_hit, inner, stage);
  s.add_work(inner);
  if (!h.hit() || !(h.t <= closest.t)) return false;
  closest = Hit{h.t, set.global_prim(inst, h.prim), h.u, h.v};
  return true;
}

namespace {

template <int N>
struct TopPolicy {
  using Dist = float;
  static constexpr int kWidth = N;

  const WideBvh<N>& top;
  const std::vector<uint32_t>& top_ids;
  const InstanceSet& set;
  const std::vector<std::unique_ptr<FloatTracer>>& tracers;
  const std::vector<AffineD>& to_object;
  const Ray& ray;
  const RayPrecomp& rp;
  bool any_hit;
  Hit& closest;
  TraversalStats& s;
  const AnyHitStage* stage;
  HitList* all;  // all-hit traversal: every instance's hits go here and the closest is never narrowed

  int expand(uint32_t node, uint32_t refs[N], float dists[N], int& tested) const {
    return expand_wide_node(top.nodes[node], rp, ray.tmin, closest.t, refs, dists, tested);
  }

  bool leaf(uint32_t ref) const {
    bool found = false;
    for (uint32_t i = 0; i < leaf_count(ref); ++i) {
      const uint32_t inst = top_ids[top.prim_ids[leaf_first(ref) + i]];
      Ray o = object_ray(to_object[inst], ray);
      o.tmax = closest.t;
      TraversalStats inner;
      std::optional<InstanceAnyHit> local;
      if (stage) local.emplace(*stage, set, inst);
      const FloatTracer& mesh = *tracers[set.instances[inst].mesh];
      if (all) {
        const uint64_t from = all->count;
        mesh.trace_all(o, *all, inner, local ? &*local : nullptr);
        s.add_work(inner);
        for (uint64_t j = from; j < all->kept(); ++j) all->out[j].prim = set.global_prim(inst, all->out[j].prim);
        continue;
      }
      if (trace_instance_float(mesh, o, set, inst, any_hit, local ? &*local : nullptr, closest, s)) {
        found = true;
        if (any_hit) return true;
      }
    }
    return found;
  }

  float limit() const { return closest.t; }
  void pushed(const uint32_t*, int, int) const {}
  void popped(int) const {}
};

}  // namespace

InstancedFloatTracer::InstancedFloatTracer(const InstanceSet& set, const Geometry& flat, const TracerOptions& opt)
    : m_set(set), m_flat(flat) {
  set.validate();
  m_planes.planes = flat.planes;
  m_plane_tracer = std::make_unique<FloatTracer>(m_planes, opt);
  for (const Geometry& g : set.meshes) m_mesh_tracers.push_back(std::make_unique<FloatTracer>(g, opt));
  std::vector<Aabb> boxes;
  for (uint32_t i = 0; i < set.instances.size(); ++i) {
    AffineD inv;
    invert(set.instances[i].to_world, inv);  // validate() has proven it invertible
    m_to_object.push_back(inv);
    boxes.push_back(set.world_bounds(i));
  }
  // An instance with no bounded primitives has an empty box: leave it out of the top level (it cannot be hit).
  std::vector<Aabb> kept;
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < boxes.size(); ++i) {
    if (boxes[i].empty()) continue;
    kept.push_back(boxes[i]);
    ids.push_back(i);
  }
  // The top level's leaves hold one instance each: an instance test is a whole bottom-level traversal, so
  // separating instances is worth more nodes.
  BvhBuildParams top = opt.bvh;
  top.max_leaf_size = 1;
  top.prim_cost = 1.0f;
  m_top = Bvh::build(kept, top);
  m_top_ids = std::move(ids);
}

InstancedFloatTracer::~InstancedFloatTracer() = default;

uint64_t InstancedFloatTracer::bytes() const {
  uint64_t b = m_top.figures().node_bytes;
  for (const auto& t : m_mesh_tracers) b += (t->bvh() ? t->bvh()->figures().node_bytes : 0) + t->leaf_prim_bytes();
  return b;
}

template <int N>
void InstancedFloatTracer::trace_top(const WideBvh<N>& t, const Ray& r, bool any_hit, Hit& h, TraversalStats& s,
                                     HitList* all) const {
  if (t.root_ref == kEmptyChild) return;
  const RayPrecomp rp(r);
  TopPolicy<N> policy{t, m_top_ids, m_set, m_mesh_tracers, m_to_object, r, rp, any_hit, h, s, m_any_hit, all};
  traverse(policy, t.root_ref, any_hit, s);
}

Hit InstancedFloatTracer::trace(const Ray& r, bool any_hit, TraversalStats& s) const {
  // Planes (and the ray's validity) by the plane tracer: its counts are the ray's.
  Hit h = m_plane_tracer->trace(r, any_hit, s);
  if (validate_ray(r) != RayStatus::kOk) return h;
  if (h.hit()) {
    --s.hits;  // counted again below when the ray ends with a hit
    h.prim = m_flat.plane_prim(h.prim);
    if (any_hit) {
      ++s.hits;
      return h;
    }
  } else {
    h.t = r.tmax;
  }
  m_top.visit([&](const auto& t) { trace_top(t, r, any_hit, h, s); });
  if (!h.hit()) return Hit{};
  ++s.hits;
  return h;
}

uint64_t InstancedFloatTracer::trace_all(const Ray& r, HitList& all, TraversalStats& s) const {
  // Planes (and the ray's validity, and its hit if a plane is hit) by the plane tracer.
  const uint64_t before = all.count;
  m_plane_tracer->trace_all(r, all, s);
  if (validate_ray(r) != RayStatus::kOk) return all.count;
  for (uint64_t j = before; j < all.kept(); ++j) all.out[j].prim = m_flat.plane_prim(all.out[j].prim);
  const bool counted = all.count > before;
  Hit h{r.tmax};
  m_top.visit([&](const auto& t) { trace_top(t, r, false, h, s, &all); });
  if (!counted && all.count > before) ++s.hits;
  return all.count;
}

void InstancedFloatTracer::trace_batch(const Ray* rays, Hit* hits, size_t n, bool any_hit, int threads,
                                       TraversalStats& s) const {
  run_batch(n, threads, s, [&](size_t i, TraversalStats& local) { hits[i] = trace(rays[i], any_hit, local); });
}

}  // namespace rtu::hw
