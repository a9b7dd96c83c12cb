// Strict number parsing shared by every text format hrad reads (OBJ/MTL, MGF,
// PLY headers and bodies, .hrsol text, command-line values).
//
// "Strict" means: the whole token is the number (no trailing "x", no "4e3"
// where an integer is expected), the value is finite and representable (no
// "inf", "nan", or "1e400" that overflows to infinity), and nothing is
// silently replaced by 0. std::from_chars does the conversion: it is
// locale-independent and never reads past the token. A leading '+' is
// accepted (printf's "%+f" writes it; from_chars alone would refuse it).
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace hrad {

/// The token as a finite double, or nullopt (malformed, partial, inf/nan,
/// out of range).
std::optional<double> parseFiniteDouble(std::string_view token);

/// The token as a decimal integer (no exponent, no fraction), or nullopt
/// (malformed, partial, out of int64 range).
std::optional<int64_t> parseInt64(std::string_view token);

}  // namespace hrad
