// tacmap: asking Linux for transparent huge pages on a large block before it is first touched.
//
// Map preparation at camera resolution allocates blocks of several MB to hundreds of MB (dense
// SIFT's fields and shared channels, the window descriptors' stores); malloc maps each one fresh
// (above glibc's mmap threshold) and the kernel zeroes it page by page on first touch. In 4 KB
// pages the faults cost more than the work that fills the memory; in 2 MB pages a few hundred
// times fewer faults (measured in bench/camera_bench.cpp's build rows).
#pragma once

#include <cstddef>
#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace tacmap::detail {

/// Asks Linux for transparent huge pages on the whole 2 MB pages of [data, data + bytes), before
/// they are first touched; elsewhere, or for a smaller block, does nothing. Why: a field at
/// camera resolution is large (37 MB of descriptors at 640 x 480) and malloc maps it fresh on
/// every call (above glibc's 32 MB mmap threshold cap); faulting it in 4 KB pages took twice as
/// long as computing it (measured: 10,000 faults, 31 ms of system time per call, loaded
/// machine; with huge pages 18 faults). Only a hint: the kernel may still use small pages, and
/// with the system's THP mode `never` nothing changes.
inline void advise_huge_pages(void* data, std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t huge = std::uintptr_t{1} << 21U;
  const auto start = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t begin = (start + huge - 1) & ~(huge - 1);
  const std::uintptr_t end = (start + bytes) & ~(huge - 1);
  if (end > begin) {
    static_cast<void>(::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE));
  }
#else
  static_cast<void>(data);
  static_cast<void>(bytes);
#endif
}

}  // namespace tacmap::detail
