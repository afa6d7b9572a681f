#include "hwmodel/numeric/fixed.h"

namespace rtu::hw {

uint64_t& saturation_counter() {
  thread_local uint64_t count = 0;
  return count;
}

}  // namespace rtu::hw
