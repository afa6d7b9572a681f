// Mesh import with Assimp, in the primitive order documented in scene.h.
//
// Only aiProcess_Triangulate and aiProcess_ValidateDataStructure are requested: steps such as
// PreTransformVertices or SortByPType reorder meshes or faces and would break the documented order. The node
// tree is walked here instead, accumulating node transforms (parent * child) into world space.
//
// Hardening (docs/guide/hardening.md): files beyond the memory budget are refused before reading; PLY headers are
// checked first (Assimp 5.2 loops for ever on some); Assimp itself runs in a child process, so a file on which it
// aborts, hangs (RTU_IMPORT_TIMEOUT) or leaks costs an Error, never rtusim. In the child it runs on a stack of
// known size, so that a file nested too deeply for Assimp's recursive parsers is named as such (import_on_stack).
#include <assimp/GltfMaterial.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <poll.h>
#include <pthread.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>
#include <assimp/Importer.hpp>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <new>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "firmware/render_scene.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/image.h"
#include "host/io/json_io.h"
#include "host/io/limits.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/instancing.h"

namespace rtu::host {
namespace {

// One instance of a node in the depth-first walk, with its world transform.
struct NodeVisit {
  const aiNode* node;
  aiMatrix4x4 world;
};

std::string format_vec(const aiVector3D& v) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "(%g, %g, %g)", double(v.x), double(v.y), double(v.z));
  return buf;
}

std::string mesh_label(const aiScene& scene, unsigned mesh_index) {
  std::string label = "mesh " + std::to_string(mesh_index);
  const aiString& name = scene.mMeshes[mesh_index]->mName;
  if (name.length > 0) label += " ('" + std::string(name.C_Str()) + "')";
  return label;
}

// Calls visit(mesh_index, world) for every mesh instance: a node's meshes in order, then its children in order.
// An explicit stack, so deep node trees cannot overflow the call stack.
template <typename Visit>
void walk_nodes(const aiScene& scene, Visit&& visit) {
  if (!scene.mRootNode) return;
  std::vector<NodeVisit> stack{{scene.mRootNode, scene.mRootNode->mTransformation}};
  while (!stack.empty()) {
    NodeVisit cur = stack.back();
    stack.pop_back();
    for (unsigned i = 0; i < cur.node->mNumMeshes; ++i) visit(cur.node->mMeshes[i], cur.world);
    // Children pushed in reverse so the first child is visited first.
    for (unsigned i = cur.node->mNumChildren; i-- > 0;) {
      const aiNode* child = cur.node->mChildren[i];
      stack.push_back({child, cur.world * child->mTransformation});
    }
  }
}

// PLY headers are checked here before Assimp sees them: Assimp 5.2's PLY parser loops for ever on a header line
// with an unknown keyword (found by tests/fuzz/fuzz_mesh_import.cpp: "prortyep float x"). The grammar: "ply", then
// lines of format / comment / obj_info / element NAME COUNT / property TYPE NAME / property list TYPE TYPE NAME,
// then end_header; at most 64 KiB of header. The elements' counts are held to the bytes after the header (each
// element takes at least a byte per binary scalar, two per ASCII value) and to the memory limit: Assimp allocates
// by a count before reading a byte of data, so a count past either is refused, named, not left to
// std::bad_alloc.
std::string import_isolated(const std::string& path);
ImportedModel decode_model(const std::string& blob, const std::string& path, uint64_t held);

constexpr uint64_t kPlyElementBytes = 64, kPlyValueBytes = 64;

// The PLY elements' declared counts against the bytes after the header and the memory limit (check_ply_header).
template <class Element>
void check_ply_counts(const std::string& path, const std::vector<Element>& elements, uint64_t header_bytes) {
  std::error_code ec;
  const uint64_t file_bytes = std::filesystem::file_size(path, ec);
  if (ec) return;  // Assimp reports the unreadable file
  const uint64_t data_bytes = file_bytes > header_bytes ? file_bytes - header_bytes : 0;
  uint64_t need = 0;
  for (const Element& e : elements) {
    const std::string named =
        path + ": PLY header line " + std::to_string(e.line) + ": element " + e.name + " " +
        (e.count == UINT64_MAX ? std::string("of 20 digits or more") : std::to_string(e.count));
    if (e.min_bytes > 0 && e.count > data_bytes / e.min_bytes)
      throw Error(named + ": more than the file's " + std::to_string(data_bytes) +
                  " bytes of data can hold (at least " + std::to_string(e.min_bytes) + " bytes each)");
    // Assimp's PLY reader keeps every element apart, each value in a vector of its own: kPlyElementBytes and
    // kPlyValueBytes (measured), the triangles copied out after. Saturating: the sum is only compared.
    const uint64_t each = kPlyElementBytes + kPlyValueBytes * e.properties;
    need = e.count > (UINT64_MAX - need) / each ? UINT64_MAX : need + e.count * each;
  }
  check_memory(path + ": the PLY header's element counts", need);
}

