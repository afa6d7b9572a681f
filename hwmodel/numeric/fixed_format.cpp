#include "hwmodel/numeric/fixed_format.h"

#include <algorithm>
#include <charconv>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace rtu::hw {

// Magnitude bounds of the datapath's values (|x| < 2^bits), from the format (B, G, F, D, R, T as in the header):
//   ray origin            |o| < 2^(B+G)           grid units, F fraction bits
//   vertex, box plane     0 <= v < 2^(B+1)         grid units (decoded child boxes may overhang the grid by one
//                                                  quantum of their parent, below 2^(B+1))
//   translated A = v - o  |A| < 2^(B+G+1) = 2^a    with F fraction bits: a = B + G + F + 1 raw bits
//   direction             |d| <= 2^D raw           D fraction bits, largest component >= 2^(D-1)
//   reciprocal            |rcp| <= 2^(D+R) raw     R + D fraction bits (|d raw| >= 1)
//   box product           |A * rcp| < 2^(a + D + R + 1)
//   edge function         |d . (A x B)| < 3 * 2 * 2^(2a) * 2^D < 2^(2a + D + 3)
//   triangle normal N     |N_i| < 2 * 2^(2B)       (from grid-integer edges below 2^B)
//   t quotients           round(num * 2^s / den) computed as q * 2^s + round(rem * 2^s / den), rem < den, so
//                         the widest term is den * 2^s: triangle den = N . d < 3 * 2^(2B+1) * 2^D,
//                         sphere den = d . d <= 3 * 2^(2D) (and 2^(2s) for the half-chord),
//                         plane den = n . d <= 3 * 2^(2D)
int FixedFormat::translated_bits() const {
  return coord_bits + guard_bits + frac_bits + 1;
}
int FixedFormat::box_product_bits() const {
  return translated_bits() + dir_bits + rcp_bits + 1;
}
int FixedFormat::edge_function_bits() const {
  return 2 * translated_bits() + dir_bits + 3;
}
int FixedFormat::t_shift() const {
  return dir_bits - frac_bits + t_frac_bits;
}
// Rotated frame: |o'| = |M o| < 3 2^(B+G+F+rb) and decoded planes |P| <= 2^(B+2) grid units (check of
// oriented_aabb.h), so |P 2^(F+rb) - o'| < 2^(B+G+F+rb+3).
int FixedFormat::rotated_translated_bits() const {
  return coord_bits + guard_bits + frac_bits + rot_bits + 3;
}

