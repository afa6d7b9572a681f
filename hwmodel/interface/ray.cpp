#include "hwmodel/interface/ray.h"

namespace rtu::hw {

const char* ray_status_name(RayStatus s) {
  switch (s) {
    case RayStatus::kOk:
      return "ok";
    case RayStatus::kNanOrigin:
      return "nan_origin";
    case RayStatus::kInfOrigin:
      return "inf_origin";
    case RayStatus::kNanDirection:
      return "nan_direction";
    case RayStatus::kInfDirection:
      return "inf_direction";
    case RayStatus::kZeroDirection:
      return "zero_direction";
    case RayStatus::kNanInterval:
      return "bad_interval";
    case RayStatus::kOutOfFrame:
      return "out_of_frame";
  }
  return "unknown";
}

}  // namespace rtu::hw