void check_ply_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  if (!std::getline(in, line)) return;
  // Assimp takes a file for PLY by its extension or by "ply" at its start, whatever follows on that line.
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (line.rfind("ply", 0) != 0 && ext != ".ply") return;
  // Header lines are text. Assimp's PLY reader separates words by ' ' and '\t' only and ends lines at other
  // control characters ('\r', '\f', '\0'), where this check, by std::getline and >>, reads them differently: on
  // "end_header\v0 0 0" Assimp never returned (found by scripts/fuzz_long.sh, regressions/mesh_import/
  // assimp_ply_vertical_tab_after_end_header_hang). So any control character but '\t' (and the '\r' of a CRLF
  // line end) is refused.
  auto check_text = [&](const std::string& text, int n) {
    for (const char c : text) {
      if (static_cast<unsigned char>(c) < 0x20 && c != '\t')
        throw Error(path + ": PLY header line " + std::to_string(n) + ": control character " +
                    std::to_string(int(static_cast<unsigned char>(c))) + " (only spaces and tabs separate words)");
    }
  };
  if (!line.empty() && line.back() == '\r') line.pop_back();
  check_text(line, 1);
  while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
  if (line != "ply") throw Error(path + ": PLY header line 1: expected 'ply'");
  static const std::set<std::string> types = {"char",  "uchar",  "short",   "ushort", "int",   "uint",
                                              "float", "double", "int8",    "uint8",  "int16", "uint16",
                                              "int32", "uint32", "float32", "float64"};
  size_t bytes = line.size() + 1;
  bool ascii = false;
  struct Element {
    std::string name;
    uint64_t count = 0, min_bytes = 0;  // declared count; the fewest bytes one takes in the file
    int line = 0;
    uint64_t properties = 0;
  };
  std::vector<Element> elements;
  static const std::map<std::string, uint64_t> type_bytes = {
      {"char", 1},  {"uchar", 1},   {"int8", 1},   {"uint8", 1},  {"short", 2}, {"ushort", 2},
      {"int16", 2}, {"uint16", 2},  {"int", 4},    {"uint", 4},   {"int32", 4}, {"uint32", 4},
      {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
  for (int n = 2; std::getline(in, line); ++n) {
    bytes += line.size() + 1;
    if (bytes > 65536) throw Error(path + ": PLY header longer than 64 KiB");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    check_text(line, n);
    std::istringstream words(line);
    std::vector<std::string> w;
    for (std::string x; words >> x;) w.push_back(x);
    auto bad = [&](const std::string& why) {
      throw Error(path + ": PLY header line " + std::to_string(n) + ": " + why + " ('" + line + "')");
    };
    if (w.empty()) bad("empty line");
    const std::string& k = w[0];
    if (k == "end_header") return check_ply_counts(path, elements, bytes);
    if (k == "comment" || k == "obj_info") continue;
    if (k == "format") {
      if (w.size() != 3 || (w[1] != "ascii" && w[1] != "binary_little_endian" && w[1] != "binary_big_endian"))
        bad("expected 'format ascii|binary_little_endian|binary_big_endian VERSION'");
      ascii = w[1] == "ascii";
    } else if (k == "element") {
      if (w.size() != 3 || w[2].find_first_not_of("0123456789") != std::string::npos)
        bad("expected 'element NAME COUNT'");
      // Twenty digits may not fit 64 bits: such a count is past any file anyway.
      elements.push_back({w[1], w[2].size() > 19 ? UINT64_MAX : std::stoull(w[2]), 0, n, 0});
    } else if (k == "property") {
      const bool list = w.size() == 5 && w[1] == "list" && types.count(w[2]) && types.count(w[3]);
      if (!list && !(w.size() == 3 && types.count(w[1])))
        bad("expected 'property TYPE NAME' or 'property list TYPE TYPE NAME'");
      // A list takes at least its length (0 entries); a scalar its bytes. ASCII: a digit and a separator.
      if (!elements.empty()) {
        elements.back().min_bytes += ascii ? 2 : type_bytes.at(w[list ? 2 : 1]);
        ++elements.back().properties;
      }
    } else {
      bad("unknown keyword '" + k + "'");
    }
  }
  throw Error(path + ": PLY header without end_header");
}

}  // namespace

// OFF: "[ST][C][N][4][n]OFF", with nOFF a dimension, then the vertex, face and edge counts (the keyword is
// optional and the counts may share its line), as Assimp reads them. Assimp allocates by the counts before reading
// the data: counts the file cannot hold (a vertex takes at least two bytes per coordinate, a face two) or the
// memory limit cannot are refused, named.
static void check_off_header(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".off") return;
  std::ifstream in(path, std::ios::binary);
  std::string head(4096, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(size_t(in.gcount()));
  std::istringstream words(head);
  std::string w;
  if (!(words >> w)) return;
  size_t at = 0;
  for (const char* prefix : {"ST", "C", "N", "4"})
    if (w.compare(at, std::strlen(prefix), prefix) == 0) at += std::strlen(prefix);
  const bool dimension = at < w.size() && w[at] == 'n';
  uint64_t dims = 3, vertices = 0, faces = 0;
  if (w.compare(at + dimension, std::string::npos, "OFF") == 0) {
    if (dimension && !(words >> dims)) return;
  } else {
    words.clear();
    words.seekg(0);  // no keyword: the counts come first
  }
  std::string v, f;
  if (!(words >> v >> f) || v.find_first_not_of("0123456789") != std::string::npos ||
      f.find_first_not_of("0123456789") != std::string::npos)
    return;  // Assimp reports a malformed header
  vertices = v.size() > 19 ? UINT64_MAX : std::stoull(v);
  faces = f.size() > 19 ? UINT64_MAX : std::stoull(f);
  std::error_code ec;
  const uint64_t bytes = std::filesystem::file_size(path, ec);
  if (ec || dims == 0 || dims > 3) return;
  const std::string named = path + ": OFF header: " + v + " vertices and " + f + " faces";
  if (vertices > bytes / (2 * dims) || faces > bytes / 2 || vertices * 2 * dims + faces * 2 > bytes)
    throw Error(named + ": more than the file's " + std::to_string(bytes) + " bytes can hold");
  // Assimp's vertices (12 bytes), faces (16 bytes and their indices) and the triangles copied out after.
  check_memory(named, vertices * 12 + faces * (16 + 12 + sizeof(hw::Triangle)));
}

