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
// boxes at both key frames.
template <int N>
void key_boxes(const WideBvh<N>& t, const MotionGeometry& g, uint32_t node, MotionBvh& out, Aabb own[2]) {
  for (int s = 0; s < N; ++s) {
    const uint32_t ref = t.nodes[node].child[s];
    const size_t slot = size_t(node) * N + size_t(s);
    out.child[slot] = ref;
    if (ref == kEmptyChild) continue;
    Aabb box[2];
    if (is_leaf(ref)) {
      for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i)
        for (int k = 0; k < 2; ++k) box[k].extend(g.key_bounds(t.prim_ids[i], k));
    } else {
      key_boxes(t, g, ref, out, box);
    }
    for (int k = 0; k < 2; ++k) {
      out.key_box[k][slot] = box[k];
      own[k].extend(box[k]);
    }
  }
}

}  // namespace

MotionBvh MotionBvh::build(const MotionGeometry& g, const BvhBuildParams& params) {
  if (g.num_prims() == 0) throw std::invalid_argument("a moving scene needs at least one primitive");
  g.validate();
  std::vector<Aabb> swept;
  swept.reserve(g.num_prims());
  for (const MotionTriangle& t : g.triangles) swept.push_back(t.swept_bounds());
  for (const MotionSphere& s : g.spheres) swept.push_back(s.swept_bounds());
  for (const MotionCurve& c : g.curves) swept.push_back(c.swept_bounds());
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
      key_boxes(t, g, 0, m, m.key_bounds);
    } else {
      for (uint32_t i = 0; i < leaf_count(t.root_ref); ++i)
        for (int k = 0; k < 2; ++k) m.key_bounds[k].extend(g.key_bounds(m.prim_ids[i], k));
    }
  });
  return m;
}

}  // namespace rtu::hw
