// A consumer of tacmap::phantom_omni (the packaging tests' fake OpenHaptics SDK stands in for the
// real one): reads one pose through tacmap's real HDAPI seam and the SDK's library.
#include <cmath>
#include <cstdio>
#include <tacmap/devices/phantom_omni_hdapi.hpp>

#if !defined(TACMAP_HAVE_PHANTOM_OMNI) || TACMAP_HAVE_PHANTOM_OMNI != 1
#error "tacmap::phantom_omni must define TACMAP_HAVE_PHANTOM_OMNI=1"
#endif

int main() {
  tacmap::phantom_omni omni;
  const auto pose = omni.next_pose();
  if (!pose) {
    std::puts("phantom_omni: no pose");
    return 1;
  }
  std::printf("phantom_omni: sensor at (%.1f, %.1f) mm\n", pose->x_mm, pose->y_mm);
  return 0;
}
