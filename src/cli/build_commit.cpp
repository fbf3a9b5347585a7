// The git commit this binary was built from (cmake/BuildCommit.cmake), in its own translation
// unit so that a new commit recompiles only this file.
#include "build_commit.hpp"
#include "cli/commands.hpp"

namespace grainbath::cli {
const char* build_commit() { return GRAINBATH_BUILD_COMMIT; }
}  // namespace grainbath::cli
