// "Did you mean": the known names nearest to a misspelt one.
//
// A misspelt subcommand, option, built-in scene name or setting key is an
// error that names the nearest known names, found by edit distance over the
// names the program knows (its registries, its Params declarations, CLI11's
// options): never a typed list that can drift from the code.
//
// Distance: Levenshtein (insertions, deletions, substitutions, each 1) with
// adjacent transpositions counted as one edit (Damerau's "optimal string
// alignment"): "solv" -> "solve" 1, "epz" -> "eps" 1, "--widht" -> "--width" 1.
// A name is suggested when it is within max(1, |word| / 3) edits. Dotted
// setting keys are also matched segment-wise: "hr.epz" is far from
// "oracle.eps" as a whole, but its last segment is one edit from "eps", so
// keys ending in a near segment are suggested when no whole key is near.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace hrad {

/// Edit distance (optimal string alignment) between a and b.
size_t editDistance(std::string_view a, std::string_view b);

/// The names of `known` within max(1, |word| / 3) edits of `word`, nearest
/// first (ties in the order given), at most `most`; none equal to word.
std::vector<std::string> nearestNames(std::string_view word, const std::vector<std::string>& known,
                                      size_t most = 3);

/// nearestNames for dotted setting keys; when no whole key is near, the keys
/// whose last segment is near word's last segment (prefix ignored).
std::vector<std::string> nearestKeys(std::string_view key, const std::vector<std::string>& known,
                                     size_t most = 3);

/// "did you mean 'a'?", "did you mean 'a' or 'b'?", "did you mean 'a', 'b' or
/// 'c'?", or "" when `names` is empty.
std::string didYouMean(const std::vector<std::string>& names);

}  // namespace hrad