void FixedFormat::validate() const {
  auto fail = [&](const std::string& what) {
    throw std::invalid_argument("fixed-point format " + name + ": " + what);
  };
  auto range = [&](const char* key, int v, int lo, int hi) {
    if (v < lo || v > hi)
      fail(std::string(key) + " = " + std::to_string(v) + " outside [" + std::to_string(lo) + ", " +
           std::to_string(hi) + "]");
  };
  if (width != 2 && width != 4 && width != 6 && width != 8) fail("width must be 2, 4, 6 or 8");
  for (const FormatField& f : format_fields())
    if (f.member != &FixedFormat::width) range(f.key, this->*f.member, f.lo, f.hi);
  if ((node_align & (node_align - 1)) != 0) fail("node_align must be a power of two");
  if (node_layout_id() == NodeLayout::kStructs && node_align != 1)
    fail("node_align applies to packed nodes (node_layout 1 or 2); node_layout 0 stores whole structs");
  if (prim_layout_id() == PrimLayout::kBlocks && node_layout_id() == NodeLayout::kStructs)
    fail("prim_layout 1 (triangle blocks) needs packed nodes (node_layout 1 or 2), which address blocks");
  if (prim_layout_id() == PrimLayout::kClusters && node_layout_id() == NodeLayout::kStructs)
    fail("prim_layout 2 (triangle clusters) needs packed nodes (node_layout 1 or 2), which address clusters");
  if (prim_layout_id() != PrimLayout::kClusters && cluster_tris != 256)
    fail("cluster_tris applies to triangle clusters (prim_layout 2)");
  constexpr int kLimit = 126;  // magnitude bits of the 128-bit intermediates, one spare
  auto fits = [&](const char* what, int bits) {
    if (bits > kLimit) fail(std::string(what) + " needs " + std::to_string(bits) + " bits (> 126)");
  };
  const int a = translated_bits(), s = t_shift();
  if (coord_bits + guard_bits + frac_bits > 60) fail("coord_bits + guard_bits + frac_bits must be <= 60");
  if (dir_bits + rcp_bits > 62) fail("dir_bits + rcp_bits must be <= 62 (the reciprocal is 64 bits)");
  if (s < 0) fail("dir_bits - frac_bits + t_frac_bits must be >= 0");
  if (frac_bits + rcp_bits < t_frac_bits || frac_bits + rcp_bits - t_frac_bits > 63)
    fail("frac_bits + rcp_bits - t_frac_bits must be in [0, 63]");
  if (t_bits < coord_bits + guard_bits + t_frac_bits + 3)
    fail("t_bits must be >= coord_bits + guard_bits + t_frac_bits + 3 (t across the whole frame)");
  fits("the box product", box_product_bits());
  fits("the edge function", edge_function_bits());
  fits("the triangle t numerator", 2 * coord_bits + a + 3);
  fits("the triangle t quotient", 2 * coord_bits + dir_bits + 3 + s);
  fits("the sphere/plane t quotient", 2 * dir_bits + 2 + s);
  fits("the sphere half-chord quotient", 2 * dir_bits + 2 + 2 * s);
  fits("the sphere closest-approach vector", t_bits + dir_bits + 1);
  fits("the sphere distance", 2 * (a + 1) + 2);
  fits("the exact box checker (model only)", a + s + dir_bits + 1);
  if (tri_pairs == 1 && prim_layout_id() != PrimLayout::kRecords)
    fail("tri_pairs 1 (triangle pairs) marks 40-byte records (prim_layout 0); triangle blocks hold no pairs");
  if (node_kind_id() == NodeKindId::kOrientedAabb) {
    // The oriented test: the ray rotated per node (o' = M o, d' = M d exactly), then the slab test in that frame
    // with the reciprocals of d' (|d'| < 2^(D+rb+1)) at R + 1 bits.
    if (node_layout_id() == NodeLayout::kCompressedWide && coord_bits > 28)
      fail(
          "node_kind 1 in compressed-wide nodes needs coord_bits <= 28 (the origin's 32-bit field holds "
          "[-2^(B+2), 2^(B+2)] plus 2^(B+2))");
    const int ar = rotated_translated_bits();
    if (dir_bits + rot_bits + rcp_bits > 62)
      fail("dir_bits + rot_bits + rcp_bits must be <= 62 (the rotated direction's reciprocal is 64 bits)");
    if (coord_bits + guard_bits + frac_bits + rot_bits + 2 > 62)
      fail("coord_bits + guard_bits + frac_bits + rot_bits must be <= 60 (the rotated origin is 64 bits)");
    fits("the rotated box product", ar + rcp_bits + 2);
    fits("the rotated exact box checker (model only)", ar + s + dir_bits + rot_bits + 1);
  }
}

std::string FixedFormat::curve_limits() const {
  // swept_sphere_test, with C = curve_bits, positions below 2^C after the local shift z <= B + F + 3 - C, and
  // Dc = max(D, 54 - C) fraction bits of w and sigma (X = Dc - D more than the direction): B^2 - A C <
  // 2^(2(C + Dc) + 17); a root's quotient shifts a remainder below 2^(C + Dc + 9) by t_shift + z + X; the
  // s check multiplies C by d . e and 2^X; the origin's move along the ray is sphere_test's closest approach with
  // one bit more (twice the midpoint).
  const int C = curve_bits, D = dir_bits, s = t_shift(), z = std::max(0, coord_bits + frac_bits + 3 - C);
  const int Dc = std::max(D, 54 - C), X = Dc - D;
  const auto rule = [](const char* what, int bits) {
    return bits > 126 ? std::string(what) + " needs " + std::to_string(bits) + " bits (> 126)" : std::string();
  };
  for (const std::string& why :
       {rule("the curve discriminant", 2 * (C + Dc) + 17), rule("the curve root quotient", C + Dc + 9 + s + z + X),
        rule("the curve closest approach", 2 * D + 3 + s), rule("the curve parameter check", 3 * C + Dc + 12)})
    if (!why.empty()) return "fixed-point format " + name + " cannot hold curve segments: " + why;
  return "";
}

