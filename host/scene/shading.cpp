#include "host/scene/shading.h"

namespace rtu::host {

namespace {

fw::F3 f3(const Vec3& v) {
  return fw::F3{v.x, v.y, v.z};
}

}  // namespace

ShadingRecords shading_records(const Scene& scene) {
  ShadingRecords r;
  const hw::Geometry& g = scene.geometry;
  const uint32_t nprims = g.num_prims();
  r.surfaces.resize(nprims);
  for (uint32_t p = 0; p < nprims; ++p) {
    fw::SurfaceRecord& s = r.surfaces[p];
    s.material = p < scene.prim_material.size() ? scene.prim_material[p] : 0;
    switch (g.kind(p)) {
      case hw::PrimKind::kTriangle: {
        const hw::Triangle& t = g.triangles[p];
        s.kind = uint32_t(fw::SurfaceKind::kTriangle);
        s.a = f3(t.v0);
        s.b = f3(t.v1);
        s.c = f3(t.v2);
        break;
      }
      case hw::PrimKind::kSphere: {
        const hw::Sphere& sp = g.spheres[p - g.triangles.size()];
        s.kind = uint32_t(fw::SurfaceKind::kSphere);
        s.a = f3(sp.center);
        s.b = fw::F3{sp.radius, 0.0f, 0.0f};
        break;
      }
      case hw::PrimKind::kCurve: {
        const hw::CurveSegment& c = g.curve(p);
        s.kind = uint32_t(fw::SurfaceKind::kCurve);
        s.a = f3(c.p0);
        s.b = f3(c.p1);
        s.c = fw::F3{c.r0, c.r1, (c.flags & hw::kCurveCapStart) ? 1.0f : 0.0f};
        break;
      }
      case hw::PrimKind::kPlane: {
        const hw::Plane& pl = g.planes[p - g.num_bounded()];
        s.kind = uint32_t(fw::SurfaceKind::kPlane);
        s.a = f3(pl.normal);
        s.b = fw::F3{pl.offset, 0.0f, 0.0f};
        break;
      }
    }
  }
  for (const Material& m : scene.materials) {
    fw::MaterialRecord mr{};
    mr.kind = uint32_t(m.type == MaterialType::kDiffuse  ? fw::MaterialKind::kDiffuse
                       : m.type == MaterialType::kMirror ? fw::MaterialKind::kMirror
                       : m.type == MaterialType::kGlass  ? fw::MaterialKind::kGlass
                                                         : fw::MaterialKind::kEmissive);
    mr.color = f3(m.color);
    mr.ior = m.ior;
    mr.emission = f3(m.emission);
    mr.texture = m.texture >= 0 ? uint32_t(m.texture) + 1 : 0;
    mr.alpha_mode = uint32_t(m.alpha_mode == AlphaMode::kMask ? fw::AlphaMode::kMask : fw::AlphaMode::kOpaque);
    mr.alpha = m.alpha;
    mr.alpha_cutoff = m.alpha_cutoff;
    r.masked |= m.alpha_mode == AlphaMode::kMask;
    r.materials.push_back(mr);
  }
  if (r.materials.empty()) {
    fw::MaterialRecord mr{};
    mr.color = fw::F3{0.8f, 0.8f, 0.8f};
    mr.ior = 1.5f;
    mr.alpha = 1.0f;
    r.materials.push_back(mr);
  }
  for (const TriangleUv& uv : scene.triangle_uv) {
    fw::UvRecord u{};
    for (int k = 0; k < 3; ++k) {
      u.s[k] = uv.s[k];
      u.t[k] = uv.t[k];
    }
    r.uvs.push_back(u);
  }
  for (const Texture& t : scene.textures) {
    r.textures.push_back(fw::TextureRecord{t.width, t.height, uint64_t(r.texels.size())});
    r.texels.insert(r.texels.end(), t.rgba.begin(), t.rgba.end());
  }
  return r;
}

SceneAnyHit::SceneAnyHit(const Scene& scene) : m_rec(shading_records(scene)) {
  if (!m_rec.masked) return;
  fw::ShadingTables st;
  st.surfaces = m_rec.surfaces.data();
  st.num_prims = uint32_t(m_rec.surfaces.size());
  st.materials = m_rec.materials.data();
  st.num_materials = uint32_t(m_rec.materials.size());
  st.uvs = m_rec.uvs.empty() ? nullptr : m_rec.uvs.data();
  st.num_uvs = uint32_t(m_rec.uvs.size());
  st.textures = m_rec.textures.empty() ? nullptr : m_rec.textures.data();
  st.num_textures = uint32_t(m_rec.textures.size());
  st.mem = m_rec.texels.data();
  st.mem_size = m_rec.texels.size();
  m_tables = st;
  m_stage.emplace(st);
}

}  // namespace rtu::host
