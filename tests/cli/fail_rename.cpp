// A test shim, loaded with LD_PRELOAD into the grainbath binary: rename(2) fails with EXDEV
// for every destination path that ends in $GRAINBATH_TEST_FAIL_RENAME_TO, and behaves as
// usual otherwise. The moves grainbath makes at the end of a run and at the start of a sweep
// (OUT to OUT.previous, OUT.tmp-PID to OUT) cannot be made to fail otherwise when the tests
// run as root (permissions do not stop root), so without it the paths that keep the results
// when a move fails were never run (docs/reviews/mutation-audit-sweep-mpi.md, S20).
// A move across file systems is the realistic failure it stands for: rename(2) cannot do it.
#include <dlfcn.h>
#include <fcntl.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace {

bool fails(const char* to) {
  const char* suffix = std::getenv("GRAINBATH_TEST_FAIL_RENAME_TO");
  if (suffix == nullptr || *suffix == '\0' || to == nullptr) return false;
  const std::size_t n = std::strlen(to), k = std::strlen(suffix);
  return n >= k && std::strcmp(to + n - k, suffix) == 0;
}

template <class F>
F next(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

}  // namespace

extern "C" {

int rename(const char* from, const char* to) {
  if (fails(to)) {
    errno = EXDEV;
    return -1;
  }
  static const auto real = next<int (*)(const char*, const char*)>("rename");
  return real(from, to);
}

int renameat(int from_dir, const char* from, int to_dir, const char* to) {
  if (fails(to)) {
    errno = EXDEV;
    return -1;
  }
  static const auto real = next<int (*)(int, const char*, int, const char*)>("renameat");
  return real(from_dir, from, to_dir, to);
}

int renameat2(int from_dir, const char* from, int to_dir, const char* to, unsigned flags) {
  if (fails(to)) {
    errno = EXDEV;
    return -1;
  }
  static const auto real = next<int (*)(int, const char*, int, const char*, unsigned)>("renameat2");
  return real(from_dir, from, to_dir, to, flags);
}

}  // extern "C"
