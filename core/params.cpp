#include "core/params.h"

#include "core/suggest.h"

#include "core/parse.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace hrad {

namespace {
std::string typeName(const Params::Value& v) {
    switch (v.index()) {
        case 0: return "boolean";
        case 1: return "integer";
        case 2: return "number";
        default: return "string";
    }
}
}  // namespace

void Params::set(const std::string& key, Value value, SourceLocation where) {
    entries_[key] = Entry{std::move(value), std::move(where), false};
}

void Params::setFromText(const std::string& key, const std::string& text, SourceLocation where) {
    if (text == "true" || text == "false") {
        set(key, text == "true", std::move(where));
        return;
    }
    // Strict (core/parse.h): "nan", "inf", "1e400" or "0x10" stay text, which
    // a numeric setting then refuses by name.
    if (auto i = parseInt64(text)) {
        set(key, *i, std::move(where));
        return;
    }
    if (auto d = parseFiniteDouble(text)) {
        set(key, *d, std::move(where));
        return;
    }
    set(key, text, std::move(where));
}

SourceLocation Params::where(const std::string& key) const {
    auto it = entries_.find(key);
    return it == entries_.end() ? SourceLocation{} : it->second.where;
}

const Params::Entry* Params::find(const std::string& key) const {
    auto it = entries_.find(key);
    if (it == entries_.end()) return nullptr;
    it->second.used = true;
    return &it->second;
}

// Each getter reads (readX, no record), checks, then records what it returned.

bool Params::readBool(const std::string& key, bool def) const {
    const Entry* e = find(key);
    if (!e) return def;
    if (auto* b = std::get_if<bool>(&e->value)) return *b;
    throwInputError(e->where, "setting '{}' must be a boolean, got {} '{}'", prefix_ + key,
                    typeName(e->value), valueToString(e->value));
}

int64_t Params::readInt(const std::string& key, int64_t def) const {
    const Entry* e = find(key);
    if (!e) return def;
    if (auto* i = std::get_if<int64_t>(&e->value)) return *i;
    if (auto* d = std::get_if<double>(&e->value)) {
        if (std::isfinite(*d) && std::floor(*d) == *d && std::fabs(*d) < 9e15)
            return static_cast<int64_t>(*d);
    }
    throwInputError(e->where, "setting '{}' must be an integer, got {} '{}'", prefix_ + key,
                    typeName(e->value), valueToString(e->value));
}

double Params::readDouble(const std::string& key, double def) const {
    const Entry* e = find(key);
    if (!e) return def;
    double v;
    if (auto* d = std::get_if<double>(&e->value))
        v = *d;
    else if (auto* i = std::get_if<int64_t>(&e->value))
        v = static_cast<double>(*i);
    else
        throwInputError(e->where, "setting '{}' must be a number, got {} '{}'", prefix_ + key,
                        typeName(e->value), valueToString(e->value));
    if (!std::isfinite(v))
        throwInputError(e->where, "setting '{}' must be finite, got {}", prefix_ + key, v);
    return v;
}

std::string Params::readString(const std::string& key, const std::string& def) const {
    const Entry* e = find(key);
    if (!e) return def;
    if (auto* s = std::get_if<std::string>(&e->value)) return *s;
    throwInputError(e->where, "setting '{}' must be a string, got {} '{}'", prefix_ + key,
                    typeName(e->value), valueToString(e->value));
}

bool Params::getBool(const Key& key, bool def) const {
    bool v = readBool(key.name, def);
    record(key, "boolean", v, def ? "true" : "false", "");
    return v;
}

int64_t Params::getInt(const Key& key, int64_t def) const {
    int64_t v = readInt(key.name, def);
    record(key, "integer", v, std::to_string(def), "");
    return v;
}

int64_t Params::getInt(const Key& key, int64_t def, int64_t lo, int64_t hi) const {
    int64_t v = readInt(key.name, def);
    if (v < lo || v > hi)
        throwInputError(where(key.name), "setting '{}' = {} is out of range [{}, {}]",
                        prefix_ + key.name, v, lo, hi);
    record(key, "integer", v, std::to_string(def), fmt::format("[{}, {}]", lo, hi));
    return v;
}

double Params::getDouble(const Key& key, double def) const {
    double v = readDouble(key.name, def);
    record(key, "number", v, fmt::format("{}", def), "");
    return v;
}

double Params::getDouble(const Key& key, double def, double lo, double hi, bool loOpen) const {
    double v = readDouble(key.name, def);
    bool bad = loOpen ? !(v > lo && v <= hi) : !(v >= lo && v <= hi);
    if (bad)
        throwInputError(where(key.name), "setting '{}' = {} is out of range {}{}, {}]",
                        prefix_ + key.name, v, loOpen ? "(" : "[", lo, hi);
    record(key, "number", v, fmt::format("{}", def),
           fmt::format("{}{}, {}]", loOpen ? "(" : "[", lo, hi));
    return v;
}

