#include "core/params.h"

#include "core/parse.h"

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

bool Params::getBool(const std::string& key, bool def) const {
    const Entry* e = find(key);
    if (!e) return def;
    if (auto* b = std::get_if<bool>(&e->value)) return *b;
    throwInputError(e->where, "setting '{}' must be a boolean, got {} '{}'", prefix_ + key,
                    typeName(e->value), valueToString(e->value));
}

int64_t Params::getInt(const std::string& key, int64_t def) const {
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

int64_t Params::getInt(const std::string& key, int64_t def, int64_t lo, int64_t hi) const {
    int64_t v = getInt(key, def);
    if (v < lo || v > hi)
        throwInputError(where(key), "setting '{}' = {} is out of range [{}, {}]", prefix_ + key, v, lo,
                        hi);
    return v;
}

double Params::getDouble(const std::string& key, double def) const {
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

double Params::getDouble(const std::string& key, double def, double lo, double hi,
                         bool loOpen) const {
    double v = getDouble(key, def);
    bool bad = loOpen ? !(v > lo && v <= hi) : !(v >= lo && v <= hi);
    if (bad)
        throwInputError(where(key), "setting '{}' = {} is out of range {}{}, {}]", prefix_ + key, v,
                        loOpen ? "(" : "[", lo, hi);
    return v;
}

std::string Params::getString(const std::string& key, const std::string& def) const {
    const Entry* e = find(key);
    if (!e) return def;
    if (auto* s = std::get_if<std::string>(&e->value)) return *s;
    throwInputError(e->where, "setting '{}' must be a string, got {} '{}'", prefix_ + key,
                    typeName(e->value), valueToString(e->value));
}

std::string Params::getEnum(const std::string& key, const std::string& def,
                            const std::vector<std::string>& allowed) const {
    std::string v = getString(key, def);
    for (const auto& a : allowed)
        if (a == v) return v;
    throwInputError(where(key), "setting '{}' = '{}' is not one of: {}", prefix_ + key, v,
                    fmt::join(allowed, ", "));
}

Params Params::subset(const std::string& prefix) const {
    Params out;
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
    for (const auto& [k, e] : entries_)
        if (!e.used)
            throwInputError(e.where, "unknown setting '{}' (no component reads it)", prefix_ + k);
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