std::string FixedFormat::describe() const {
  std::ostringstream o;
  o << name << ": width " << width << ", coord " << coord_bits << ", child " << child_bits << ", guard "
    << guard_bits << ", frac " << frac_bits << ", dir " << dir_bits << ", rcp " << rcp_bits << ", t " << t_bits
    << "." << t_frac_bits;
  static const char* const kNodes[] = {"structs", "bit-packed", "compressed-wide"};
  if (node_layout_id() != NodeLayout::kStructs || prim_layout_id() != PrimLayout::kRecords) {
    o << ", nodes " << kNodes[node_layout < 0 || node_layout > 2 ? 0 : node_layout];
    if (node_align > 1) o << " (" << node_align << "-byte aligned)";
    const PrimLayout pl = prim_layout_id();
    o << ", "
      << (pl == PrimLayout::kClusters  ? "triangle clusters"
          : pl != PrimLayout::kRecords ? "triangle blocks"
                                       : "40-byte records");
    if (pl == PrimLayout::kClusters && cluster_tris != 256) o << " of " << cluster_tris;
  }
  if (xform_bits != 24) o << ", transforms " << xform_bits << " bits";
  if (node_kind_id() == NodeKindId::kOrientedAabb)
    o << ", oriented boxes (" << rotations << " rotations, " << rot_bits << " bits)";
  if (tri_pairs == 1) o << ", triangle pairs";
  return o.str();
}

namespace {

// Applies "key=value:key=value..." (the text after a preset name and its colon; one change at least) to f;
// `spec` names the whole spec in messages.
void apply_changes(FixedFormat& f, const std::string& changes, const std::string& spec) {
  for (size_t from = 0;;) {
    const size_t colon = changes.find(':', from);
    const std::string kv = changes.substr(from, colon == std::string::npos ? std::string::npos : colon - from);
    const size_t eq = kv.find('=');
    int* field = eq == std::string::npos ? nullptr : format_field(f, kv.substr(0, eq));
    if (!field)
      throw std::invalid_argument("format spec " + spec + ": '" + kv + "' is not key=value with a format key (" +
                                  format_field_keys() + ")");
    const std::string v = kv.substr(eq + 1);
    int value = 0;
    const auto r = std::from_chars(v.data(), v.data() + v.size(), value);
    if (r.ec != std::errc() || r.ptr != v.data() + v.size() || v.empty())
      throw std::invalid_argument("format spec " + spec + ": '" + v + "' is not an integer");
    *field = value;
    if (colon == std::string::npos) break;
    from = colon + 1;
  }
}

}  // namespace

const std::vector<FixedFormat>& format_presets() {
  // Each preset: the header's defaults with these changes.
  static const std::pair<const char*, const char*> kPresets[] = {
      {"default", ""},
      {"wide6", "width=6"},
      {"wide8", "width=8"},
      {"binary", "width=2"},
      {"compact",
       "coord_bits=16:child_bits=6:guard_bits=4:frac_bits=4:dir_bits=16:rcp_bits=16:t_frac_bits=8:t_bits=32"},
      {"precise",
       "coord_bits=28:child_bits=12:guard_bits=4:frac_bits=10:dir_bits=28:rcp_bits=28:t_frac_bits=16:t_bits=60"},
      // 8-wide nodes of byte fields, 80 bytes at 8-bit offsets (after Ylitie et al., HPG 2017), with blocks.
      {"cwbvh", "width=8:node_layout=2:prim_layout=1"},
      // The default's bits, stored bit-packed: nodes and triangle blocks.
      {"packed", "node_layout=1:prim_layout=1"},
      // 6-wide bit-packed nodes padded to 64 bytes, in the spirit of Intel's 64-byte BVH6 node (Intel's Embree
      // and Xe documentation), with 40-byte records as Intel's quad leaves hold full-precision vertices.
      {"xe6", "width=6:node_layout=1:node_align=64"},
      // 8-wide bit-packed oriented nodes (104 rotations, as RDNA4's table) of 12-bit child boxes padded to 128
      // bytes, with triangle blocks, in the spirit of AMD RDNA4's 128-byte BVH8 node with its rotation index and
      // compressed primitive nodes (timing preset rdna4, timing_config.cpp).
      {"rdna4", "width=8:child_bits=12:node_layout=1:node_align=128:prim_layout=1:node_kind=1"},
      // The default's bits, bit-packed nodes over triangle clusters of up to 256 triangles
      // (format/cluster_layout.h), in the spirit of the cluster acceleration structures of NVIDIA's RTX Mega
      // Geometry.
      {"clusters", "node_layout=1:prim_layout=2"},
  };
  static const std::vector<FixedFormat> presets = [] {
    std::vector<FixedFormat> v;
    for (const auto& [name, changes] : kPresets) {
      FixedFormat f;
      if (*changes) apply_changes(f, changes, name);
      f.name = name;
      f.validate();
      v.push_back(f);
    }
    return v;
  }();
  return presets;
}

