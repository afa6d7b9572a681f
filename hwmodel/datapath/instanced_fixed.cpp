#include "hwmodel/datapath/instanced_fixed.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "hwmodel/datapath/intersect_fixed.h"

namespace rtu::hw {

float round_significant(double x, int bits) {
  if (bits < 8 || bits > 24) throw std::invalid_argument("round_significant: bits outside 8..24");
  if (x == 0.0 || !std::isfinite(x)) return float(x);
  // x = m * 2^e with |m| in [2^(bits-1), 2^bits): m rounded to an integer (nearest even) is exact in double.
  const int e = std::ilogb(x) - (bits - 1);
  const double m = std::nearbyint(std::ldexp(x, -e));
  return float(std::ldexp(m, e));  // at most 24 significant bits: exact in float unless it over- or underflows
}

StoredXform StoredXform::from_inverse(const AffineD& inv, int xform_bits) {
  StoredXform x;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      x.m[r][c] = round_significant(inv.m[r][c], xform_bits);
      if (!std::isfinite(x.m[r][c]))
        throw std::invalid_argument("instance transform: an inverse entry beyond the float range");
    }
  return x;
}

Ray StoredXform::apply(const Ray& w) const {
  Ray o = w;
  // Products of two floats are exact in double; the sums of three or four of them are rounded once in double
  // (53 bits), then once to float: the result is the correctly rounded fused dot product except when the double
  // sum lands exactly on a float rounding boundary it did not start on (probability about 2^-29 per component).
  for (int k = 0; k < 3; ++k) {
    const double px = double(m[k][0]) * double(w.origin.x), py = double(m[k][1]) * double(w.origin.y),
                 pz = double(m[k][2]) * double(w.origin.z);
    o.origin[k] = float(px + py + pz + double(m[k][3]));
    const double dx = double(m[k][0]) * double(w.dir.x), dy = double(m[k][1]) * double(w.dir.y),
                 dz = double(m[k][2]) * double(w.dir.z);
    o.dir[k] = float(dx + dy + dz);
  }
  return o;
}

uint32_t StoredXform::bytes(int xform_bits) {
  return (12 * uint32_t(1 + 8 + xform_bits - 1) + 7) / 8;
}

// The any-hit stage as a bottom level sees it: its triangle indices are the mesh's, the stage's the flattened
// scene's.
class InstancedFixedTracer::Stage final : public AnyHitStage {
 public:
  Stage(const AnyHitStage& stage, const InstancedFixedTracer& t, uint32_t inst)
      : m_stage(stage), m_t(t), m_inst(inst) {}
  bool accept(uint32_t prim, float u, float v) const override {
    return m_stage.accept(m_t.global_prim(m_inst, prim), u, v);
  }

 private:
  const AnyHitStage& m_stage;
  const InstancedFixedTracer& m_t;
  uint32_t m_inst;
};

InstancedFixedTracer::InstancedFixedTracer(const InstanceSet& set, const Geometry& flat, const FixedFormat& f,
                                           const TracerOptions& opt, const FixedTraceOptions& trace_opt)
    : m_format(f) {
  f.validate();
  set.validate();
  if (opt.bvh.width != f.width)
    throw std::invalid_argument("InstancedFixedTracer: BVH width " + std::to_string(opt.bvh.width) +
                                " differs from the format's width " + std::to_string(f.width));
  for (const Geometry& g : set.meshes) {
    const std::optional<Bvh> bvh = choose_accel(g, opt);
    m_bottoms.push_back(std::make_unique<DeviceImage>(encode_scene(g, f, bvh ? &*bvh : nullptr)));
    m_mesh_spheres.push_back(uint32_t(g.spheres.size()));
  }
  // The top level as the float reference builds it (instancing.cpp): one instance per leaf, empty ones left out.
  std::vector<Aabb> kept;
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < set.instances.size(); ++i) {
    const Instance& in = set.instances[i];
    AffineD inv;
    invert(in.to_world, inv);  // validate() has proven it invertible
    m_xforms.push_back(StoredXform::from_inverse(inv, f.xform_bits));
    m_info.push_back(Info{in.mesh, in.tri_base, in.sphere_base, in.curve_base});
    const Aabb b = set.world_bounds(i);
    if (b.empty()) continue;
    kept.push_back(b);
    ids.push_back(i);
  }
  BvhBuildParams top = opt.bvh;
  top.max_leaf_size = 1;
  top.prim_cost = 1.0f;
  m_top_bvh = Bvh::build(kept, top);
  m_top = std::make_unique<DeviceImage>(encode_top_level(kept, ids, flat, f, m_top_bvh));
  make_tracers(trace_opt);
}

