#include "core/suggest.h"

#include <algorithm>
#include <numeric>

namespace hrad {

size_t editDistance(std::string_view a, std::string_view b) {
    // Three rows of the optimal-string-alignment table (Damerau 1964 with
    // the restriction that a transposed pair is not edited again).
    const size_t n = b.size();
    std::vector<size_t> prev2(n + 1), prev(n + 1), cur(n + 1);
    std::iota(prev.begin(), prev.end(), size_t(0));
    for (size_t i = 1; i <= a.size(); ++i) {
        cur[0] = i;
        for (size_t j = 1; j <= n; ++j) {
            const size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
            cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + cost});
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
                cur[j] = std::min(cur[j], prev2[j - 2] + 1);
        }
        prev2.swap(prev);
        prev.swap(cur);
    }
    return prev[n];
}

namespace {

size_t allowedEdits(std::string_view word) { return std::max<size_t>(1, word.size() / 3); }

std::string_view lastSegment(std::string_view key) {
    const size_t dot = key.rfind('.');
    return dot == std::string_view::npos ? key : key.substr(dot + 1);
}

/// The candidates with distance(candidate) <= limit, nearest first.
template <class Distance>
std::vector<std::string> nearest(const std::vector<std::string>& known, size_t most,
                                 std::string_view word, size_t limit, Distance distance) {
    std::vector<std::pair<size_t, size_t>> hits;  // (distance, index)
    for (size_t i = 0; i < known.size(); ++i) {
        if (known[i] == word) continue;
        const size_t d = distance(known[i]);
        if (d <= limit) hits.emplace_back(d, i);
    }
    std::stable_sort(hits.begin(), hits.end(),
                     [](const auto& x, const auto& y) { return x.first < y.first; });
    std::vector<std::string> out;
    for (const auto& [d, i] : hits) {
        if (out.size() >= most) break;
        if (std::find(out.begin(), out.end(), known[i]) == out.end()) out.push_back(known[i]);
    }
    return out;
}

}  // namespace

std::vector<std::string> nearestNames(std::string_view word, const std::vector<std::string>& known,
                                      size_t most) {
    return nearest(known, most, word, allowedEdits(word),
                   [&](const std::string& k) { return editDistance(word, k); });
}

std::vector<std::string> nearestKeys(std::string_view key, const std::vector<std::string>& known,
                                     size_t most) {
    std::vector<std::string> whole = nearestNames(key, known, most);
    if (!whole.empty()) return whole;
    const std::string_view last = lastSegment(key);
    return nearest(known, most, key, allowedEdits(last),
                   [&](const std::string& k) { return editDistance(last, lastSegment(k)); });
}

std::string didYouMean(const std::vector<std::string>& names) {
    if (names.empty()) return "";
    std::string s = "did you mean ";
    for (size_t i = 0; i < names.size(); ++i) {
        if (i > 0) s += i + 1 == names.size() ? " or " : ", ";
        s += "'" + names[i] + "'";
    }
    return s + "?";
}

}  // namespace hrad
