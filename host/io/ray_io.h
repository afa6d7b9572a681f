// Ray and hit files (docs/file-formats.md): little-endian binary without header (32-byte rays, 16-byte hits), or
// CSV with a header line when the file name ends in ".csv".
#pragma once

#include <string>
#include <vector>

#include "hwmodel/interface/ray.h"

namespace rtu::host {

bool is_csv_path(const std::string& path);

// Throw Error naming the file and the problem (missing, size not a multiple of the record, bad CSV line).
std::vector<hw::Ray> read_rays(const std::string& path);
std::vector<hw::Hit> read_hits(const std::string& path);
void write_rays(const std::string& path, const std::vector<hw::Ray>& rays);
void write_hits(const std::string& path, const std::vector<hw::Hit>& hits);
// An all-hit trace's lists (docs/file-formats.md, hit list files): ray i's counts[i] intersections, of which the
// first min(count, k) at lists[i * k ...]. Binary: per ray the device's hit list (a 16-byte header, then k hit
// records, misses after the kept ones); CSV (.csv): a row per kept hit, one row for a ray with none.
void write_hit_lists(const std::string& path, uint32_t k, const std::vector<hw::Hit>& lists,
                     const std::vector<uint64_t>& counts);

inline constexpr const char* kRayCsvHeader = "ox,oy,oz,tmin,dx,dy,dz,tmax";
inline constexpr const char* kHitCsvHeader = "t,prim,u,v";
inline constexpr const char* kHitListCsvHeader = "ray,count,kept,overflow,hit,t,prim,u,v";

}  // namespace rtu::host