uint32_t InstancedFixedTracer::mesh_spheres(const DeviceImage& img) {
  // The mesh's round records before the first curve segment's local index.
  const ImageHeader& h = img.header();
  uint32_t first_curve = h.num_triangles + h.num_spheres;
  for (uint32_t r = 0; r < h.record_count; ++r)
    if (record_kind(img.record(r)) == RecordKind::kCurve) {
      uint32_t word;
      std::memcpy(&word, img.record(r) + 36, 4);
      first_curve = std::min(first_curve, word & kRecordPrimMask);
    }
  return first_curve >= h.num_triangles ? first_curve - h.num_triangles : 0;
}

void InstancedFixedTracer::make_tracers(const FixedTraceOptions& trace_opt) {
  // A far origin moves to its mesh frame's grid box (inside the frame, so its setup succeeds).
  for (const auto& img : m_bottoms) {
    const QuantFrame q = img->frame();
    Aabb b;
    for (int a = 0; a < 3; ++a) {
      b.lo[a] = float(q.to_world(0, a));
      b.hi[a] = float(q.to_world(q.grid_max(), a));
    }
    m_mesh_bounds.push_back(b);
  }
  FixedTraceOptions to = trace_opt;
  to.bottom = this;
  to.box_unit = nullptr;  // co-simulated units are for flat images (one thread, one image)
  to.tri_unit = nullptr;
  m_top_tracer = std::make_unique<FixedTracer>(*m_top, to);
  for (const Info& in : m_info) {
    FixedTraceOptions bo = trace_opt;
    bo.bottom = nullptr;
    bo.box_unit = nullptr;
    bo.tri_unit = nullptr;
    bo.any_hit = nullptr;
    m_tracers.push_back(std::make_unique<FixedTracer>(*m_bottoms[in.mesh], bo));
  }
  set_any_hit(trace_opt.any_hit);
}

void InstancedFixedTracer::set_any_hit(const AnyHitStage* stage) {
  m_stages.clear();
  for (uint32_t i = 0; i < m_tracers.size(); ++i) {
    if (stage) m_stages.push_back(std::make_unique<Stage>(*stage, *this, i));
    m_tracers[i]->set_any_hit(stage ? m_stages.back().get() : nullptr);
  }
}

namespace {

uint64_t align8(uint64_t x) {
  return (x + 7) / 8 * 8;
}

[[noreturn]] void bad_block(const std::string& why) {
  throw std::invalid_argument("two-level scene image: " + why);
}

}  // namespace