// glTF 2.0 (.gltf JSON, or the JSON chunk of a .glb): Assimp allocates an accessor's `count` elements before it
// reads them, and for point and line primitives a face with its own index list per vertex or pair (a 627-byte
// file declaring 10^8 line vertices took 6.7 GB in the importer). Every accessor is checked first: one on a
// buffer view must fit in it (offset, stride and count against the view's byteLength, the view against its
// buffer's), and all of them against the memory limit, at their elements' bytes and about 48 bytes of Assimp's
// faces each. Files that are not glTF 2.0, or that do not parse, are left to Assimp and its messages.
static void check_gltf_accessors(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".gltf" && ext != ".glb") return;
  std::ifstream in(path, std::ios::binary);
  std::string text;
  if (ext == ".glb") {  // header (magic, version, length), then the JSON chunk (length, type "JSON", bytes)
    uint32_t head[5] = {};
    if (!in.read(reinterpret_cast<char*>(head), sizeof head) || head[0] != 0x46546C67u || head[4] != 0x4E4F534Au)
      return;
    std::error_code ec;
    const uint64_t file_bytes = std::filesystem::file_size(path, ec);
    if (ec || head[3] > file_bytes) return;
    text.resize(head[3]);
    if (!in.read(text.data(), std::streamsize(text.size()))) return;
  } else {
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  nlohmann::ordered_json j;
  try {
    j = parse_json_limited(text, path);
  } catch (const Error&) {
    return;  // Assimp says what is wrong with it
  }
  if (!j.is_object() || !j.contains("accessors") || !j["accessors"].is_array()) return;  // not glTF 2.0
  auto length = [](const nlohmann::ordered_json& o, const char* key, uint64_t fallback) -> uint64_t {
    if (!o.is_object() || !o.contains(key)) return fallback;
    const auto& v = o[key];
    if (v.is_number_unsigned()) return v.get<uint64_t>();
    if (v.is_number_integer() && v.get<int64_t>() >= 0) return uint64_t(v.get<int64_t>());
    return fallback;
  };
  const auto& buffers = j.contains("buffers") && j["buffers"].is_array() ? j["buffers"] : nlohmann::ordered_json();
  const auto& views =
      j.contains("bufferViews") && j["bufferViews"].is_array() ? j["bufferViews"] : nlohmann::ordered_json();
  const auto component_bytes = [](uint64_t type) -> uint64_t {
    switch (type) {
      case 5120:  // BYTE
      case 5121:  // UNSIGNED_BYTE
        return 1;
      case 5122:  // SHORT
      case 5123:  // UNSIGNED_SHORT
        return 2;
      case 5125:  // UNSIGNED_INT
      case 5126:  // FLOAT
        return 4;
      default:
        return 0;
    }
  };
  const std::map<std::string, uint64_t> components = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4},
                                                      {"MAT2", 4},   {"MAT3", 9}, {"MAT4", 16}};
  constexpr uint64_t kFaceBytes = 48;  // Assimp's face per point or line vertex, with its index list
  uint64_t total = 0;
  const auto& accessors = j["accessors"];
  for (size_t i = 0; i < accessors.size(); ++i) {
    const auto& a = accessors[i];
    const std::string named = path + ": glTF accessor " + std::to_string(i);
    const uint64_t count = length(a, "count", 0), comp = component_bytes(length(a, "componentType", 0));
    const auto type = a.is_object() && a.contains("type") && a["type"].is_string()
                          ? components.find(a["type"].get<std::string>())
                          : components.end();
    if (count == 0 || comp == 0 || type == components.end()) continue;  // malformed: Assimp's message
    const uint64_t elem = comp * type->second;
    if (count > (uint64_t(1) << 40))
      throw Error(named + ": count " + std::to_string(count) + " is beyond any file");
    total = std::min(total + count * (elem + kFaceBytes), uint64_t(1) << 62);  // each term below 2^47
    if (!a.contains("bufferView")) continue;  // zeros (or sparse): nothing to hold the count to but the budget
    const uint64_t v = length(a, "bufferView", UINT64_MAX);
    if (v >= views.size()) continue;
    const auto& view = views[size_t(v)];
    const uint64_t view_bytes = length(view, "byteLength", 0);
    // glTF's strides are at most 252 and offsets below 2^53: clamped so that the sum cannot wrap.
    const uint64_t stride = std::min<uint64_t>(std::max(length(view, "byteStride", 0), elem), 1 << 20);
    const uint64_t need =
        std::min<uint64_t>(length(a, "byteOffset", 0), uint64_t(1) << 53) + stride * (count - 1) + elem;
    if (need > view_bytes)
      throw Error(named + ": " + std::to_string(count) + " elements of " + std::to_string(elem) + " bytes need " +
                  std::to_string(need) + " bytes, more than its buffer view's " + std::to_string(view_bytes));
    const uint64_t b = length(view, "buffer", UINT64_MAX);
    if (b < buffers.size()) {
      const uint64_t buffer_bytes = length(buffers[size_t(b)], "byteLength", 0);
      if (std::min<uint64_t>(length(view, "byteOffset", 0), uint64_t(1) << 53) +
              std::min<uint64_t>(view_bytes, uint64_t(1) << 53) >
          buffer_bytes)
        throw Error(path + ": glTF buffer view " + std::to_string(v) + ": " + std::to_string(view_bytes) +
                    " bytes, more than its buffer's " + std::to_string(buffer_bytes));
    }
  }
  check_memory(path + ": the glTF accessors' elements", total);
}

ImportedModel import_model(const std::string& path, uint64_t held) {
  check_input_file(path);
  std::error_code ec;
  // Assimp holds the file and its parsed meshes at once (several times the file's bytes for text formats), then
  // the triangles are copied out: refuse a file that cannot fit before reading it.
  const uint64_t file_bytes = std::filesystem::file_size(path, ec);
  if (!ec)
    check_memory(path + ": importing a " + std::to_string(file_bytes >> 20) + " MiB mesh file", 8 * file_bytes);

  check_ply_header(path);
  check_off_header(path);
  check_gltf_accessors(path);
  return decode_model(import_isolated(path), path, held);
}

std::vector<hw::Triangle> import_mesh(const std::string& path) {
  return import_model(path).triangles;
}

namespace {

// The child's answer is one blob: the triangles, each triangle's material (the file's material index), texture
// coordinates when a material is textured, the materials' raw properties and their textures (a file path, the
// encoded bytes of an embedded image, or embedded texels). Decoding images and mapping materials happen in the
// parent (decode_model), so the child runs nothing but Assimp.
class BlobWriter {
 public:
  template <typename T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    m_out.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <typename T>
  void put_array(const std::vector<T>& v) {
    put(uint64_t(v.size()));
    m_out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void put_string(const std::string& str) {
    put(uint64_t(str.size()));
    m_out.append(str);
  }
  std::string take() { return std::move(m_out); }

 private:
  std::string m_out;
};

class BlobReader {
 public:
  BlobReader(const std::string& blob, const std::string& path) : m_blob(blob), m_path(path) {}
  template <typename T>
  T get() {
    T v;
    std::memcpy(&v, need(sizeof v), sizeof v);
    return v;
  }
  template <typename T>
  std::vector<T> get_array() {
    const uint64_t n = get<uint64_t>();
    if (n > (m_blob.size() - m_at) / sizeof(T)) truncated();
    std::vector<T> v(n);
    if (n) std::memcpy(v.data(), need(n * sizeof(T)), n * sizeof(T));
    return v;
  }
  std::string get_string() {
    const uint64_t n = get<uint64_t>();
    if (n > m_blob.size() - m_at) truncated();
    return std::string(need(n), n);
  }
  bool done() const { return m_at == m_blob.size(); }
  [[noreturn]] void truncated() const {
    throw Error(m_path + ": the mesh importer (Assimp) sent a truncated answer");
  }

