// A second translation unit that includes io/image_file.hpp: with stb compiled privately into
// each one (STB_IMAGE_STATIC), the test program must link, and both copies must decode alike.
#include <cstdint>
#include <span>
#include <string_view>

#include "tacmap/io/image_file.hpp"

tacmap::image<float> load_image_in_second_translation_unit(std::span<const std::uint8_t> bytes,
                                                           std::string_view name);

tacmap::image<float> load_image_in_second_translation_unit(std::span<const std::uint8_t> bytes,
                                                           std::string_view name) {
  return tacmap::load_image(bytes, name);
}