std::vector<uint64_t> InstancedFixedTracer::encode() const {
  TwoLevelHeader h{};
  h.magic = kTwoLevelMagic;
  h.version = kTwoLevelVersion;
  h.xform_bits = uint8_t(m_format.xform_bits);
  h.instance_count = uint32_t(m_xforms.size());
  h.mesh_count = uint32_t(m_bottoms.size());
  h.num_triangles = m_top->header().num_triangles;
  h.num_spheres = m_top->header().num_spheres;
  h.instance_offset = align8(sizeof h);
  h.mesh_offset = h.instance_offset + uint64_t(h.instance_count) * sizeof(InstanceEntry);
  h.top_offset = align8(h.mesh_offset + uint64_t(h.mesh_count) * sizeof(MeshEntry));
  h.top_bytes = m_top->size();
  std::vector<MeshEntry> meshes;
  uint64_t at = align8(h.top_offset + h.top_bytes);
  for (const auto& img : m_bottoms) {
    meshes.push_back(MeshEntry{at, img->size()});
    at = align8(at + img->size());
  }
  h.total_bytes = at;
  std::vector<uint64_t> words(h.total_bytes / 8, 0);
  uint8_t* base = reinterpret_cast<uint8_t*>(words.data());
  std::memcpy(base, &h, sizeof h);
  for (size_t i = 0; i < m_xforms.size(); ++i) {
    InstanceEntry e{};
    std::memcpy(e.m, m_xforms[i].m, sizeof e.m);
    e.mesh = m_info[i].mesh;
    e.tri_base = m_info[i].tri_base;
    e.sphere_base = m_info[i].sphere_base;
    e.curve_base = m_info[i].curve_base;
    std::memcpy(base + h.instance_offset + i * sizeof e, &e, sizeof e);
  }
  if (!meshes.empty()) std::memcpy(base + h.mesh_offset, meshes.data(), meshes.size() * sizeof(MeshEntry));
  std::memcpy(base + h.top_offset, m_top->data(), m_top->size());
  for (size_t m = 0; m < m_bottoms.size(); ++m)
    std::memcpy(base + meshes[m].offset, m_bottoms[m]->data(), m_bottoms[m]->size());
  return words;
}

