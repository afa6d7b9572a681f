#include "hwmodel/scene/motion.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace rtu::hw {

Geometry MotionGeometry::at(float time) const {
  Geometry g;
  g.triangles.reserve(triangles.size());
  for (const MotionTriangle& t : triangles) g.triangles.push_back(t.at(time));
  for (const MotionSphere& s : spheres) g.spheres.push_back(s.at(time));
  for (const MotionCurve& c : curves) g.curves.push_back(c.at(time));
  return g;
}

void MotionGeometry::validate() const {
  const auto bad = [](const Vec3& v) {
    for (int a = 0; a < 3; ++a)
      if (!(std::fabs(v[a]) <= kMaxCoordinate)) return true;  // also NaN
    return false;
  };
  for (size_t i = 0; i < triangles.size(); ++i)
    for (const Triangle& t : triangles[i].key)
      if (bad(t.v0) || bad(t.v1) || bad(t.v2))
        throw std::invalid_argument("moving triangle " + std::to_string(i) +
                                    ": a key-frame vertex is not finite or beyond 2^62");
  for (size_t i = 0; i < spheres.size(); ++i)
    for (int k = 0; k < 2; ++k)
      if (bad(spheres[i].center[k]) || !(spheres[i].radius[k] > 0.0f && spheres[i].radius[k] <= kMaxCoordinate))
        throw std::invalid_argument(
            "moving sphere " + std::to_string(i) +
            ": a key-frame center is not finite or beyond 2^62, or a radius not in (0, 2^62]");
  for (size_t i = 0; i < curves.size(); ++i) {
    for (int k = 0; k < 2; ++k)
      if (const std::string why = check_curve_segment(curves[i].key[k]); !why.empty())
        throw std::invalid_argument("moving curve segment " + std::to_string(i) + ": key frame " +
                                    std::to_string(k) + ": " + why);
    if (curves[i].key[0].flags != curves[i].key[1].flags)
      throw std::invalid_argument("moving curve segment " + std::to_string(i) + ": key frames of different flags");
  }
}

namespace {

// Fills the key-frame boxes of every child slot below node `node` of tree t, bottom up; returns the node's own
// boxes at both key frames. key(p, k): item p's box at key frame k.
template <int N, class Key>
void key_boxes(const WideBvh<N>& t, const Key& key, uint32_t node, MotionBvh& out, Aabb own[2]) {
  for (int s = 0; s < N; ++s) {
    const uint32_t ref = t.nodes[node].child[s];
    const size_t slot = size_t(node) * N + size_t(s);
    out.child[slot] = ref;
    if (ref == kEmptyChild) continue;
    Aabb box[2];
    if (is_leaf(ref)) {
      for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i)
        for (int k = 0; k < 2; ++k) box[k].extend(key(t.prim_ids[i], k));
    } else {
      key_boxes(t, key, ref, out, box);
    }
    for (int k = 0; k < 2; ++k) {
      out.key_box[k][slot] = box[k];
      own[k].extend(box[k]);
    }
  }
}

// The tree over the swept boxes, each slot's boxes at both key frames from key(p, k).
template <class Key>
MotionBvh build_over(const std::vector<Aabb>& swept, const Key& key, const BvhBuildParams& params) {
  const Bvh topology = Bvh::build(swept, params);
  MotionBvh m;
  topology.visit([&](const auto& t) {
    constexpr int N = std::decay_t<decltype(t)>::kWidth;
    m.width = N;
    m.root_ref = t.root_ref;
    m.prim_ids = t.prim_ids;
    m.child.assign(t.nodes.size() * N, kEmptyChild);
    for (auto& k : m.key_box) k.assign(t.nodes.size() * N, Aabb{});
    if (!is_leaf(t.root_ref)) {
      key_boxes(t, key, 0, m, m.key_bounds);
    } else {
      for (uint32_t i = 0; i < leaf_count(t.root_ref); ++i)
        for (int k = 0; k < 2; ++k) m.key_bounds[k].extend(key(m.prim_ids[i], k));
    }
  });
  return m;
}

// Rounds a double to a float no greater (down) or no smaller (up) than it.
float round_out(double x, bool up) {
  float f = float(x);
  if (up ? double(f) < x : double(f) > x) f = std::nextafter(f, up ? INFINITY : -INFINITY);
  return f;
}

}  // namespace

void MotionBvh::box_at(size_t slot, float time, float lo[3], float hi[3]) const {
  const double w = time, r = 1.0 - w;
  const Aabb& b0 = key_box[0][slot];
  const Aabb& b1 = key_box[1][slot];
  for (int a = 0; a < 3; ++a) {
    lo[a] = round_out(r * b0.lo[a] + w * b1.lo[a], false);
    hi[a] = round_out(r * b0.hi[a] + w * b1.hi[a], true);
  }
}

MotionBvh MotionBvh::build(const MotionGeometry& g, const BvhBuildParams& params) {
  if (g.num_prims() == 0) throw std::invalid_argument("a moving scene needs at least one primitive");
  g.validate();
  std::vector<Aabb> swept;
  swept.reserve(g.num_prims());
  for (const MotionTriangle& t : g.triangles) swept.push_back(t.swept_bounds());
  for (const MotionSphere& s : g.spheres) swept.push_back(s.swept_bounds());
  for (const MotionCurve& c : g.curves) swept.push_back(c.swept_bounds());
  return build_over(
      swept, [&](uint32_t p, int k) { return g.key_bounds(p, k); }, params);
}

MotionBvh MotionBvh::build(const std::vector<Aabb>& key0, const std::vector<Aabb>& key1,
                           const BvhBuildParams& params) {
  if (key0.empty()) throw std::invalid_argument("a moving scene needs at least one item");
  if (key0.size() != key1.size())
    throw std::invalid_argument("moving items: " + std::to_string(key0.size()) + " boxes at key frame 0, " +
                                std::to_string(key1.size()) + " at key frame 1");
  std::vector<Aabb> swept(key0.size());
  for (size_t i = 0; i < key0.size(); ++i) {
    for (const Aabb* b : {&key0[i], &key1[i]})
      for (int a = 0; a < 3; ++a)
        if (!(std::isfinite(b->lo[a]) && std::isfinite(b->hi[a]) && b->lo[a] <= b->hi[a]))
          throw std::invalid_argument("moving item " + std::to_string(i) +
                                      ": a key-frame box is empty or not finite");
    swept[i] = key0[i];
    swept[i].extend(key1[i]);
  }
  return build_over(
      swept, [&](uint32_t p, int k) { return (k ? key1 : key0)[p]; }, params);
}

}  // namespace rtu::hw