 private:
  const char* need(size_t n) {
    if (n > m_blob.size() - m_at) truncated();
    const char* p = m_blob.data() + m_at;
    m_at += n;
    return p;
  }
  const std::string& m_blob;
  const std::string& m_path;
  size_t m_at = 0;
};

// A material's properties as the file states them (glTF's metallic-roughness model; other formats' diffuse
// colour and opacity stand in for the base colour and alpha).
struct RawMaterial {
  float base[4] = {0.8f, 0.8f, 0.8f, 1.0f};
  float metallic = 0.0f, roughness = 1.0f;
  float emission[3] = {0.0f, 0.0f, 0.0f};
  float transmission = 0.0f, ior = 1.5f, alpha_cutoff = 0.5f;
  uint8_t alpha_mode = 0;  // 0 opaque, 1 mask, 2 blend (glTF alphaMode)
  int32_t texture = -1;    // index into the textures sent, or -1
};

// Where the node tree places a mesh: the object mesh (meshes in the order of their first placement) and the
// node's world transform.
struct Placement {
  uint32_t mesh = 0;
  hw::Affine to_world;
};

enum TextureKind : uint8_t { kTextureFile = 0, kTextureEncoded = 1, kTextureTexels = 2 };

RawMaterial raw_material(const aiMaterial& m) {
  RawMaterial r;
  aiColor4D c;
  if (m.Get(AI_MATKEY_BASE_COLOR, c) == AI_SUCCESS) {
    r.base[0] = c.r, r.base[1] = c.g, r.base[2] = c.b, r.base[3] = c.a;
  } else if (m.Get(AI_MATKEY_COLOR_DIFFUSE, c) == AI_SUCCESS) {
    r.base[0] = c.r, r.base[1] = c.g, r.base[2] = c.b;
    float opacity = 1.0f;
    if (m.Get(AI_MATKEY_OPACITY, opacity) == AI_SUCCESS) r.base[3] = opacity;
  }
  m.Get(AI_MATKEY_METALLIC_FACTOR, r.metallic);
  m.Get(AI_MATKEY_ROUGHNESS_FACTOR, r.roughness);
  aiColor3D e;
  if (m.Get(AI_MATKEY_COLOR_EMISSIVE, e) == AI_SUCCESS) {
    float strength = 1.0f;
    m.Get(AI_MATKEY_EMISSIVE_INTENSITY, strength);
    r.emission[0] = e.r * strength, r.emission[1] = e.g * strength, r.emission[2] = e.b * strength;
  }
  m.Get(AI_MATKEY_TRANSMISSION_FACTOR, r.transmission);
  m.Get(AI_MATKEY_REFRACTI, r.ior);
  aiString mode;
  if (m.Get(AI_MATKEY_GLTF_ALPHAMODE, mode) == AI_SUCCESS) {
    const std::string s = mode.C_Str();
    r.alpha_mode = s == "MASK" ? 1 : s == "BLEND" ? 2 : 0;
  }
  m.Get(AI_MATKEY_GLTF_ALPHACUTOFF, r.alpha_cutoff);
  return r;
}

// Reads the file with Assimp, triangulated and validated. Throws Error when Assimp cannot read it.
const aiScene* read_with_assimp(Assimp::Importer& importer, const std::string& path) {
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_ValidateDataStructure);
  if (!scene && std::string(importer.GetErrorString()).find("contains no faces") != std::string::npos) {
    // Validation rejects a mesh without faces (e.g. an OBJ of bare vertices: a point cloud). Such a mesh just
    // has no triangles; read again without validation, the checks below cover what this code relies on.
    scene = importer.ReadFile(path, aiProcess_Triangulate);
  }
  if (!scene) {
    // Assimp reports what it caught as its error string: a std::bad_alloc as that bare name.
    const std::string why = importer.GetErrorString();
    if (why == std::bad_alloc().what()) throw Error(out_of_memory_message(path + ": importing the mesh"));
    throw Error(path + ": " + why);
  }
  return scene;
}

// An embedded texture into the blob: compressed (mWidth bytes of a PNG, JPEG, ...) as it is, or mWidth x mHeight
// aiTexels (BGRA) as RGBA.
void put_embedded_texture(BlobWriter& textures, const aiTexture& t, const std::string& label) {
  if (t.mHeight == 0) {
    textures.put(kTextureEncoded);
    textures.put_string(label);
    textures.put_string(std::string(reinterpret_cast<const char*>(t.pcData), t.mWidth));
    return;
  }
  textures.put(kTextureTexels);
  textures.put_string(label);
  textures.put(uint32_t(t.mWidth));
  textures.put(uint32_t(t.mHeight));
  std::string rgba(size_t(t.mWidth) * t.mHeight * 4, '\0');
  for (size_t k = 0; k < size_t(t.mWidth) * t.mHeight; ++k) {
    const aiTexel& x = t.pcData[k];
    rgba[4 * k] = char(x.r), rgba[4 * k + 1] = char(x.g), rgba[4 * k + 2] = char(x.b);
    rgba[4 * k + 3] = char(x.a);
  }
  textures.put_string(rgba);
}

// The file's materials and their base-colour textures (each texture once, by its path).
struct ImportedMaterials {
  std::vector<RawMaterial> materials;
  std::vector<std::string> names;
  BlobWriter textures;
  size_t texture_count = 0;
};

ImportedMaterials import_materials(const aiScene& scene, const std::string& path) {
  ImportedMaterials out;
  out.materials.resize(scene.mNumMaterials);
  out.names.resize(scene.mNumMaterials);
  std::map<std::string, int32_t> texture_index;
  for (unsigned i = 0; i < scene.mNumMaterials; ++i) {
    const aiMaterial* m = scene.mMaterials[i];
    if (!m) continue;
    out.materials[i] = raw_material(*m);
    aiString name;
    if (m->Get(AI_MATKEY_NAME, name) == AI_SUCCESS) out.names[i] = name.C_Str();
    aiString tex;
    if (m->GetTexture(aiTextureType_BASE_COLOR, 0, &tex) != AI_SUCCESS &&
        m->GetTexture(aiTextureType_DIFFUSE, 0, &tex) != AI_SUCCESS)
      continue;
    const std::string key = tex.C_Str();
    if (key.empty()) continue;
    auto it = texture_index.find(key);
    if (it == texture_index.end()) {
      it = texture_index.emplace(key, int32_t(texture_index.size())).first;
      if (const aiTexture* t = scene.GetEmbeddedTexture(key.c_str())) {
        put_embedded_texture(out.textures, *t, path + " (embedded texture " + key + ")");
      } else {
        out.textures.put(kTextureFile);
        out.textures.put_string(key);
      }
    }
    out.materials[i].texture = it->second;
  }
  out.texture_count = texture_index.size();
  return out;
}

// Where the node tree places each mesh, and how many triangles that makes.
struct MeshPlacements {
  size_t count = 0;                   // triangles placed (world space, every placement)
  bool textured = false;              // a placed mesh has texture coordinates and a textured material
  std::vector<uint32_t> placed;       // per Assimp mesh: the nodes that place it
  std::vector<Placement> placements;  // every placement, in node order
  std::vector<uint32_t> object_mesh;  // Assimp mesh -> object mesh
  std::vector<uint32_t> object_tris;  // per object mesh
  bool invertible = true;             // every placement's transform can be inverted
};

// First pass: count triangles, so a large mesh is allocated once, and note where each mesh is placed.
MeshPlacements place_meshes(const aiScene& scene, const std::string& path,
                            const std::vector<RawMaterial>& materials) {
  MeshPlacements mp;
  mp.placed.assign(scene.mNumMeshes, 0);
  mp.object_mesh.assign(scene.mNumMeshes, UINT32_MAX);
  walk_nodes(scene, [&](unsigned mesh_index, const aiMatrix4x4& world) {
    if (mesh_index >= scene.mNumMeshes)
      throw Error(path + ": node refers to missing mesh " + std::to_string(mesh_index));
    if (mp.object_mesh[mesh_index] == UINT32_MAX) {
      mp.object_mesh[mesh_index] = uint32_t(mp.object_tris.size());
      uint32_t n = 0;
      for (unsigned f = 0; f < scene.mMeshes[mesh_index]->mNumFaces; ++f)
        n += scene.mMeshes[mesh_index]->mFaces[f].mNumIndices == 3;
      mp.object_tris.push_back(n);
    }
    ++mp.placed[mesh_index];
    Placement pl{mp.object_mesh[mesh_index], {}};
    for (int c = 0; c < 4; ++c) {
      pl.to_world.m[0][c] = world[0][c];
      pl.to_world.m[1][c] = world[1][c];
      pl.to_world.m[2][c] = world[2][c];
    }
    hw::AffineD inverse;
    mp.invertible = mp.invertible && hw::invert(pl.to_world, inverse);
    mp.placements.push_back(pl);
    const aiMesh* mesh = scene.mMeshes[mesh_index];
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) mp.count += mesh->mFaces[f].mNumIndices == 3;
    if (mesh->mMaterialIndex < materials.size() && materials[mesh->mMaterialIndex].texture >= 0 &&
        mesh->HasTextureCoords(0))
      mp.textured = true;
  });
  return mp;
}

