// The bundled gecko protocol (data/gecko), loaded once per test program.
#pragma once

#include <filesystem>

#include "tacmap/sim/protocol.hpp"

namespace tacmap_test {

inline const tacmap::touch_protocol& gecko() {
  static const tacmap::touch_protocol p =
      tacmap::load_protocol(std::filesystem::path(TACMAP_DATA_DIR) / "gecko" / "protocol.txt");
  return p;
}

}  // namespace tacmap_test