FixedFormat format_preset(const std::string& name) {
  std::string names;
  for (const FixedFormat& f : format_presets()) {
    if (f.name == name) return f;
    names += (names.empty() ? "" : ", ") + f.name;
  }
  throw std::invalid_argument("unknown format preset '" + name + "' (known: " + names + ")");
}

namespace {

using F = FixedFormat;
constexpr FormatField kFields[] = {
    {"width", "", &F::width, 2, 8, "BVH node width: 2, 4, 6 or 8 children"},
    // Node origins and vertices are stored as int32.
    {"coord_bits", "B", &F::coord_bits, 2, 30, "grid bits of vertices and boxes"},
    {"child_bits", "k", &F::child_bits, 1, 16, "bits of a child box offset relative to its parent"},
    {"guard_bits", "G", &F::guard_bits, 1, 16, "guard bits: ray origins within 2^(B+G) grid units"},
    {"frac_bits", "F", &F::frac_bits, 0, 24, "fraction bits of origins, sphere centers and radii, plane offsets"},
    // Directions and plane normals are stored as int32.
    {"dir_bits", "D", &F::dir_bits, 4, 30, "fraction bits of the scaled direction"},
    {"rcp_bits", "R", &F::rcp_bits, 4, 40, "reciprocal bits: relative rounding error <= 2^-R"},
    {"t_frac_bits", "T", &F::t_frac_bits, 0, 32, "fraction bits of t (ray units)"},
    {"t_bits", "", &F::t_bits, 8, 62, "magnitude bits of the t register"},
    {"node_layout", "", &F::node_layout, 0, 2, "node storage: 0 structs, 1 bit-packed, 2 compressed-wide bytes"},
    {"node_align", "", &F::node_align, 1, 128, "packed node size rounded up to a multiple of this (bytes)"},
    {"prim_layout", "", &F::prim_layout, 0, 2,
     "primitive storage: 0 40-byte records, 1 triangle blocks, 2 triangle clusters"},
    {"xform_bits", "X", &F::xform_bits, 8, 24, "significant bits of an instance transform's entries"},
    {"node_kind", "", &F::node_kind, 0, 1, "node kind: 0 axis-aligned boxes, 1 oriented boxes (rotation table)"},
    {"rotations", "", &F::rotations, 1, 1024, "oriented boxes: rotations in the table a node indexes"},
    {"rot_bits", "", &F::rot_bits, 4, 16, "oriented boxes: fraction bits of the rotation table's entries"},
    {"tri_pairs", "", &F::tri_pairs, 0, 1,
     "triangle pairs: consecutive triangles of a leaf sharing an edge tested as one request (prim_layout 0)"},
    {"curve_bits", "", &F::curve_bits, 8, 31,
     "curve segments: magnitude bits of the curve unit's local positions"},
    {"cluster_tris", "", &F::cluster_tris, 16, 256, "triangle clusters: the most triangles one cluster holds"},
};

}  // namespace

std::span<const FormatField> format_fields() {
  return kFields;
}

std::string format_field_keys() {
  std::string s;
  for (const FormatField& f : kFields) s += (s.empty() ? "" : ", ") + std::string(f.key);
  return s;
}

int* format_field(FixedFormat& f, const std::string& key) {
  for (const FormatField& d : kFields)
    if (key == d.key) return &(f.*d.member);
  return nullptr;
}

FixedFormat format_from_spec(const std::string& spec) {
  const size_t colon = spec.find(':');
  FixedFormat f = format_preset(spec.substr(0, colon));
  if (colon == std::string::npos) return f;  // a preset, validated with the others
  apply_changes(f, spec.substr(colon + 1), spec);
  f.name = spec;
  try {
    f.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("format spec " + spec + ": " + e.what());
  }
  return f;
}

}  // namespace rtu::hw
