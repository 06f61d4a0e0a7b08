// Linked with tacmap::phantom_omni from the parent project's folder: the SDK's header folder,
// its library and TACMAP_HAVE_PHANTOM_OMNI reach a consumer outside tacmap's own folder. (The
// real seam, devices/phantom_omni_hdapi.hpp, is compiled against the installed package by the
// find_package_omni test; here the link is what could break.)
#include <HD/hd.h>

#include <tacmap/config.hpp>

#if !defined(TACMAP_HAVE_PHANTOM_OMNI) || TACMAP_HAVE_PHANTOM_OMNI != 1
#error "tacmap::phantom_omni must define TACMAP_HAVE_PHANTOM_OMNI=1"
#endif

int main() { return hdInitDevice(HD_DEFAULT_DEVICE) == 1 ? 0 : 1; }
