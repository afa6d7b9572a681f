// The rotations of oriented nodes (format/oriented_aabb.h): a fixed table of R rotations, each a 3x3 integer
// matrix at `bits` fraction bits, that every encoder and unit derives the same way from (R, bits), so an image
// stores only a node's index into it.
//
// Entry 0 is the identity (an oriented node with rotation 0 is an axis-aligned one). Entry i >= 1 turns about one
// of the cube's 13 rotation axes (3 face normals, 4 body diagonals, 6 edge midpoints: axis (i - 1) mod 13) by
// step (i - 1) / 13 + 1 of S + 1 equal parts of that axis' symmetry period (90, 120 and 180 degrees), where
// S = ceil((R - 1) / 13): angles that a box's own symmetry does not repeat. R = 104 gives 8 angles about each
// of 13 axes, less one: the size of RDNA4's table (Chips and Cheese, "RDNA 4's raytracing improvements"). AMD
// stores "a rotation amount and an axis" (US patent 12,079,919); its table itself is not published, so this one
// is ours. Entries are round(R_ij 2^bits) of the double matrix (glibc's sin and cos, correctly rounded in
// practice): exact integers from then on.
#pragma once

#include <cstdint>
#include <vector>

namespace rtu::hw {

struct Rotation {
  int32_t m[3][3];  // row a maps a point p to its rotated coordinate a: sum_j m[a][j] p[j] / 2^bits
};

inline constexpr int kMaxRotations = 1024;
inline constexpr int kMinRotationBits = 4, kMaxRotationBits = 16;

// The table of `count` rotations at `bits` fraction bits (1 <= count <= kMaxRotations, bits in
// [kMinRotationBits, kMaxRotationBits]); built once per (count, bits) and kept (thread-safe).
const std::vector<Rotation>& rotation_table(int count, int bits);

}  // namespace rtu::hw
