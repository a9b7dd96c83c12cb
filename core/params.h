// Typed settings with provenance, that report keys nobody read.
//
// Every strategy (oracle, solver, loader, quadrature rule...) builds its plain
// Settings struct from a Params. Each value remembers where it came from (a
// TOML file and line, or the command-line flag), and each read marks it used.
// After construction the owner calls reportUnused(), which throws an
// InputError naming the first unread key and its origin: a misspelt setting is
// an error, never a silent default (pbrt-v4 ParameterDictionary::ReportUnused).
// Range checks happen where a value is read, and the message names the key.
//
// Every read is also recorded (key, resolved value, type, default, range or
// allowed values, one-line doc, reading component): the doc, default and
// range are declared once, at the read site (`p.getInt({"hr.max_level",
// "deepest quadtree level"}, 14, 0, 31)`), and `records()` is what the
// summary, the results store, `hrad settings` and docs/settings.md show.
// subset() shares the records with its parent (keys keep their full name);
// a copy of a Params takes its own copy of them, so points of a sweep never
// mix. Choices resolved after reading (cluster.model = auto, a memory budget
// of 0) are written back with recordResolved().
#pragma once

#include <cstdint>
#include <map>
#include <memory>
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

    /// A key as a reader names it: its name and a one-line doc (what it
    /// does, when to change it). A bare string converts (no doc).
    struct Key {
        Key(const char* n) : name(n) {}
        Key(std::string n) : name(std::move(n)) {}
        Key(std::string n, std::string d) : name(std::move(n)), doc(std::move(d)) {}
        std::string name;
        std::string doc;
    };

    /// What one key's readers saw (the first non-empty doc wins; every
    /// reading component is listed).
    struct Record {
        std::string key;        ///< full name (subset prefixes included)
        std::string type;       ///< boolean, integer, number, string
        Value value;            ///< as read (the default when absent)
        std::string def;        ///< the default, as text
        std::string range;      ///< "[lo, hi]", "(lo, hi]", "a | b | c" or ""
        std::string doc;
        std::string component;  ///< the readers' scopes, ", "-joined
        bool given = false;     ///< set in the input (not the default)
        std::optional<Value> resolved;  ///< recordResolved: what the run used
        const Value& used() const { return resolved ? *resolved : value; }
        /// Adds a reader to `component` unless it is listed already.
        void addReader(const std::string& who);
    };

    /// RAII: reads while it lives are recorded as read by `component`
    /// (nested scopes: the innermost wins). Shared with subset()s.
    class Scope {
      public:
        Scope(const Params& p, std::string component);
        ~Scope();
        Scope(const Scope&) = delete;
        Scope& operator=(const Scope&) = delete;

      private:
        const Params& p_;
    };

    Params() = default;
    Params(const Params& o);
    Params& operator=(const Params& o);
    Params(Params&&) noexcept = default;
    Params& operator=(Params&&) noexcept = default;

    void set(const std::string& key, Value value, SourceLocation where = {});
    /// Parses text as bool ("true"/"false"), integer, double, else keeps a string.
    void setFromText(const std::string& key, const std::string& text, SourceLocation where = {});
    bool has(const std::string& key) const { return entries_.count(key) != 0; }
    bool empty() const { return entries_.empty(); }
    void erase(const std::string& key) { entries_.erase(key); }

    /// Where a key came from (empty location when absent).
    SourceLocation where(const std::string& key) const;

    bool getBool(const Key& key, bool def) const;
    int64_t getInt(const Key& key, int64_t def) const;
    /// Integer with inclusive range check.
    int64_t getInt(const Key& key, int64_t def, int64_t lo, int64_t hi) const;
    double getDouble(const Key& key, double def) const;
    /// Double in [lo, hi] (inclusive), or (lo, hi] when loOpen.
    double getDouble(const Key& key, double def, double lo, double hi,
                     bool loOpen = false) const;
    std::string getString(const Key& key, const std::string& def) const;
    /// A string that must be one of `allowed`; the error lists them.
    std::string getEnum(const Key& key, const std::string& def,
                        const std::vector<std::string>& allowed) const;

    /// The value a run used for a key read earlier, when it differs from
    /// what was read (an "auto" resolved, 0 meaning "80 % of RAM"...).
    void recordResolved(const std::string& key, Value value) const;
    /// Records a key read as it is, without a default or type of its own
    /// (free-form keys handed on as text, e.g. mitsuba.param.*).
    void recordAsGiven(const Key& key) const;
    /// Every key read so far (through this Params and its subsets), by full name.
    const std::map<std::string, Record>& records() const;

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
    struct Recorder {
        std::map<std::string, Record> records;
        std::vector<std::string> scopes;
    };
    const Entry* find(const std::string& key) const;
    bool readBool(const std::string& key, bool def) const;
    int64_t readInt(const std::string& key, int64_t def) const;
    double readDouble(const std::string& key, double def) const;
    std::string readString(const std::string& key, const std::string& def) const;
    Recorder& recorder() const;
    void record(const Key& key, const char* type, const Value& value, const std::string& def,
                std::string range) const;
    std::map<std::string, Entry> entries_;
    mutable std::shared_ptr<Recorder> rec_;  ///< shared with subset()s, copied by copies
    std::string prefix_;  ///< prepended to key names in messages (set by subset())
};

}  // namespace hrad
