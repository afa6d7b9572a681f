// A scene as the host knows it: the unit's geometry plus what the renderer needs (materials, lights, camera).
//
// Primitive order (the contract of hit files, docs/file-formats.md): triangles first, in this order
//   1. each mesh entry of the scene description, in file order; inside one mesh file, Assimp's node tree
//      depth-first (a node's meshes in order, then its children in order), each mesh's faces in order;
//   2. the two triangles of each area light, in file order;
//   3. the triangles of each instance, in the order the instances expand (scenes/README.md);
// then spheres in file order, then planes in file order. A bare mesh file is a scene with one mesh entry.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "hwmodel/datapath/instancing.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/interface/vec.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::host {

using hw::Vec3;

enum class MaterialType : uint8_t { kDiffuse, kMirror, kGlass, kEmissive };

enum class AlphaMode : uint8_t { kOpaque, kMask };

struct Material {
  std::string name;
  MaterialType type = MaterialType::kDiffuse;
  Vec3 color{0.8f};     // diffuse albedo, mirror/glass tint; unused for emissive
  float ior = 1.5f;     // glass: index of refraction (> 0)
  Vec3 emission{0.0f};  // emissive: radiance
  int texture = -1;     // base colour texture (index into Scene::textures; its colour multiplies `color`), or -1
  // Alpha testing (glTF alphaMode MASK): the surface is there where alpha (this factor times the texture's alpha)
  // reaches alpha_cutoff; elsewhere rays pass through it (the any-hit stage, hwmodel/interface/any_hit.h).
  AlphaMode alpha_mode = AlphaMode::kOpaque;
  float alpha = 1.0f;         // in [0, 1]
  float alpha_cutoff = 0.5f;  // in [0, 1]
};

// A texture: RGBA8 texels, row 0 at the top, colour in sRGB (firmware/render_scene.h, TextureRecord).
struct Texture {
  std::string name;  // where it came from (a file, or the scene file's key)
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;  // width * height * 4
};

// Texture coordinates (s, t) of a triangle's vertices v0, v1, v2.
struct TriangleUv {
  float s[3] = {0, 0, 0}, t[3] = {0, 0, 0};
};

enum class LightType : uint8_t { kPoint, kArea };

struct Light {
  LightType type = LightType::kPoint;
  Vec3 position{0.0f};                // point: position; area: one corner of the parallelogram
  Vec3 edge_u{0.0f};                  // area: first edge from the corner
  Vec3 edge_v{0.0f};                  // area: second edge from the corner
  Vec3 intensity{1.0f};               // point: radiant intensity (W/sr per channel); area: emitted radiance
  uint32_t first_prim = hw::kNoPrim;  // area: index of its first triangle (the second follows)
};

struct Camera {
  Vec3 position{0.0f, 0.0f, 5.0f};
  Vec3 look_at{0.0f};
  Vec3 up{0.0f, 1.0f, 0.0f};
  float fov_y_deg = 45.0f;  // vertical field of view
  int width = 640;          // default image resolution
  int height = 480;
};

struct Scene {
  std::string name;       // what it was loaded from (file path or builtin:NAME)
  hw::Geometry geometry;  // triangles, spheres, planes in the documented order
  std::vector<Material> materials;
  std::vector<uint32_t> prim_material;  // per primitive index: index into materials
  std::vector<Texture> textures;
  std::vector<TriangleUv> triangle_uv;  // per triangle, or empty (no texture coordinates)
  std::vector<Light> lights;
  Camera camera;
  bool has_camera = false;  // false: the camera was framed automatically around the bounds
  // Two levels, when the scene places instances (empty otherwise): `geometry` is then its flattened form
  // (hw::InstanceSet::flatten), which numbers the primitives and which devices without instancing trace.
  hw::InstanceSet instances;
  bool instanced() const { return !instances.instances.empty(); }
};

// Loads a scene from `spec`: a scene description file (.json), any mesh file Assimp reads, or builtin:NAME
// (see builtin_scene_names()). Throws Error with a message naming the input and the problem: missing file,
// unparsable file, unknown key, NaN/Inf coordinates, index out of range, empty scene.
Scene load_scene(const std::string& spec);

