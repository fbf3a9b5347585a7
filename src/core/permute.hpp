#pragma once
// Reordering several parallel arrays by one permutation, in place.
//
// Why not `copy = a; a[k] = copy[order[k]]`: at 10^6 EDMD disks the copies of the per-slot
// arrays (188 bytes per disk) are ≈ 190 MB of fresh pages at every re-sort, each page zeroed
// by the kernel on first touch; on the project's VMs that zeroing was a third of a short
// run's time (docs/performance/edmd.md, "the re-sort without copies"). Following the
// permutation's cycles needs one saved element per array instead.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <tuple>
#include <type_traits>
#include <vector>

namespace grainbath {

// After the call, for every non-empty array a: a_after[k] == a_before[order[k]] (new slot k
// takes old slot order[k]). Every array must have order.size() elements or none (an array
// with none is left alone: an optional per-particle field that this run does not carry).
// `order` must be a permutation of 0..n-1; it is consumed (left as the identity). One that is
// not throws std::invalid_argument when the walk finds it out, the arrays then part-reordered
// (a caller's logic error, not an input error).
template <class... Arrays>
void permute_in_place(std::vector<std::uint32_t>& order, Arrays&... arrays) {
  const std::size_t n = order.size();
  if (((arrays.size() != n && !arrays.empty()) || ...))
    throw std::invalid_argument("permute_in_place: an array's length differs from the permutation's");
  auto get = [](const auto& a, std::size_t i) {
    using T = typename std::remove_cvref_t<decltype(a)>::value_type;
    return a.empty() ? T{} : a[i];
  };
  for (std::size_t start = 0; start < n; ++start) {
    if (order[start] == start) continue;  // a fixed point, or placed by an earlier cycle
    // the cycle start <- order[start] <- order[order[start]] ... <- start
    std::tuple<typename Arrays::value_type...> saved{get(arrays, start)...};
    std::size_t to = start;
    for (;;) {
      const std::size_t from = order[to];
      if (from >= n || from == to) throw std::invalid_argument("permute_in_place: order is not a permutation");
      order[to] = static_cast<std::uint32_t>(to);
      if (from == start) {
        std::apply([&](const auto&... s) { ((arrays.empty() ? void() : void(arrays[to] = s)), ...); }, saved);
        break;
      }
      ((arrays.empty() ? void() : void(arrays[to] = arrays[from])), ...);
      to = from;
    }
  }
}

}  // namespace grainbath
