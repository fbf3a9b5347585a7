#pragma once
// Sums over blocks of kGlobalBlock particles of the global particle order when the
// population is spread over MPI ranks in rank order (src/dsmc/decomposition.cpp,
// Decomposition::moments_in_global_blocks): rank r holds the particles [offset, offset + n)
// of the global order. The blocks that lie inside a rank are summed at once, on that rank; a
// block split between ranks is summed by its ranks in turn, each going on from the sums of
// the ones before (the carry), so that every block is added in particle order exactly as one
// process adds it, and the moments are the same bits at any rank count.
//
// Two parts, so that the rank-order logic can be checked without MPI
// (tests/dsmc/test_dsmc_decomposition.cpp, `DsmcGlobalBlocks.*`, which simulates the ranks):
// split_into_global_blocks, local to a rank, and continue_global_blocks, run on each rank in
// rank order with the carry the rank before left.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace grainbath::dsmc {

inline constexpr std::size_t kGlobalBlock = 4096;  // measure_moments' block (src/dsmc/moments.cpp)

template <class Sums>
struct GlobalBlockCarry {
  int open = 0;  // a block begun on an earlier rank is not finished
  Sums sums{};
};

// One rank's particles [0, n) (global offset `offset`) against the global blocks.
template <class Sums>
struct RankInGlobalBlocks {
  std::size_t head = 0;          // [0, head): the end of a block begun on the ranks before
  bool head_ends_block = false;  // ... and that block ends on this rank
  std::vector<Sums> inside;      // the whole blocks inside this rank, in order
  bool tail_open = false;        // [tail_from, n) begins a block that goes on after this rank
  std::size_t tail_from = 0;
  Sums tail{};
};

// The local part: `blocks(bounds, out)` sums the particles between consecutive bounds into
// out (one Sums per block); `range(lo, hi, s)` adds the particles [lo, hi) to s.
template <class Sums, class Blocks, class Range>
RankInGlobalBlocks<Sums> split_into_global_blocks(std::size_t n, std::uint64_t offset, const Blocks& blocks,
                                                  const Range& range) {
  RankInGlobalBlocks<Sums> part;
  const auto to_boundary = static_cast<std::size_t>((kGlobalBlock - offset % kGlobalBlock) % kGlobalBlock);
  part.head = to_boundary < n ? to_boundary : n;
  // the block begun before ends here when its boundary is at or before this rank's end: a
  // head that reaches exactly n ends its block on this rank too (audit D53)
  part.head_ends_block = part.head > 0 && to_boundary <= n;
  std::vector<std::size_t> bounds;
  std::size_t lo = part.head;
  for (; lo + kGlobalBlock <= n; lo += kGlobalBlock) bounds.push_back(lo);
  if (!bounds.empty()) bounds.push_back(lo);
  blocks(bounds, part.inside);
  // not when the head already ran to n (then lo = n anyway)
  part.tail_open = lo < n && (part.head_ends_block || part.head == 0);
  part.tail_from = lo;
  if (part.tail_open) range(lo, n, part.tail);
  return part;
}

// The rank's turn, in rank order: goes on from the carry of the ranks before, appends to
// `done` the blocks that end on this rank (in order), and leaves the carry for the next rank.
// The last rank also ends the last, partial block of the population.
template <class Sums, class Range>
void continue_global_blocks(const RankInGlobalBlocks<Sums>& part, bool last_rank, const Range& range,
                            GlobalBlockCarry<Sums>& carry, std::vector<Sums>& done) {
  if (part.head > 0) {
    range(0, part.head, carry.sums);  // goes on from the ranks before
    carry.open = 1;
  }
  if (part.head_ends_block) {
    done.push_back(carry.sums);
    carry = GlobalBlockCarry<Sums>{};
  }
  done.insert(done.end(), part.inside.begin(), part.inside.end());
  if (part.tail_open) carry = GlobalBlockCarry<Sums>{1, part.tail};
  if (last_rank && carry.open) {
    done.push_back(carry.sums);
    carry = GlobalBlockCarry<Sums>{};
  }
}

}  // namespace grainbath::dsmc