std::unique_ptr<InstancedFixedTracer> InstancedFixedTracer::from_bytes(const uint8_t* data, size_t bytes,
                                                                       const FixedTraceOptions& trace_opt) {
  TwoLevelHeader h;
  if (bytes < sizeof h || bytes % 8 != 0) bad_block("size below the header or not a multiple of 8");
  std::memcpy(&h, data, sizeof h);
  if (h.magic != kTwoLevelMagic) bad_block("bad magic");
  if (h.version != kTwoLevelVersion) bad_block("unsupported version " + std::to_string(h.version));
  if (h.total_bytes != bytes) bad_block("total_bytes differs from the bound size");
  if (h.reserved != 0) bad_block("reserved bits set");
  if (h.xform_bits < 8 || h.xform_bits > 24) bad_block("xform_bits outside 8..24");
  if (h.instance_count == 0 || h.instance_count > (1u << 20)) bad_block("instance count outside 1..2^20");
  if (h.mesh_count == 0 || h.mesh_count > (1u << 20)) bad_block("mesh count outside 1..2^20");
  auto section = [&](uint64_t off, uint64_t size, const char* what) {
    if (off % 8 != 0 || off < sizeof h || off > bytes || size > bytes - off)
      bad_block(std::string(what) + " outside the block or misaligned");
  };
  section(h.instance_offset, uint64_t(h.instance_count) * sizeof(InstanceEntry), "instance table");
  section(h.mesh_offset, uint64_t(h.mesh_count) * sizeof(MeshEntry), "mesh table");
  section(h.top_offset, h.top_bytes, "top image");
  std::unique_ptr<InstancedFixedTracer> t(new InstancedFixedTracer());
  auto image = [&](uint64_t off, uint64_t size, const std::string& what) {
    try {
      return std::make_unique<DeviceImage>(DeviceImage::from_bytes(data + off, size_t(size)));
    } catch (const std::invalid_argument& e) {
      bad_block(what + ": " + e.what());
    }
  };
  t->m_top = image(h.top_offset, h.top_bytes, "top image");
  const ImageHeader& th = t->m_top->header();
  if (!(th.flags & kImageTopLevel)) bad_block("the top image is not a top level");
  if (th.num_triangles != h.num_triangles || th.num_spheres != h.num_spheres)
    bad_block("the top image's primitive counts differ from the header's");
  for (uint32_t m = 0; m < h.mesh_count; ++m) {
    MeshEntry e;
    std::memcpy(&e, data + h.mesh_offset + uint64_t(m) * sizeof e, sizeof e);
    const std::string what = "mesh " + std::to_string(m);
    section(e.offset, e.bytes, what.c_str());
    t->m_bottoms.push_back(image(e.offset, e.bytes, what));
    const ImageHeader& bh = t->m_bottoms.back()->header();
    if ((bh.flags & kImageTopLevel) || bh.plane_count != 0) bad_block(what + ": a top level, or planes");
  }
  for (const auto& img : t->m_bottoms) t->m_mesh_spheres.push_back(mesh_spheres(*img));
  const uint64_t num_bounded = uint64_t(h.num_triangles) + h.num_spheres;
  for (uint32_t i = 0; i < h.instance_count; ++i) {
    InstanceEntry e;
    std::memcpy(&e, data + h.instance_offset + uint64_t(i) * sizeof e, sizeof e);
    const std::string what = "instance " + std::to_string(i);
    if (e.mesh >= h.mesh_count) bad_block(what + ": mesh out of range");
    const ImageHeader& bh = t->m_bottoms[e.mesh]->header();
    // Its triangles, spheres and curve segments inside the flattened scene's: every hit it reports is numbered in
    // range.
    const uint32_t ns = t->m_mesh_spheres[e.mesh], nc = bh.num_spheres - ns;
    if (uint64_t(e.tri_base) + bh.num_triangles > h.num_triangles || e.sphere_base < h.num_triangles ||
        uint64_t(e.sphere_base) + ns > num_bounded || e.curve_base < h.num_triangles ||
        uint64_t(e.curve_base) + nc > num_bounded)
      bad_block(what + ": its primitives fall outside the flattened scene's");
    StoredXform x;
    std::memcpy(x.m, e.m, sizeof x.m);
    for (const auto& row : x.m)
      for (const float v : row)
        if (!std::isfinite(v) || round_significant(v, h.xform_bits) != v)
          bad_block(what + ": a transform entry not finite or wider than xform_bits");
    t->m_xforms.push_back(x);
    t->m_info.push_back(Info{e.mesh, e.tri_base, e.sphere_base, e.curve_base});
  }
  // The top level's instance records name instances of the table.
  for (uint32_t r = 0; r < th.record_count; ++r) {
    uint32_t word;
    std::memcpy(&word, t->m_top->record(r) + 36, 4);
    if ((word & kRecordPrimMask) >= h.instance_count) bad_block("a top-level record names no instance");
  }
  t->m_format = t->m_top->format();
  t->m_format.xform_bits = h.xform_bits;
  t->make_tracers(trace_opt);
  return t;
}

InstancedFixedTracer::~InstancedFixedTracer() = default;

uint64_t InstancedFixedTracer::transform_bytes() const {
  return uint64_t(m_xforms.size()) * (StoredXform::bytes(m_format.xform_bits) + 8);
}

uint64_t InstancedFixedTracer::bytes() const {
  uint64_t b = m_top->size() + transform_bytes();
  for (const auto& img : m_bottoms) b += img->size();
  return b;
}

uint64_t InstancedFixedTracer::rebased() const {
  return m_rebased->load();
}

bool InstancedFixedTracer::rebase(const Ray& o, uint32_t mesh, Ray& m, float& t0) const {
  const Aabb& b = m_mesh_bounds[mesh];
  double t_in = double(o.tmin), t_out = double(o.tmax);
  for (int a = 0; a < 3; ++a) {
    const double d = double(o.dir[a]);
    if (d == 0.0) {
      if (o.origin[a] < b.lo[a] || o.origin[a] > b.hi[a]) return false;
      continue;
    }
    double ta = (double(b.lo[a]) - double(o.origin[a])) / d, tb = (double(b.hi[a]) - double(o.origin[a])) / d;
    if (ta > tb) std::swap(ta, tb);
    t_in = std::max(t_in, ta);
    t_out = std::min(t_out, tb);
  }
  if (!(t_in <= t_out)) return false;
  ++*m_rebased;
  t0 = float(t_in);
  m = o;
  for (int a = 0; a < 3; ++a) m.origin[a] = float(double(o.origin[a]) + double(t0) * double(o.dir[a]));
  m.tmin = std::max(0.0f, float(double(o.tmin) - double(t0)));
  m.tmax = float(double(o.tmax) - double(t0));
  return true;
}

