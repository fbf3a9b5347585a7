#pragma once
// A std::vector whose resize() leaves new elements default-initialised: for trivially
// constructible types (double, integers) no zero fill. For the large per-particle arrays of
// DSMC (the grains' state and the cell sort's scratch), which are written in full, in
// parallel, right after they grow: std::vector's value-initialising resize filled them with
// zeros on one thread first, and so took every page fault of a fresh allocation on that
// thread (at 10^7 particles most of the run's set-up and of its first step; docs/PERFORMANCE.md,
// "DSMC set-up"). With it, the pages are first touched by the threads that write them.
//
// Only for arrays every new element of which is written before it is read, wherever they
// grow (each growing resize of one says so where it is).
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

namespace grainbath {

template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  using value_type = T;
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() noexcept = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  // no arguments (resize): default-initialise, i.e. a double keeps what the memory held
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

template <class T, class U>
bool operator==(const DefaultInitAllocator<T>&, const DefaultInitAllocator<U>&) noexcept {
  return true;
}

template <class T>
using NoFillVector = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace grainbath