// The two loaders behind load_scene (which validates what they return; call load_scene unless you need one).
// A scene description file, schema in scenes/README.md. Relative mesh paths are relative to the file's folder.
Scene load_scene_file(const std::string& path);
// A scene description already parsed (by parse_json_limited, which bounds its depth): `path` names it in messages
// and becomes the scene's name, relative mesh paths are relative to `base_dir`. load_scene_file reads a file into
// it; the Python module passes a dict through it. Not validated (validate_scene).
Scene load_scene_json(const nlohmann::ordered_json& root, const std::string& path, const std::string& base_dir);
// A built-in scene from its spec without the "builtin:" prefix, e.g. "icosphere?subdiv=5&radius=2".
Scene load_builtin_scene(const std::string& spec);

// Imports every triangle of a mesh file in the documented order, transformed to world space by the node tree.
// Faces that are points or lines are dropped; polygons are triangulated. Throws Error on failure.
std::vector<hw::Triangle> import_mesh(const std::string& path);

// A mesh file with its materials and its instancing: the triangles as import_mesh returns them, and when the file
// has materials of its own (not only the one Assimp makes up for formats without), each triangle's material, the
// materials as the renderer approximates them (docs/scenes.md), their base-colour textures and the triangles'
// texture coordinates (when a material is textured). A texture that cannot be read is left out with a warning on
// stderr.
// A line of a mesh file (a face of two indices, as OBJ's `l` gives them), in world space: a strand's segment once
// it has a radius (curves.h, add_lines).
struct ImportedLine {
  hw::Vec3 p0, p1;
  uint32_t joined;    // 1: it starts where the line before it in the same mesh ends (the same point)
  uint32_t material;  // the file's material index, or UINT32_MAX
};
static_assert(sizeof(ImportedLine) == 32);

struct ImportedModel {
  std::vector<hw::Triangle> triangles;
  std::vector<ImportedLine> lines;     // the file's lines (faces of two indices), in node order
  std::vector<uint32_t> tri_material;  // per triangle, into `materials`; empty: the file has no materials
  std::vector<Material> materials;     // `texture` indexes `textures`
  std::vector<Texture> textures;
  std::vector<TriangleUv> tri_uv;  // per triangle, or empty
  // When the node tree places a mesh more than once: its meshes in object space and an instance per placement
  // (each node's transform composed from the root); `triangles` is then their flattened form. Empty otherwise.
  hw::InstanceSet instances;
};
// `held`: the texel bytes of textures the caller already holds (a scene file's, and earlier mesh files'): the
// file's textures are held to the memory budget beside them.
ImportedModel import_model(const std::string& path, uint64_t held = 0);

// Throws Error when a scene of `prims` primitives cannot be traced: more than the unit's primitive index holds
// (hw::kMaxBvhPrims - 1), or more than the memory budget (host/io/limits.h) at 256 bytes per primitive.
void check_scene_size(const std::string& name, uint64_t prims);

// Names accepted by builtin:NAME, each with a one-line description.
std::vector<std::pair<std::string, std::string>> builtin_scene_names();

// Checks a loaded scene: finite coordinates, positive radii, non-zero plane normals, materials in range, at
// least one primitive. Throws Error naming `scene.name` and the first problem.
void validate_scene(const Scene& scene);

// What load_scene does to every scene it loads: validate_scene, then mark_non_opaque. Callers that load through
// load_scene_json or build a Scene themselves call it before tracing.
void finish_scene(Scene& scene);

// Marks the geometry's non-opaque triangles (hw::Geometry::non_opaque, and the instance meshes' for the
// two-level float device): triangles whose material is alpha-masked. load_scene calls it.
void mark_non_opaque(Scene& scene);

// A camera that frames `bounds` from a diagonal direction (used when a scene has none).
Camera frame_camera(const hw::Aabb& bounds);

}  // namespace rtu::host