bool InstancedFixedTracer::trace_instance(uint32_t inst, const Ray& r, float tmax, bool any_hit, Hit& h,
                                          TraversalStats& s, std::vector<TraceEvent>* rec) const {
  if (inst >= m_xforms.size()) return false;  // cannot come from an image this tracer encoded
  return trace_instance_as(inst, m_xforms[inst], r, tmax, any_hit, h, s, rec);
}

bool InstancedFixedTracer::trace_instance_as(uint32_t inst, const StoredXform& x, const Ray& r, float tmax,
                                             bool any_hit, Hit& h, TraversalStats& s,
                                             std::vector<TraceEvent>* rec) const {
  Ray o = x.apply(r);
  o.tmax = tmax;
  const FixedTracer& tracer = *m_tracers[inst];
  const uint32_t mesh = m_info[inst].mesh;
  // The bottom level's events between kEnter and kLeave; a ray its setup rejects records none.
  auto trace = [&](const Ray& ray, TraversalStats& st) {
    if (!rec) return tracer.trace(ray, any_hit, st);
    rec->push_back(TraceEvent{TraceEvent::kEnter, 0, 0, 0, mesh});
    const Hit hit = tracer.trace_recorded(ray, any_hit, st, *rec);
    rec->push_back(TraceEvent{TraceEvent::kLeave, 0, 0, 0, mesh});
    return hit;
  };
  TraversalStats inner;
  h = trace(o, inner);
  const bool far = inner.invalid_by_reason[size_t(RayStatus::kOutOfFrame)] > 0;
  s.add_work(inner);
  if (!far) {
    if (h.hit()) h.prim = global_prim(inst, h.prim);
    return h.hit();
  }
  // The origin is beyond the mesh frame's guard range: start the ray where it enters the mesh's bounds.
  Ray m;
  float t0;
  if (!rebase(o, mesh, m, t0)) return false;
  TraversalStats again;
  h = trace(m, again);
  s.add_work(again);
  if (!h.hit()) return false;
  h.t = float(double(t0) + double(h.t));
  h.prim = global_prim(inst, h.prim);
  return true;
}

void InstancedFixedTracer::trace_instance_all(uint32_t inst, const Ray& r, HitList& all, TraversalStats& s,
                                              std::vector<TraceEvent>* rec) const {
  if (inst >= m_xforms.size()) return;  // cannot come from an image this tracer encoded
  const Ray o = m_xforms[inst].apply(r);
  const FixedTracer& tracer = *m_tracers[inst];
  const uint32_t mesh = m_info[inst].mesh;
  // The bottom level's hits, renumbered into the flattened scene and (a rebased ray's) moved back by t0.
  auto trace = [&](const Ray& ray, float t0) {
    const uint64_t from = all.count;
    TraversalStats st;
    if (rec) rec->push_back(TraceEvent{TraceEvent::kEnter, 0, 0, 0, mesh});
    tracer.trace_all(ray, all, st, rec);
    if (rec) rec->push_back(TraceEvent{TraceEvent::kLeave, 0, 0, 0, mesh});
    s.add_work(st);
    for (uint64_t j = from; j < all.kept(); ++j) {
      all.out[j].prim = global_prim(inst, all.out[j].prim);
      if (t0 != 0.0f) all.out[j].t = float(double(t0) + double(all.out[j].t));
    }
    return st.invalid_by_reason[size_t(RayStatus::kOutOfFrame)] > 0;
  };
  if (!trace(o, 0.0f)) return;
  Ray m;
  float t0;
  if (rebase(o, mesh, m, t0)) trace(m, t0);
}

}  // namespace rtu::hw