// The triangles as sent to the parent, their materials and (textured files) texture coordinates.
struct ImportedTriangles {
  std::vector<hw::Triangle> triangles;
  std::vector<uint32_t> tri_material;
  std::vector<TriangleUv> tri_uv;
};

// One face's vertices (world space when `transform`) and texture coordinates. Throws Error for an index out of
// range or a coordinate that is not finite.
void read_face(const aiScene& scene, const std::string& path, unsigned mesh_index, unsigned f,
               const aiMatrix4x4& world, bool transform, hw::Vec3 (&v)[3], TriangleUv& uv) {
  const aiMesh* mesh = scene.mMeshes[mesh_index];
  const aiFace& face = mesh->mFaces[f];
  const bool uvs = mesh->HasTextureCoords(0);
  for (int k = 0; k < 3; ++k) {
    const unsigned index = face.mIndices[k];
    if (index >= mesh->mNumVertices) {
      throw Error(path + ": " + mesh_label(scene, mesh_index) + ", face " + std::to_string(f) +
                  ": index out of range (" + std::to_string(index) + " >= " + std::to_string(mesh->mNumVertices) +
                  " vertices)");
    }
    aiVector3D p = mesh->mVertices[index];
    if (transform) p = world * p;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      throw Error(path + ": " + mesh_label(scene, mesh_index) + ", face " + std::to_string(f) + ", vertex " +
                  std::to_string(index) + ": NaN/Inf coordinate " + format_vec(p));
    }
    v[k] = hw::Vec3(p.x, p.y, p.z);
    if (uvs) {
      // Assimp's texture coordinates have their origin at the image's bottom left (it flips glTF's); rtu's
      // textures have row 0 on top (scene.h), so t is flipped back.
      uv.s[k] = mesh->mTextureCoords[0][index].x;
      uv.t[k] = 1.0f - mesh->mTextureCoords[0][index].y;
    }
  }
}

// Second pass: the triangles. Two-level: object space, each mesh's triangles once. Otherwise world space; an
// identity node keeps the file's bits (the comparison is exact). Materials and texture coordinates are per
// placed triangle either way.
ImportedTriangles read_triangles(const aiScene& scene, const std::string& path, size_t num_materials,
                                 bool instanced, bool textured, size_t count, size_t flat_count) {
  ImportedTriangles out;
  out.triangles.reserve(count);
  out.tri_material.reserve(flat_count);
  if (textured) out.tri_uv.reserve(flat_count);
  std::vector<bool> sent(scene.mNumMeshes, false);
  const aiMatrix4x4 identity;
  walk_nodes(scene, [&](unsigned mesh_index, const aiMatrix4x4& world) {
    const aiMesh* mesh = scene.mMeshes[mesh_index];
    const bool transform = !instanced && !(world == identity);
    const bool send = !instanced || !sent[mesh_index];
    sent[mesh_index] = true;
    const uint32_t material = mesh->mMaterialIndex < num_materials ? mesh->mMaterialIndex : UINT32_MAX;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      if (mesh->mFaces[f].mNumIndices != 3) continue;  // points and lines
      hw::Vec3 v[3];
      TriangleUv uv;
      read_face(scene, path, mesh_index, f, world, transform, v, uv);
      if (send) out.triangles.push_back({v[0], v[1], v[2]});
      out.tri_material.push_back(material);
      if (textured) out.tri_uv.push_back(uv);
    }
  });
  return out;
}

