// Typed errors carrying a source location, and CHECK macros.
//
// Input problems (malformed files, bad settings) throw hrad::InputError with the
// file and line that caused them; the CLI prints what() and exits non-zero.
// Broken invariants (bugs) use HRAD_CHECK, which throws hrad::InternalError with
// the C++ source location, in the spirit of pbrt-v4's util/check.h.
#pragma once

#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace hrad {

/// Where a piece of input came from: a file and line (column optional), or a
/// description such as "command line" with line 0.
struct SourceLocation {
    std::string file;
    int line = 0;
    int column = 0;

    std::string str() const;
    bool known() const { return !file.empty(); }
};

/// Base class of every hrad error.
class Error : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// Bad input: a malformed scene file, an invalid setting, an impossible request.
class InputError : public Error {
  public:
    InputError(SourceLocation where, const std::string& message);
    const SourceLocation& where() const { return where_; }
    const std::string& message() const { return message_; }

  private:
    SourceLocation where_;
    std::string message_;
};

/// A violated internal invariant (a bug in hrad, not in the input).
class InternalError : public Error {
  public:
    using Error::Error;
};

template <typename... Args>
[[noreturn]] void throwInputError(const SourceLocation& where, fmt::format_string<Args...> f,
                                  Args&&... args) {
    throw InputError(where, fmt::format(f, std::forward<Args>(args)...));
}

}  // namespace hrad

#define HRAD_CHECK(cond)                                                                   \
    do {                                                                                   \
        if (!(cond))                                                                       \
            throw ::hrad::InternalError(                                                   \
                ::fmt::format("{}:{}: check failed: {}", __FILE__, __LINE__, #cond));      \
    } while (false)

#define HRAD_CHECK_MSG(cond, ...)                                                          \
    do {                                                                                   \
        if (!(cond))                                                                       \
            throw ::hrad::InternalError(::fmt::format("{}:{}: check failed: {}: {}",       \
                                                      __FILE__, __LINE__, #cond,           \
                                                      ::fmt::format(__VA_ARGS__)));        \
    } while (false)

#ifdef NDEBUG
#define HRAD_DCHECK(cond) \
    do {                  \
    } while (false)
#else
#define HRAD_DCHECK(cond) HRAD_CHECK(cond)
#endif
