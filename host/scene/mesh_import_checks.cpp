// The headers of PLY, OFF and glTF files, checked before Assimp reads them: counts that the file or the memory
// limit cannot hold are refused, named (Assimp allocates by them before reading a byte of data), and PLY headers
// Assimp would loop on are refused (docs/guide/hardening.md).
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "host/io/error.h"
#include "host/io/json_io.h"
#include "host/io/limits.h"
#include "host/scene/mesh_import_internal.h"

namespace rtu::host::mesh_detail {
namespace {

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

}  // namespace

// PLY headers are checked here before Assimp sees them: Assimp 5.2's PLY parser loops for ever on a header line
// with an unknown keyword (found by tests/fuzz/fuzz_mesh_import.cpp: "prortyep float x"). The grammar: "ply", then
// lines of format / comment / obj_info / element NAME COUNT / property TYPE NAME / property list TYPE TYPE NAME,
// then end_header; at most 64 KiB of header. The elements' counts are held to the bytes after the header (each
// element takes at least a byte per binary scalar, two per ASCII value) and to the memory limit: Assimp allocates
// by a count before reading a byte of data, so a count past either is refused, named, not left to
// std::bad_alloc.
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

// OFF: "[ST][C][N][4][n]OFF", with nOFF a dimension, then the vertex, face and edge counts (the keyword is
// optional and the counts may share its line), as Assimp reads them. Assimp allocates by the counts before reading
// the data: counts the file cannot hold (a vertex takes at least two bytes per coordinate, a face two) or the
// memory limit cannot are refused, named.
void check_off_header(const std::string& path) {
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
void check_gltf_accessors(const std::string& path) {
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

}  // namespace rtu::host::mesh_detail