// The lines (faces of two indices) in world space, in node order; a line joins the one before it in the same mesh
// placement when it starts where that one ends (the same point: importers such as OBJ's give every face its own
// vertices). Throws Error for an index out of range or a
// coordinate that is not finite.
std::vector<ImportedLine> read_lines(const aiScene& scene, const std::string& path, size_t num_materials) {
  std::vector<ImportedLine> out;
  walk_nodes(scene, [&](unsigned mesh_index, const aiMatrix4x4& world) {
    const aiMesh* mesh = scene.mMeshes[mesh_index];
    const uint32_t material = mesh->mMaterialIndex < num_materials ? mesh->mMaterialIndex : UINT32_MAX;
    bool any = false;
    hw::Vec3 last_end(0.0f);
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 2) continue;
      hw::Vec3 p[2];
      for (int k = 0; k < 2; ++k) {
        const unsigned index = face.mIndices[k];
        if (index >= mesh->mNumVertices)
          throw Error(path + ": " + mesh_label(scene, mesh_index) + ", line " + std::to_string(f) +
                      ": index out of range (" + std::to_string(index) +
                      " >= " + std::to_string(mesh->mNumVertices) + " vertices)");
        const aiVector3D v = world * mesh->mVertices[index];
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
          throw Error(path + ": " + mesh_label(scene, mesh_index) + ", line " + std::to_string(f) +
                      ": NaN/Inf coordinate " + format_vec(v));
        p[k] = hw::Vec3(v.x, v.y, v.z);
      }
      out.push_back({p[0], p[1], any && p[0] == last_end ? 1u : 0u, material});
      last_end = p[1];
      any = true;
    }
  });
  return out;
}

// The import proper, in the child process of import_isolated().
std::string import_with_assimp(const std::string& path) {
  Assimp::Importer importer;
  const aiScene* scene = read_with_assimp(importer, path);
  ImportedMaterials mats = import_materials(*scene, path);
  MeshPlacements mp = place_meshes(*scene, path, mats.materials);

  // A mesh placed by more than one node makes the file two-level: its meshes are sent once each in object space
  // with every placement (instances), unless a transform cannot be inverted (a node scaled to zero): then, as
  // for files that place each mesh once, every triangle is sent in world space.
  bool instanced = false;
  for (const uint32_t n : mp.placed) instanced = instanced || n > 1;
  instanced = instanced && mp.invertible;
  const size_t flat_count = mp.count;
  // A node tree may place a mesh many times: the triangles it places, as the flattened scene will hold them, are
  // held to the scene's budget before anything per placed triangle is reserved (here, and where the parent
  // flattens two levels).
  check_scene_size(path, flat_count);
  size_t count = flat_count;
  if (instanced) {
    count = 0;
    for (const uint32_t n : mp.object_tris) count += n;
  } else {
    mp.placements.clear();
    mp.object_tris.clear();
  }
  const ImportedTriangles tris =
      read_triangles(*scene, path, mats.materials.size(), instanced, mp.textured, count, flat_count);

  BlobWriter out;
  out.put_array(tris.triangles);
  out.put_array(tris.tri_material);
  out.put_array(tris.tri_uv);
  out.put_array(mp.object_tris);
  out.put_array(mp.placements);
  out.put_array(read_lines(*scene, path, mats.materials.size()));
  out.put(uint64_t(mats.materials.size()));
  for (size_t i = 0; i < mats.materials.size(); ++i) {
    out.put_string(mats.names[i]);
    out.put(mats.materials[i]);
  }
  out.put(uint64_t(mats.texture_count));
  std::string blob = out.take();
  blob += mats.textures.take();
  importer.FreeScene();
  return blob;
}

bool write_all(int fd, const void* data, size_t n) {
  const auto* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= size_t(w);
  }
  return true;
}

// Assimp's parsers and its scene recurse once per level of nesting: rapidjson under glTF (nested arrays), the
// Collada, DirectX .x and AC3D node readers (nested <node> elements, Frames, kids), aiNode's destructor. Measured
// on Assimp 5.2.5 with an 8 MiB stack (tests/host/test_nesting.cpp builds such files): a Collada node chain of
// 10^4 levels overflows it (at least 800 bytes a level), glTF arrays 2 x 10^5 deep do (40-80 bytes a level; 10^5
// do not). Each format nests in its own syntax, so rather than pre-scan each, the import runs on a stack rtu
// allocates itself: kImportStackBytes, whatever `ulimit -s` says (an unlimited stack would let a deep file eat
// memory until the machine runs out), 8 times the usual default (ample for real models, whose node trees nest
// tens of levels), with kStackGuardBytes without access below it. A fault in the guard is a stack overflow: the
// handler, on its own small stack, sends the child's error message ("nests too deeply") through the pipe and
// exits, so the parent reports it as an Error like any other. Other faults die by the signal as before.
constexpr size_t kImportStackBytes = size_t(64) << 20;
// Larger than any frame Assimp pushes, so an overflowing call lands in the guard, not in a mapping beyond it.
constexpr size_t kStackGuardBytes = size_t(16) << 20;

// What the overflow handler needs, set before the import thread starts (the handler may not allocate).
struct OverflowReport {
  int fd = -1;
  const char* message = nullptr;
  size_t length = 0;
  uintptr_t guard_lo = 0, guard_hi = 0;
};
OverflowReport g_overflow;

