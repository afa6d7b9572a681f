#include "hwmodel/interface/ray.h"

#include "hwmodel/interface/enum_names.h"

namespace rtu::hw {

const char* ray_status_name(RayStatus s) {
  static constexpr const char* names[] = {
      "ok",           "nan_origin",  "inf_origin", "nan_direction", "inf_direction", "zero_direction",
      "bad_interval", "out_of_frame"};
  static_assert(count_of(names) == std::size_t(RayStatus::kOutOfFrame) + 1, "a name for every ray status");
  return enum_name(names, s);
}

}  // namespace rtu::hw
