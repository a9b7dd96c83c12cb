// The code's version as `git describe --always --dirty --tags` of the
// source tree when the binary was built ("unknown" outside a git checkout).
// Summaries, results stores and `hrad --version` record it, so a store names
// the commit its points ran on. It is refreshed at every build, not only when
// CMake configures (cmake/git_describe.cmake).
#pragma once

namespace hrad {

const char* gitDescribe();

}  // namespace hrad