extern "C" void on_import_fault(int sig, siginfo_t* info, void*) {
  const auto addr = reinterpret_cast<uintptr_t>(info->si_addr);
  if (addr >= g_overflow.guard_lo && addr < g_overflow.guard_hi) {
    // write() and _exit() are async-signal-safe; write_all only loops over write().
    const uint64_t head[2] = {1, g_overflow.length};
    const bool ok = write_all(g_overflow.fd, head, sizeof head) &&
                    write_all(g_overflow.fd, g_overflow.message, g_overflow.length);
    ::_exit(ok ? 0 : 3);
  }
  // Not an overflow: back to the default action; the faulting instruction runs again and the child dies by `sig`.
  ::signal(sig, SIG_DFL);
}

// The import's outcome, filled by the import thread.
struct ImportJob {
  std::string path;
  std::string blob;   // the answer (import_with_assimp)
  std::string error;  // empty: success
};

void run_import(ImportJob& job) {
  try {
    job.blob = import_with_assimp(job.path);
  } catch (const std::bad_alloc&) {
    job.error = out_of_memory_message(job.path + ": importing the mesh");
  } catch (const std::exception& e) {
    job.error = e.what();
  }
}

extern "C" void* import_thread(void* arg) {
  // The handler runs on this alternate stack: the thread's own stack is the one that overflowed.
  static char alt_stack[1 << 16];
  stack_t ss{}, previous{};
  ss.ss_sp = alt_stack;
  ss.ss_size = sizeof alt_stack;
  const bool replaced = ::sigaltstack(&ss, &previous) == 0;
  if (replaced) {
    struct sigaction sa {};
    sa.sa_sigaction = on_import_fault;
    sa.sa_flags = SA_SIGINFO | SA_ONSTACK;
    sigemptyset(&sa.sa_mask);
    ::sigaction(SIGSEGV, &sa, nullptr);
    ::sigaction(SIGBUS, &sa, nullptr);
  }
  run_import(*static_cast<ImportJob*>(arg));
  // Put back the alternate stack the thread started with: AddressSanitizer gives every thread one and unmaps
  // whatever is installed when the thread ends, which must not be this static buffer (found by the asan tests:
  // every import that returned aborted the child).
  if (replaced) ::sigaltstack(&previous, nullptr);
  return nullptr;
}

// Runs the import (in the child) on a kImportStackBytes stack with an overflow guard, reporting an overflow on
// `fd`. When the stack cannot be had (an address-space limit), the import runs on the calling thread instead.
void import_on_stack(ImportJob& job, int fd) {
  const size_t total = kStackGuardBytes + kImportStackBytes;
  void* base = ::mmap(nullptr, total, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (base == MAP_FAILED) return run_import(job);
  if (::mprotect(base, kStackGuardBytes, PROT_NONE) != 0) {
    ::munmap(base, total);
    return run_import(job);
  }
  static std::string message;  // outlives the thread: the handler reads it
  message = job.path + ": the mesh importer (Assimp) ran out of its " + std::to_string(kImportStackBytes >> 20) +
            " MiB stack: the file nests too deeply (nodes, elements or arrays inside each other) for Assimp's "
            "recursive parsers";
  g_overflow = {fd, message.data(), message.size(), reinterpret_cast<uintptr_t>(base),
                reinterpret_cast<uintptr_t>(base) + kStackGuardBytes};
  pthread_attr_t attr;
  pthread_t thread;
  bool started = ::pthread_attr_init(&attr) == 0;
  started = started &&
            ::pthread_attr_setstack(&attr, static_cast<char*>(base) + kStackGuardBytes, kImportStackBytes) == 0;
  started = started && ::pthread_create(&thread, &attr, import_thread, &job) == 0;
  ::pthread_attr_destroy(&attr);
  if (started) {
    ::pthread_join(thread, nullptr);
  } else {
    run_import(job);
  }
  ::munmap(base, total);
}

// Assimp runs in a child process: a file that makes it crash (its assertions abort, e.g. on a PLY body that
// contradicts its header), hang or leak cannot take rtusim with it. The child sends {status, bytes} and then its
// answer (status 0: the blob of import_with_assimp) or the error message (status 1); the parent waits at most
// RTU_IMPORT_TIMEOUT seconds (default 300). Found necessary by tests/fuzz/fuzz_mesh_import.cpp (README
// "Hardening").
// The parent's side: reads the child's answer from `fd` until the child closes it, or kills the child after
// timeout_s; reaps it into `status`. Returns true on a timeout. Left out of the fuzzers'
// coverage: how the pipe splits the answer into reads, and so how often this loop turns, depends on the two
// processes' timing, and coverage that changed from run to run would make a fixed-seed fuzz run take other paths.
#if defined(__clang__)
__attribute__((no_sanitize("coverage")))
#endif
bool receive_answer(int fd, pid_t pid, int timeout_s, std::vector<char>& data, int& status) {
  // Gathered with libc's realloc and memcpy (no instrumented code runs once per read), handed over once.
  char* got = nullptr;
  size_t got_bytes = 0, got_cap = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  bool timed_out = false;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;
      break;
    }
    pollfd p{fd, POLLIN, 0};
    const int r = ::poll(&p, 1, int(std::min<int64_t>(left.count(), 1000)));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) continue;
    char buf[1 << 16];
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // the child closed its end (exited)
    if (got_bytes + size_t(n) > got_cap) {
      const size_t cap = std::max(got_cap * 2, got_bytes + size_t(n));
      char* more = static_cast<char*>(std::realloc(got, cap));
      if (more == nullptr) break;  // the answer is then short: refused as truncated
      got = more;
      got_cap = cap;
    }
    std::memcpy(got + got_bytes, buf, size_t(n));
    got_bytes += size_t(n);
  }
  if (got != nullptr) data.assign(got, got + got_bytes);
  std::free(got);
  ::close(fd);
  if (timed_out) ::kill(pid, SIGKILL);
  status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return timed_out;
}

