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

inline constexpr const char* kRayCsvHeader = "ox,oy,oz,tmin,dx,dy,dz,tmax";
inline constexpr const char* kHitCsvHeader = "t,prim,u,v";

}  // namespace rtu::host
