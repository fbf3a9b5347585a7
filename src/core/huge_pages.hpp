#pragma once
// An allocator for the large particle arrays that are read at random places (EDMD records,
// DSMC gathers): blocks of 4 MiB and more are aligned to 2 MiB and marked MADV_HUGEPAGE, so
// the kernel may back them with transparent huge pages.
//
// Why: at N = 10^6 every neighbour record an EDMD prediction reads is a cache miss, and with
// 4 KiB pages most of them are also TLB misses (10^6 x 128 B of records = 32k pages, against
// ~3k second-level TLB entries), each adding a page walk to the DRAM latency. bench_memory's
// pointer chase measures the difference on this machine (docs/PERFORMANCE.md, "Memory
// latency"). The advice changes no result: it only changes which pages back the memory, and
// it is ignored where THP is disabled ("never") or unavailable (non-Linux).
#include <cstddef>
#include <cstdlib>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace grainbath {

template <class T>
struct HugePageAllocator {
  using value_type = T;
  static constexpr std::size_t kHugePage = std::size_t{2} << 20;
  static constexpr std::size_t kThreshold = std::size_t{4} << 20;  // smaller blocks: plain new

  HugePageAllocator() noexcept = default;
  template <class U>
  HugePageAllocator(const HugePageAllocator<U>&) noexcept {}

  T* allocate(std::size_t n) {
    if (n > std::size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
    const std::size_t bytes = n * sizeof(T);
    if (bytes < kThreshold) return static_cast<T*>(::operator new(bytes, std::align_val_t{alignof(T)}));
    const std::size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
    void* p = std::aligned_alloc(kHugePage, rounded);
    if (!p) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    madvise(p, rounded, MADV_HUGEPAGE);  // advice: failure leaves 4 KiB pages, still correct
#endif
    return static_cast<T*>(p);
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (n * sizeof(T) < kThreshold)
      ::operator delete(p, std::align_val_t{alignof(T)});
    else
      std::free(p);
  }
  template <class U>
  bool operator==(const HugePageAllocator<U>&) const noexcept { return true; }
};

// std::vector on huge pages where it is large (same interface as std::vector)
template <class T>
using HugePageVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace grainbath
