// Typed settings with provenance, that report keys nobody read.
//
// Every strategy (oracle, solver, loader, quadrature rule...) builds its plain
// Settings struct from a Params. Each value remembers where it came from (a
// TOML file and line, or the command-line flag), and each read marks it used.
// After construction the owner calls reportUnused(), which throws an
// InputError naming the first unread key and its origin: a misspelt setting is
// an error, never a silent default (pbrt-v4 ParameterDictionary::ReportUnused).
// Range checks happen where a value is read, and the message names the key.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "core/error.h"

namespace hrad {

class Params {
  public:
    using Value = std::variant<bool, int64_t, double, std::string>;

    struct Entry {
        Value value;
        SourceLocation where;
        mutable bool used = false;
    };

    Params() = default;

    void set(const std::string& key, Value value, SourceLocation where = {});
    /// Parses text as bool ("true"/"false"), integer, double, else keeps a string.
    void setFromText(const std::string& key, const std::string& text, SourceLocation where = {});
    bool has(const std::string& key) const { return entries_.count(key) != 0; }
    bool empty() const { return entries_.empty(); }
    void erase(const std::string& key) { entries_.erase(key); }

    /// Where a key came from (empty location when absent).
    SourceLocation where(const std::string& key) const;

    bool getBool(const std::string& key, bool def) const;
    int64_t getInt(const std::string& key, int64_t def) const;
    /// Integer with inclusive range check.
    int64_t getInt(const std::string& key, int64_t def, int64_t lo, int64_t hi) const;
    double getDouble(const std::string& key, double def) const;
    /// Double in [lo, hi] (inclusive), or (lo, hi] when loOpen.
    double getDouble(const std::string& key, double def, double lo, double hi,
                     bool loOpen = false) const;
    std::string getString(const std::string& key, const std::string& def) const;
    /// A string that must be one of `allowed`; the error lists them.
    std::string getEnum(const std::string& key, const std::string& def,
                        const std::vector<std::string>& allowed) const;

    /// Keys starting with "prefix." with the prefix removed (marks nothing used).
    /// Error messages of the subset still name keys with the prefix.
    Params subset(const std::string& prefix) const;
    /// Mark every key starting with "prefix." as used (after subset() was consumed).
    void markUsedPrefix(const std::string& prefix) const;
    void markUsed(const std::string& key) const;

    /// Throws InputError for the first key never read.
    void reportUnused() const;
    std::vector<std::string> unusedKeys() const;

    /// Human-readable "key = value" lines, sorted by key.
    std::string toString() const;
    const std::map<std::string, Entry>& entries() const { return entries_; }

    static std::string valueToString(const Value& v);

  private:
    const Entry* find(const std::string& key) const;
    std::map<std::string, Entry> entries_;
    std::string prefix_;  ///< prepended to key names in messages (set by subset())
};

}  // namespace hrad