std::string import_isolated(const std::string& path) {
  int timeout_s = 300;
  if (const char* t = std::getenv("RTU_IMPORT_TIMEOUT"); t && std::atoi(t) > 0) timeout_s = std::atoi(t);
  int fds[2];
  if (::pipe(fds) != 0) throw Error(path + ": cannot import: pipe: " + std::strerror(errno));
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error(path + ": cannot import: fork: " + std::strerror(errno));
  }
  if (pid == 0) {  // the child: import, send, _exit (no atexit handlers, no leak report of Assimp's leaks)
    ::close(fds[0]);
    // Die by the signal if Assimp crashes: no handler inherited from the parent (a sanitizer's, a fuzzer's) may
    // report the child's crash as the parent's.
    for (int sig : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL}) std::signal(sig, SIG_DFL);
    ImportJob job{path, {}, {}};
    import_on_stack(job, fds[1]);
    const bool failed = !job.error.empty();
    const std::string& answer = failed ? job.error : job.blob;
    const uint64_t head[2] = {failed ? 1u : 0u, answer.size()};
    const bool ok = write_all(fds[1], head, sizeof head) && write_all(fds[1], answer.data(), head[1]);
    ::_exit(ok ? 0 : 3);
  }
  ::close(fds[1]);
  std::vector<char> data;
  int status = 0;
  const bool timed_out = receive_answer(fds[0], pid, timeout_s, data, status);
  if (timed_out)
    throw Error(path + ": the mesh importer (Assimp) did not finish within " + std::to_string(timeout_s) +
                " s (RTU_IMPORT_TIMEOUT); the file is malformed or too large");
  if (WIFSIGNALED(status))
    throw Error(path + ": the mesh importer (Assimp) crashed on this file (signal " +
                std::to_string(WTERMSIG(status)) + ", " + strsignal(WTERMSIG(status)) + "): a malformed file");
  uint64_t head[2] = {0, 0};
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || data.size() < sizeof head)
    throw Error(path + ": the mesh importer (Assimp) failed without a message");
  std::memcpy(head, data.data(), sizeof head);
  if (data.size() != sizeof head + head[1])
    throw Error(path + ": the mesh importer (Assimp) sent a truncated answer");
  if (head[0] != 0) throw Error(std::string(data.data() + sizeof head, head[1]));
  return std::string(data.data() + sizeof head, head[1]);
}

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

ImportedModel decode_model(const std::string& blob, const std::string& path, uint64_t held) {
  BlobReader in(blob, path);
  ImportedModel model;
  model.triangles = in.get_array<hw::Triangle>();
  std::vector<uint32_t> tri_material = in.get_array<uint32_t>();
  model.tri_uv = in.get_array<TriangleUv>();
  const std::vector<uint32_t> object_tris = in.get_array<uint32_t>();
  const std::vector<Placement> placements = in.get_array<Placement>();
  model.lines = in.get_array<ImportedLine>();
  if (!placements.empty()) {
    // Two levels: the object meshes, one instance per placement, and the flattened scene they number.
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
  const uint64_t num_materials = in.get<uint64_t>();
  for (const ImportedLine& l : model.lines)
    if (l.joined > 1 || (l.material != UINT32_MAX && l.material >= num_materials)) in.truncated();
  if (tri_material.size() != model.triangles.size() ||
      !(model.tri_uv.empty() || model.tri_uv.size() == model.triangles.size()) || num_materials > blob.size())
    in.truncated();
  std::vector<std::string> names(num_materials);
  std::vector<RawMaterial> raw(num_materials);
  for (uint64_t i = 0; i < num_materials; ++i) {
    names[i] = in.get_string();
    raw[i] = in.get<RawMaterial>();
  }
  const uint64_t num_textures = in.get<uint64_t>();
  if (num_textures > blob.size()) in.truncated();
  // A texture that cannot be read (missing, not an image, too large) leaves its materials untextured, with a
  // warning naming both files: the geometry imports as before. -1: texture i was not read.
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
      if (kind == kTextureFile) {
        // Paths written on Windows (OBJ's map_Kd .\\tex.jpg) separate with backslashes.
        std::string rel = in.get_string();
        std::replace(rel.begin(), rel.end(), '\\', '/');
        fits(texture_header_bytes((dir / rel).string()));
        t = read_texture((dir / rel).string());
      } else if (kind == kTextureEncoded) {
        const std::string label = in.get_string(), bytes = in.get_string();
        const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
        fits(texture_header_bytes(data, bytes.size()));
        t = read_texture_memory(data, bytes.size(), label);
      } else if (kind == kTextureTexels) {
        t.emplace();
        t->name = in.get_string();
        t->width = in.get<uint32_t>();
        t->height = in.get<uint32_t>();
        const std::string rgba = in.get_string();
        if (rgba.size() != uint64_t(t->width) * t->height * 4) in.truncated();
        t->rgba.assign(rgba.begin(), rgba.end());
        if (t->width < 1 || t->height < 1 || t->width > fw::kMaxTextureSide || t->height > fw::kMaxTextureSide)
          throw Error(t->name + ": texture of " + std::to_string(t->width) + " x " + std::to_string(t->height) +
                      " texels (each side must be in [1, " + std::to_string(fw::kMaxTextureSide) + "])");
      } else {
        in.truncated();
      }
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
  if (!in.done()) in.truncated();

  // The file's own materials, when it has any: Assimp names the material it makes up for formats without
  // materials (PLY, OFF, OBJ without MTL) AI_DEFAULT_MATERIAL_NAME; with only that, the caller's material holds.
  bool own = false;
  for (const uint32_t m : tri_material) own = own || (m < num_materials && names[m] != AI_DEFAULT_MATERIAL_NAME);
  if (!own) {
    model.tri_uv.clear();
    model.textures.clear();
    return model;
  }
  // Only the materials the triangles use, in the order of their first use (a missing index: the default).
  std::vector<int64_t> remap(num_materials + 1, -1);
  model.tri_material.resize(tri_material.size());
  for (size_t i = 0; i < tri_material.size(); ++i) {
    const uint64_t m = tri_material[i] < num_materials ? tri_material[i] : num_materials;
    if (remap[m] < 0) {
      remap[m] = int64_t(model.materials.size());
      Material mat = m < num_materials ? approximate_material(raw[m], names[m]) : Material{.name = "default"};
      if (mat.texture >= 0) mat.texture = size_t(mat.texture) < num_textures ? texture_slot[mat.texture] : -1;
      model.materials.push_back(std::move(mat));
    }
    model.tri_material[i] = uint32_t(remap[m]);
  }
  bool textured = false;
  for (const Material& m : model.materials) textured = textured || m.texture >= 0;
  if (!textured) model.tri_uv.clear();
  return model;
}

}  // namespace

}  // namespace rtu::host
