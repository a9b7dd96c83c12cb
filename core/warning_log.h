// Warnings counted, not repeated.
//
// A loader may meet the same problem thousands of times (35 of a conference
// room's 37 OBJ warnings were one "both d and Tr" line; 10^8 instances of a
// skipped Mitsuba shape once held 7.6 GiB of warning strings). WarningLog
// keeps one line per distinct warning, "<first occurrence> (N times in all;
// also <second>; <third>)", at most kExamples different occurrences of each
// as examples; past kDistinct
// distinct warnings the rest are only counted, in one closing line. Its
// memory is bounded whatever the number of warnings (tests/core).
//
// Distinct means: the same text once every number is replaced by '#' and
// every quoted name ('...', "...", `...`) by '*', so "a.mtl:12: material
// 'chair': ..." and "a.mtl:40: material 'desk': ..." are one warning with two
// examples. A caller with its own notion of "the same" passes a key.
//
// It reads as the list of lines it prints (size(), operator[], iteration),
// so callers that printed a vector of strings print it unchanged.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace hrad {

class WarningLog {
  public:
    static constexpr size_t kExamples = 3;    ///< occurrences kept per distinct warning
    static constexpr size_t kDistinct = 200;  ///< distinct warnings kept; more are counted

    struct Entry {
        uint64_t count = 0;
        std::vector<std::string> examples;  ///< the first kExamples different occurrences
    };

    /// Adds a warning; distinct by its text with numbers and quoted names blanked.
    void push_back(const std::string& text) { add(normalized(text), text); }
    /// Adds a warning that is the same as every other of the same key.
    void add(const std::string& key, const std::string& text);

    /// The lines to print, one per distinct warning (plus one for those past kDistinct).
    size_t size() const { return lines_.size(); }
    bool empty() const { return lines_.empty(); }
    const std::string& operator[](size_t i) const { return lines_[i]; }
    std::vector<std::string>::const_iterator begin() const { return lines_.begin(); }
    std::vector<std::string>::const_iterator end() const { return lines_.end(); }
    /// The distinct warnings, in the order they first occurred (lines() minus the overflow line).
    const std::vector<Entry>& entries() const { return entries_; }
    /// Every warning added, repeats included.
    uint64_t total() const { return total_; }
    /// Bytes held (strings, tables): bounded by the constants above.
    size_t memoryBytes() const;
    /// Appends another log's warnings (each occurrence counted, examples kept).
    void merge(const WarningLog& other);

    /// The key push_back uses: digits -> '#', quoted names -> '*'.
    static std::string normalized(const std::string& text);

  private:
    void refreshLine(size_t i);
    void addCounted(const std::string& key, const std::string& text, uint64_t n);
    std::vector<Entry> entries_;
    std::vector<std::string> lines_;
    std::unordered_map<std::string, size_t> index_;  ///< key -> entries_ index
    uint64_t total_ = 0, overflow_ = 0;
};

}  // namespace hrad
