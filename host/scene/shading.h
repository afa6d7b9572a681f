// The renderer's shading records of a scene (firmware/render_scene.h): per primitive surfaces, materials,
// texture coordinates and textures. The render job places them in the unit's device memory; the direct devices
// (trace, compare, ...) keep them in host memory and alpha-test through the firmware's own any-hit stage over
// them (fw::AlphaStage), so every device and the renderer ignore the same candidate hits.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "firmware/render_scene.h"
#include "firmware/surface.h"
#include "host/scene/scene.h"

namespace rtu::host {

struct ShadingRecords {
  std::vector<fw::SurfaceRecord> surfaces;  // per primitive
  std::vector<fw::MaterialRecord> materials;
  std::vector<fw::UvRecord> uvs;  // per triangle, or empty
  // Texture records whose `texels` are offsets into `texels` (the render job adds the blob's device address).
  std::vector<fw::TextureRecord> textures;
  std::vector<uint8_t> texels;
  bool masked = false;  // a material is alpha-masked: the any-hit stage is needed
};

ShadingRecords shading_records(const Scene& scene);

// The firmware's any-hit stage over a scene's shading records in host memory, for the direct devices.
class SceneAnyHit {
 public:
  explicit SceneAnyHit(const Scene& scene);
  SceneAnyHit(const SceneAnyHit&) = delete;
  SceneAnyHit& operator=(const SceneAnyHit&) = delete;
  // The stage, or null when no material is alpha-masked (every triangle is opaque).
  const hw::AnyHitStage* stage() const { return m_stage ? &*m_stage : nullptr; }
  const ShadingRecords& records() const { return m_rec; }
  // The tables the stage reads (null when no material is alpha-masked): what micromaps are baked from.
  const fw::ShadingTables* tables() const { return m_stage ? &m_tables : nullptr; }

 private:
  ShadingRecords m_rec;
  fw::ShadingTables m_tables;
  std::optional<fw::AlphaStage> m_stage;
};

}  // namespace rtu::host
