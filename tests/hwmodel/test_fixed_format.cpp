// The fixed-point formats (fixed_format.h): every preset validates (and keeps the edge function and box products
// within 126 bits), and bad widths are rejected with the rule they break.
#include <catch2/catch.hpp>

#include <stdexcept>

#include "fixed_checks.h"
#include "hwmodel/numeric/fixed_format.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

TEST_CASE("fixed formats: every preset validates, bad widths are rejected with their rule", "[fixed][format]") {
  REQUIRE_FALSE(format_presets().empty());
  for (const FixedFormat& f : format_presets()) {
    INFO(f.describe());
    CHECK_NOTHROW(f.validate());
    CHECK(format_preset(f.name).describe() == f.describe());
    CHECK(f.edge_function_bits() <= 126);
    CHECK(f.box_product_bits() <= 126);
  }
  CHECK_NOTHROW(coarse_format().validate());
  CHECK_NOTHROW(fine_position_format().validate());

  auto rejects = [](const FixedFormat& f, const char* rule) {
    INFO(f.describe() << " should break: " << rule);
    CHECK_THROWS_AS(f.validate(), std::invalid_argument);
    CHECK_THROWS_WITH(f.validate(), Catch::Contains(rule));
  };
  FixedFormat f;
  f.coord_bits = 31;  // vertices and node origins are stored as int32
  rejects(f, "coord_bits");
  for (int w : {2, 4, 6, 8}) {
    f = FixedFormat{};
    f.width = w;
    CHECK_NOTHROW(f.validate());
  }
  for (int w : {0, 1, 3, 5, 7, 16}) {
    f = FixedFormat{};
    f.width = w;
    rejects(f, "width must be 2, 4, 6 or 8");
  }
  // B = 30, G = 16, F = 14: translated values need a = 61 bits, the edge function 2a + D + 3 = 149 > 126. With the
  // default t bits this combination also breaks the t-range rule (t_bits >= B + G + T + 3), which validate()
  // checks first; T = 8 and t_bits = 62 leave the edge function as the only rule broken.
  f = FixedFormat{};
  f.coord_bits = 30;
  f.guard_bits = 16;
  f.frac_bits = 14;
  CHECK_THROWS_AS(f.validate(), std::invalid_argument);
  f.t_frac_bits = 8;
  f.t_bits = 62;
  CHECK(f.edge_function_bits() > 126);
  rejects(f, "edge function");
  f = FixedFormat{};
  f.dir_bits = 30;
  f.rcp_bits = 33;  // the reciprocal would need 64 magnitude bits
  rejects(f, "dir_bits + rcp_bits");
  CHECK_THROWS_AS(format_preset("nope"), std::invalid_argument);
}
