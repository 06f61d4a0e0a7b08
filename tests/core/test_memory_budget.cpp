// Tests of the memory check that refuses a preparation before allocating it (issue 14, "Bad
// input"): the figures in the message, the exception's fields, what is never refused.
#include <doctest/doctest.h>

#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "tacmap/detail/memory_budget.hpp"

namespace test_memory_budget {

TEST_CASE("check_memory refuses more than is available, naming both figures and the advice") {
  using tacmap::detail::check_memory;
  const std::uint64_t gb = 1000ULL * 1000ULL * 1000ULL;
  try {
    check_memory("descriptor_likelihood", "the per-window descriptors", 17 * gb + gb / 5,
                 "use a coarser map", 2 * gb);
    FAIL("expected insufficient_memory");
  } catch (const tacmap::insufficient_memory& e) {
    CHECK(e.needed_bytes == 17 * gb + gb / 5);
    CHECK(e.available_bytes == 2 * gb);
    const std::string m = e.what();
    CHECK(m.find("descriptor_likelihood") != std::string::npos);
    CHECK(m.find("17.2 GB") != std::string::npos);
    CHECK(m.find("the per-window descriptors") != std::string::npos);
    CHECK(m.find("2 GB is available") != std::string::npos);
    CHECK(m.find("use a coarser map") != std::string::npos);
  }
  // Exactly what is available, less, or an unknown figure: never refused.
  CHECK_NOTHROW(check_memory("m", "x", 2 * gb, "", 2 * gb));
  CHECK_NOTHROW(check_memory("m", "x", 1, "", 2 * gb));
  CHECK_NOTHROW(
      check_memory("m", "x", std::numeric_limits<std::uint64_t>::max(), "", std::nullopt));
}

TEST_CASE("bytes_text and saturating_product") {
  using tacmap::detail::bytes_text;
  CHECK(bytes_text(17) == "17 bytes");
  CHECK(bytes_text(12'300) == "12.3 KB");
  CHECK(bytes_text(512'000'000) == "512 MB");
  CHECK(bytes_text(1'430'000'000) == "1.43 GB");
  using tacmap::detail::saturating_product;
  CHECK(saturating_product(640, 480, 3, 128, 4) == 471'859'200ULL);
  CHECK(saturating_product(std::uint64_t{1} << 40, std::uint64_t{1} << 30) ==
        std::numeric_limits<std::uint64_t>::max());
  CHECK(saturating_product(0, std::numeric_limits<std::uint64_t>::max(), 7) == 0);
}

TEST_CASE("available_memory_bytes reads a positive figure on Linux") {
#ifdef __linux__
  const auto available = tacmap::available_memory_bytes();
  REQUIRE(available.has_value());
  CHECK(*available > 0);
#endif
}

}  // namespace test_memory_budget
