// See version.h.
#include "core/version.h"

#include "hrad_git_describe.h"

namespace hrad {

const char* gitDescribe() { return HRAD_GIT_DESCRIBE; }

}  // namespace hrad
