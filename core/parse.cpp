// Strict number parsing (see parse.h).
#include "core/parse.h"

#include <charconv>
#include <cmath>
#include <system_error>

namespace hrad {

namespace {
std::string_view withoutPlus(std::string_view t) {
    if (t.size() > 1 && t[0] == '+' && t[1] != '-' && t[1] != '+') t.remove_prefix(1);
    return t;
}
}  // namespace

std::optional<double> parseFiniteDouble(std::string_view token) {
    token = withoutPlus(token);
    if (token.empty()) return std::nullopt;
    double v = 0.0;
    auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
    if (ec != std::errc() || end != token.data() + token.size() || !std::isfinite(v))
        return std::nullopt;
    return v;
}

std::optional<int64_t> parseInt64(std::string_view token) {
    token = withoutPlus(token);
    if (token.empty()) return std::nullopt;
    int64_t v = 0;
    auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
    if (ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
    return v;
}

}  // namespace hrad