std::string Params::getString(const Key& key, const std::string& def) const {
    std::string v = readString(key.name, def);
    record(key, "string", v, def, "");
    return v;
}

std::string Params::getEnum(const Key& key, const std::string& def,
                            const std::vector<std::string>& allowed) const {
    std::string v = readString(key.name, def);
    if (std::find(allowed.begin(), allowed.end(), v) == allowed.end())
        throwInputError(where(key.name), "setting '{}' = '{}' is not one of: {}",
                        prefix_ + key.name, v, fmt::join(allowed, ", "));
    record(key, "string", v, def, fmt::format("{}", fmt::join(allowed, " | ")));
    return v;
}

// ---- records ------------------------------------------------------------------

Params::Params(const Params& o) : entries_(o.entries_), prefix_(o.prefix_) {
    if (o.rec_) rec_ = std::make_shared<Recorder>(*o.rec_);
}

Params& Params::operator=(const Params& o) {
    if (this == &o) return *this;
    entries_ = o.entries_;
    prefix_ = o.prefix_;
    rec_ = o.rec_ ? std::make_shared<Recorder>(*o.rec_) : nullptr;
    return *this;
}

Params::Recorder& Params::recorder() const {
    if (!rec_) rec_ = std::make_shared<Recorder>();
    return *rec_;
}

Params::Scope::Scope(const Params& p, std::string component) : p_(p) {
    p_.recorder().scopes.push_back(std::move(component));
}

Params::Scope::~Scope() { p_.recorder().scopes.pop_back(); }

void Params::record(const Key& key, const char* type, const Value& value, const std::string& def,
                    std::string range) const {
    Recorder& rec = recorder();
    const std::string full = prefix_ + key.name;
    auto [it, fresh] = rec.records.try_emplace(full);
    Record& r = it->second;
    if (fresh) {
        r.key = full;
        r.type = type;
        r.def = def;
    }
    r.value = value;
    r.given = has(key.name);
    if (r.doc.empty()) r.doc = key.doc;
    if (r.range.empty()) r.range = std::move(range);
    if (!rec.scopes.empty()) r.addReader(rec.scopes.back());
}

void Params::Record::addReader(const std::string& who) {
    if (!who.empty() && (", " + component + ", ").find(", " + who + ", ") == std::string::npos)
        component += (component.empty() ? "" : ", ") + who;
}

void Params::recordAsGiven(const Key& key) const {
    const Entry* e = find(key.name);
    if (!e) return;
    static constexpr const char* kTypes[] = {"boolean", "integer", "number", "string"};
    record(key, kTypes[e->value.index()], e->value, "", "");
}

void Params::recordResolved(const std::string& key, Value value) const {
    auto& records = recorder().records;
    auto it = records.find(prefix_ + key);
    if (it != records.end() && it->second.value != value) it->second.resolved = std::move(value);
}

const std::map<std::string, Params::Record>& Params::records() const {
    return recorder().records;
}

Params Params::subset(const std::string& prefix) const {
    Params out;
    recorder();
    out.rec_ = rec_;  // the subset's reads are the parent's records
    std::string p = prefix + ".";
    out.prefix_ = prefix_ + p;
    for (const auto& [k, e] : entries_)
        if (k.rfind(p, 0) == 0) out.entries_[k.substr(p.size())] = Entry{e.value, e.where, false};
    return out;
}

void Params::markUsedPrefix(const std::string& prefix) const {
    std::string p = prefix + ".";
    for (const auto& [k, e] : entries_)
        if (k.rfind(p, 0) == 0) e.used = true;
}

void Params::markUsed(const std::string& key) const {
    auto it = entries_.find(key);
    if (it != entries_.end()) it->second.used = true;
}

std::vector<std::string> Params::unusedKeys() const {
    std::vector<std::string> out;
    for (const auto& [k, e] : entries_)
        if (!e.used) out.push_back(k);
    return out;
}

void Params::reportUnused() const {
    for (const auto& [k, e] : entries_) {
        if (e.used) continue;
        // The near keys among those read (their readers declared them):
        // "hr.epz" -> "did you mean 'oracle.eps'?" (core/suggest.h).
        std::vector<std::string> known;
        for (const auto& r : records()) known.push_back(r.first);
        const std::string hint = didYouMean(nearestKeys(prefix_ + k, known));
        throwInputError(e.where, "unknown setting '{}' (no component reads it{})", prefix_ + k,
                        hint.empty() ? "" : "; " + hint);
    }
}

std::string Params::valueToString(const Value& v) {
    switch (v.index()) {
        case 0: return std::get<bool>(v) ? "true" : "false";
        case 1: return std::to_string(std::get<int64_t>(v));
        case 2: return fmt::format("{}", std::get<double>(v));
        default: return std::get<std::string>(v);
    }
}

std::string Params::toString() const {
    std::string s;
    for (const auto& [k, e] : entries_) s += fmt::format("{} = {}\n", k, valueToString(e.value));
    return s;
}

}  // namespace hrad
