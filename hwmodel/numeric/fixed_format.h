// The number formats of the fixed-point device, all run-time parameters so that sweeps can trade error for
// cost. Units (see quant_frame.h): scene coordinates are integers on the frame's grid; a ray's direction is
// scaled by a power of two so that its largest component lies in [1/2, 1]; "ray units" of t are world t times
// that power of two, so t converts back to world units exactly.
//
// Widths below count magnitude bits; every signed value has one more (sign) bit. validate() checks that every
// intermediate of the datapath fits the 127 magnitude bits of the model's widest integer, and says which limit
// a format breaks: those limits are also the bits real hardware would need for the same exactness.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace rtu::hw {

// How nodes are stored (packed_layout.h): whole-byte structs, bit-packed, compressed-wide (CWBVH-like bytes).
enum class NodeLayout : uint8_t { kStructs = 0, kBitPacked = 1, kCompressedWide = 2 };
// How primitives are stored: 40-byte records, compressed triangle blocks, triangle clusters (cluster_layout.h).
enum class PrimLayout : uint8_t { kRecords = 0, kBlocks = 1, kClusters = 2 };
// The node kind (format/node_kinds.h): quantized axis-aligned boxes, oriented boxes.
enum class NodeKindId : uint8_t { kQuantizedAabb = 0, kOrientedAabb = 1 };

struct FixedFormat {
  std::string name = "custom";  // preset name, or "custom"
  int width = 4;                // BVH node width: 2, 4, 6 or 8 children
  int coord_bits = 24;          // B: vertices and boxes are grid integers in [0, 2^B - 1]; 2..30
  int child_bits = 8;           // k: child box offsets relative to the parent, 1..16 (stored in 8 or 16 bits)
  int guard_bits = 6;           // G: ray origins must lie in (-2^(B+G), 2^(B+G)) grid units (else out of frame)
  int frac_bits = 8;            // F: fraction bits of ray origins, sphere centers and radii, plane offsets
  int dir_bits = 24;            // D: fraction bits of the scaled direction (largest component in [1/2, 1])
  int rcp_bits = 20;            // R: 1/direction, R + 1 significant bits: relative rounding error <= 2^-R
  int t_frac_bits = 16;         // T: fraction bits of t (ray units); the t register is t_bits wide
  int t_bits = 56;              // total magnitude bits of t: saturates at 2^t_bits - 1 raw (beyond every tmax)
  // How the image stores what the fields above describe (packed_layout.h): the bytes the bits cost.
  int node_layout = 0;  // 0 structs (whole-byte fields), 1 bit-packed, 2 compressed-wide (CWBVH-like bytes)
  int node_align = 1;   // packed nodes padded to a multiple of this many bytes (power of two, 1..128)
  int prim_layout =
      0;  // 0 40-byte records, 1 compressed triangle blocks, 2 triangle clusters (1, 2: node_layout 1/2)
  // Two-level scenes (instanced_fixed.h): significant bits of each entry of an instance's world -> object
  // transform, 8..24 (24: the float32 matrices of DXR and Vulkan instances).
  int xform_bits = 24;
  // The node kind (format/node_kinds.h): 0 quantized axis-aligned boxes, 1 oriented boxes (each node's children
  // in the frame of one of `rotations` fixed rotations whose entries have rot_bits fraction bits:
  // format/rotation_table.h).
  int node_kind = 0;
  // Triangle pairs: a leaf's consecutive triangles that share an edge are one request of the unit (a
  // kTrianglePair record and the next; 40-byte records only).
  int tri_pairs = 0;
  int rotations = 104;
  int rot_bits = 12;
  // Curve segments (intersect_fixed.h, swept_sphere_test): magnitude bits of the curve unit's local positions
  // (a ray's offset from a segment, the segment, its radii), each shifted right until it fits.
  int curve_bits = 24;
  // Triangle clusters (prim_layout 2, format/cluster_layout.h): the most triangles one cluster holds, 16..256.
  int cluster_tris = 256;

  // The enumerated fields as their enums (the fields stay ints: their keys read and print them as numbers).
  NodeLayout node_layout_id() const { return NodeLayout(node_layout); }
  PrimLayout prim_layout_id() const { return PrimLayout(prim_layout); }
  NodeKindId node_kind_id() const { return NodeKindId(node_kind); }

  // Throws std::invalid_argument with the rule a format breaks.
  void validate() const;
  // Bits of the widest intermediate of each unit (magnitude bits; see fixed_format.cpp for the derivation).
  int translated_bits() const;     // a = B+G+F+1: a vertex or plane minus a ray origin, F fraction bits
  int box_product_bits() const;    // (plane - origin) * reciprocal
  int edge_function_bits() const;  // d . (A x B) of the triangle test
  int t_shift() const;             // s = D - F + T: a quotient of (F-unit) / (D-unit) values -> t raw
  // An oriented node's test (datapath/oriented_aabb_test.h) works in the rotated frame: origins and planes with
  // F + rot_bits fraction bits, directions with D + rot_bits; a plane minus an origin there.
  int rotated_translated_bits() const;  // B + G + F + rot_bits + 3
  // Empty when swept_sphere_test's intermediates fit 127 bits in this format, else the rule it breaks. Checked
  // where a scene or image holds curve segments, not by validate(): a format too wide for curves still traces
  // triangles and spheres.
  std::string curve_limits() const;
  int offset_bytes() const { return child_bits <= 8 ? 1 : 2; }  // storage of one child offset
  std::string describe() const;                                 // one line: "width 4, B=24 k=8 ..."
};

// Named formats. "default" is what every command uses without format options.
const std::vector<FixedFormat>& format_presets();
// Throws std::invalid_argument listing the known names.
FixedFormat format_preset(const std::string& name);

// One integer field of a format, declared once: validate(), format_field(), format specs, the CLI's per-field
// options, the stats JSON and `rtusim info --formats` read this table.
struct FormatField {
  const char* key;     // "coord_bits" (the CLI option is "--coord-bits")
  const char* symbol;  // "B" (fixed_format.h's letters; "" for width)
  int FixedFormat::*member;
  int lo, hi;  // the field's own range (validate() also checks rules across fields; width: 2, 4, 6 or 8)
  const char* description;
};
// Every integer field, in the order of the struct.
std::span<const FormatField> format_fields();
// The keys of format_fields(), comma-separated (for messages).
std::string format_field_keys();

// The integer field of that key; null for an unknown key.
int* format_field(FixedFormat& f, const std::string& key);
// A format from a spec: a preset name, optionally followed by ":key=value" changes of its fields
// ("default:coord_bits=16:child_bits=6"). The result is validated and named by the spec. Throws
// std::invalid_argument for an unknown preset or key, a value that is not an integer, or a format validate()
// refuses.
FixedFormat format_from_spec(const std::string& spec);

}  // namespace rtu::hw
