#include "core/warning_log.h"

#include <fmt/format.h>

#include <algorithm>

namespace hrad {

std::string WarningLog::normalized(const std::string& text) {
    std::string key;
    key.reserve(text.size());
    for (size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (c >= '0' && c <= '9') {
            while (i + 1 < text.size() && text[i + 1] >= '0' && text[i + 1] <= '9') ++i;
            key += '#';
        } else if (c == '\'' || c == '"' || c == '`') {
            const size_t close = text.find(c, i + 1);
            if (close == std::string::npos) {
                key += c;
                continue;
            }
            key += c;
            key += '*';
            key += c;
            i = close;
        } else {
            key += c;
        }
    }
    return key;
}

void WarningLog::refreshLine(size_t i) {
    const Entry& e = entries_[i];
    std::string also;
    for (size_t k = 1; k < e.examples.size(); ++k) also += (k > 1 ? "; " : "; also ") + e.examples[k];
    lines_[i] = e.count > 1 ? fmt::format("{} ({} times in all{})", e.examples.front(), e.count, also)
                            : e.examples.front();
}

void WarningLog::add(const std::string& key, const std::string& text) {
    addCounted(key, text, 1);
}

void WarningLog::addCounted(const std::string& key, const std::string& text, uint64_t n) {
    total_ += n;
    auto it = index_.find(key);
    if (it == index_.end()) {
        if (entries_.size() >= kDistinct) {
            overflow_ += n;
            if (lines_.size() == entries_.size()) lines_.emplace_back();  // the closing line
            lines_.back() = fmt::format("... and {} more warnings not kept (more than {} kinds)",
                                        overflow_, kDistinct);
            return;
        }
        it = index_.emplace(key, entries_.size()).first;
        entries_.emplace_back();
        lines_.emplace_back();
    }
    Entry& e = entries_[it->second];
    e.count += n;
    // Examples differ from one another: a repeat of the same text is only counted.
    if (e.examples.size() < kExamples &&
        std::find(e.examples.begin(), e.examples.end(), text) == e.examples.end())
        e.examples.push_back(text);
    refreshLine(it->second);
}

void WarningLog::merge(const WarningLog& other) {
    for (const Entry& e : other.entries_) {
        const std::string key = normalized(e.examples.front());
        addCounted(key, e.examples.front(), e.count - (e.examples.size() - 1));
        for (size_t k = 1; k < e.examples.size(); ++k) addCounted(key, e.examples[k], 1);
    }
    if (other.overflow_ > 0)
        addCounted("\x01overflow", "warnings of other kinds", other.overflow_);
}

size_t WarningLog::memoryBytes() const {
    size_t bytes = sizeof(*this) + entries_.capacity() * sizeof(Entry) +
                   lines_.capacity() * sizeof(std::string);
    for (const Entry& e : entries_) {
        bytes += e.examples.capacity() * sizeof(std::string);
        for (const std::string& x : e.examples) bytes += x.capacity();
    }
    for (const std::string& l : lines_) bytes += l.capacity();
    for (const auto& [k, v] : index_) bytes += k.capacity() + sizeof(k) + sizeof(v) + 2 * sizeof(void*);
    return bytes;
}

}  // namespace hrad
