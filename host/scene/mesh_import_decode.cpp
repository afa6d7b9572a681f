// The parent's side of the import: the child's blob (mesh_import_internal.h) into an ImportedModel. Decoding
// images and mapping the file's materials onto the renderer's happen here, so the child runs nothing but Assimp.
#include <assimp/material.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "firmware/render_scene.h"
#include "host/io/error.h"
#include "host/io/image.h"
#include "host/io/limits.h"
#include "host/scene/mesh_import_internal.h"
#include "hwmodel/datapath/instancing.h"

namespace rtu::host::mesh_detail {
namespace {

// The renderer has four materials (diffuse, mirror, glass, emissive); a file's metallic-roughness material is
// approximated by the nearest: emissive where it emits, glass where it transmits (KHR_materials_transmission at
// least one half), a tinted mirror where it is metallic and smooth (metallic >= 0.5, roughness <= 0.25), diffuse
// with the base colour otherwise (rough metals included). glTF's BLEND, which needs order-dependent blending, is
// alpha-tested at its cutoff like MASK.
Material approximate_material(const RawMaterial& r, const std::string& name) {
  Material m;
  m.name = name;
  m.color = Vec3(r.base[0], r.base[1], r.base[2]);
  const Vec3 e(r.emission[0], r.emission[1], r.emission[2]);
  if (std::max({e.x, e.y, e.z}) > 0.0f) {
    m.type = MaterialType::kEmissive;
    m.emission = e;
  } else if (r.transmission >= 0.5f) {
    m.type = MaterialType::kGlass;
    m.ior = r.ior >= 1.0f && r.ior <= 4.0f ? r.ior : 1.5f;
  } else if (r.metallic >= 0.5f && r.roughness <= 0.25f) {
    m.type = MaterialType::kMirror;
  }
  m.texture = r.texture;  // index into the file's textures (decode_model maps it to those read)
  m.alpha = std::clamp(r.base[3], 0.0f, 1.0f);
  if (r.alpha_mode != 0) {
    m.alpha_mode = AlphaMode::kMask;
    m.alpha_cutoff = std::clamp(r.alpha_cutoff, 0.0f, 1.0f);
  }
  return m;
}

// Two levels: the object meshes, one instance per placement, and the flattened scene they number.
void place_instances(ImportedModel& model, const std::vector<uint32_t>& object_tris,
                     const std::vector<Placement>& placements, const BlobReader& in, const std::string& path) {
  hw::InstanceSet& set = model.instances;
  size_t at = 0;
  for (const uint32_t n : object_tris) {
    if (n > model.triangles.size() - at) in.truncated();
    hw::Geometry g;
    g.triangles.assign(model.triangles.begin() + ptrdiff_t(at), model.triangles.begin() + ptrdiff_t(at + n));
    set.meshes.push_back(std::move(g));
    at += n;
  }
  if (at != model.triangles.size()) in.truncated();
  for (const Placement& pl : placements) {
    if (pl.mesh >= set.meshes.size()) in.truncated();
    set.instances.push_back(hw::Instance{pl.mesh, pl.to_world, 0, 0});
  }
  set.finish();
  try {
    set.validate();
  } catch (const std::invalid_argument& e) {
    throw Error(path + ": its node tree: " + e.what());
  }
  model.triangles = set.flatten({}).triangles;
}

// The file's materials as the child sent them: each one's name and raw properties.
struct FileMaterials {
  std::vector<std::string> names;
  std::vector<RawMaterial> raw;
};

// Reads the materials, first holding what was read before them (lines, per-triangle materials and texture
// coordinates) to their count: a mismatch is a truncated answer.
FileMaterials read_materials(BlobReader& in, const ImportedModel& model, size_t tri_materials, size_t blob_bytes) {
  const uint64_t num_materials = in.get<uint64_t>();
  for (const ImportedLine& l : model.lines)
    if (l.joined > 1 || (l.material != UINT32_MAX && l.material >= num_materials)) in.truncated();
  if (tri_materials != model.triangles.size() ||
      !(model.tri_uv.empty() || model.tri_uv.size() == model.triangles.size()) || num_materials > blob_bytes)
    in.truncated();
  FileMaterials out;
  out.names.resize(num_materials);
  out.raw.resize(num_materials);
  for (uint64_t i = 0; i < num_materials; ++i) {
    out.names[i] = in.get_string();
    out.raw[i] = in.get<RawMaterial>();
  }
  return out;
}

// One texture as the child sent it (`kind`): a file beside the mesh (in `dir`), an embedded image's encoded bytes
// or embedded texels. fits(bytes) holds the size its header declares to the budget before it is decoded. Throws
// Error when it cannot be read.
template <typename Fits>
std::optional<Texture> read_texture_entry(BlobReader& in, uint8_t kind, const std::filesystem::path& dir,
                                          Fits&& fits) {
  if (kind == kTextureFile) {
    // Paths written on Windows (OBJ's map_Kd .\\tex.jpg) separate with backslashes.
    std::string rel = in.get_string();
    std::replace(rel.begin(), rel.end(), '\\', '/');
    fits(texture_header_bytes((dir / rel).string()));
    return read_texture((dir / rel).string());
  }
  if (kind == kTextureEncoded) {
    const std::string label = in.get_string(), bytes = in.get_string();
    const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
    fits(texture_header_bytes(data, bytes.size()));
    return read_texture_memory(data, bytes.size(), label);
  }
  if (kind != kTextureTexels) in.truncated();
  Texture t;
  t.name = in.get_string();
  t.width = in.get<uint32_t>();
  t.height = in.get<uint32_t>();
  const std::string rgba = in.get_string();
  if (rgba.size() != uint64_t(t.width) * t.height * 4) in.truncated();
  t.rgba.assign(rgba.begin(), rgba.end());
  if (t.width < 1 || t.height < 1 || t.width > fw::kMaxTextureSide || t.height > fw::kMaxTextureSide)
    throw Error(t.name + ": texture of " + std::to_string(t.width) + " x " + std::to_string(t.height) +
                " texels (each side must be in [1, " + std::to_string(fw::kMaxTextureSide) + "])");
  return t;
}

// Reads the textures into model.textures and returns, per texture of the file, its slot there (-1: not read). A
// texture that cannot be read (missing, not an image, too large) leaves its materials untextured, with a warning
// naming both files: the geometry imports as before.
std::vector<int> read_textures(BlobReader& in, const std::string& path, uint64_t held, size_t blob_bytes,
                               ImportedModel& model) {
  const uint64_t num_textures = in.get<uint64_t>();
  if (num_textures > blob_bytes) in.truncated();
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  std::vector<int> texture_slot(num_textures, -1);
  // Each texture is held to the budget when decoded; their sum here, from the size each header declares, before
  // decoding it: the texels the caller holds (`held`) and those read so far, and this texture's twice while it
  // decodes.
  const std::string beside =
      held > 0 ? " beside the scene's " + std::to_string((held + (1 << 20) - 1) >> 20) + " MiB of textures" : "";
  auto fits = [&](uint64_t next) {
    check_memory(path + ": " + std::to_string(model.textures.size() + 1) + " textures so far" + beside,
                 held + 2 * next);
  };
  for (uint64_t i = 0; i < num_textures; ++i) {
    const auto kind = in.get<uint8_t>();
    std::optional<Texture> t;
    try {
      t = read_texture_entry(in, kind, dir, fits);
    } catch (const Error& e) {
      if (std::string(e.what()).find("truncated answer") != std::string::npos) throw;
      std::fprintf(stderr, "rtusim: warning: %s: texture not used: %s\n", path.c_str(), e.what());
      t.reset();
    }
    if (t) {
      held += t->rgba.size();
      texture_slot[i] = int(model.textures.size());
      model.textures.push_back(std::move(*t));
    }
  }
  return texture_slot;
}

// The file's own materials, when it has any: Assimp names the material it makes up for formats without
// materials (PLY, OFF, OBJ without MTL) AI_DEFAULT_MATERIAL_NAME; with only that, the caller's material holds
// (no materials, texture coordinates or textures in the model). Otherwise only the materials the triangles use,
// in the order of their first use (a missing index: the default), their textures mapped to the slots read.
void map_materials(ImportedModel& model, const std::vector<uint32_t>& tri_material, const FileMaterials& file,
                   const std::vector<int>& texture_slot) {
  const uint64_t num_materials = file.names.size(), num_textures = texture_slot.size();
  bool own = false;
  for (const uint32_t m : tri_material)
    own = own || (m < num_materials && file.names[m] != AI_DEFAULT_MATERIAL_NAME);
  if (!own) {
    model.tri_uv.clear();
    model.textures.clear();
    return;
  }
  std::vector<int64_t> remap(num_materials + 1, -1);
  model.tri_material.resize(tri_material.size());
  for (size_t i = 0; i < tri_material.size(); ++i) {
    const uint64_t m = tri_material[i] < num_materials ? tri_material[i] : num_materials;
    if (remap[m] < 0) {
      remap[m] = int64_t(model.materials.size());
      Material mat =
          m < num_materials ? approximate_material(file.raw[m], file.names[m]) : Material{.name = "default"};
      if (mat.texture >= 0) mat.texture = size_t(mat.texture) < num_textures ? texture_slot[mat.texture] : -1;
      model.materials.push_back(std::move(mat));
    }
    model.tri_material[i] = uint32_t(remap[m]);
  }
  bool textured = false;
  for (const Material& m : model.materials) textured = textured || m.texture >= 0;
  if (!textured) model.tri_uv.clear();
}

}  // namespace

ImportedModel decode_model(const std::string& blob, const std::string& path, uint64_t held) {
  BlobReader in(blob, path);
  ImportedModel model;
  model.triangles = in.get_array<hw::Triangle>();
  const std::vector<uint32_t> tri_material = in.get_array<uint32_t>();
  model.tri_uv = in.get_array<TriangleUv>();
  const std::vector<uint32_t> object_tris = in.get_array<uint32_t>();
  const std::vector<Placement> placements = in.get_array<Placement>();
  model.lines = in.get_array<ImportedLine>();
  if (!placements.empty()) place_instances(model, object_tris, placements, in, path);
  const FileMaterials materials = read_materials(in, model, tri_material.size(), blob.size());
  const std::vector<int> texture_slot = read_textures(in, path, held, blob.size(), model);
  if (!in.done()) in.truncated();
  map_materials(model, tri_material, materials, texture_slot);
  return model;
}

}  // namespace rtu::host::mesh_detail
