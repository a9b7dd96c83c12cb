#include "core/error.h"

namespace hrad {

std::string SourceLocation::str() const {
    if (file.empty()) return "<unknown>";
    if (line <= 0) return file;
    if (column <= 0) return fmt::format("{}:{}", file, line);
    return fmt::format("{}:{}:{}", file, line, column);
}

InputError::InputError(SourceLocation where, const std::string& message)
    : Error(where.known() ? where.str() + ": error: " + message : "error: " + message),
      where_(std::move(where)),
      message_(message) {}

}  // namespace hrad
