// Memory accounting: named byte counters and process RSS.
//
// Data structures report the bytes they hold by category ("elements",
// "links", "clusters", "visibility", ...), in the spirit of pbrt-v4's
// STAT_MEMORY_COUNTER, and every result records them together with the
// process peak resident set size read from /proc/self/status.
#pragma once

#include <cstdint>
#include <map>
#include <string>

namespace hrad {

class MemoryCounters {
  public:
    void set(const std::string& category, uint64_t bytes) { bytes_[category] = bytes; }
    void add(const std::string& category, uint64_t bytes) { bytes_[category] += bytes; }
    uint64_t get(const std::string& category) const {
        auto it = bytes_.find(category);
        return it == bytes_.end() ? 0 : it->second;
    }
    uint64_t total() const {
        uint64_t t = 0;
        for (const auto& [k, v] : bytes_) t += v;
        return t;
    }
    const std::map<std::string, uint64_t>& all() const { return bytes_; }

  private:
    std::map<std::string, uint64_t> bytes_;
};

/// Peak resident set size of this process in bytes (VmHWM), 0 if unknown.
uint64_t peakRssBytes();
/// Current resident set size in bytes (VmRSS), 0 if unknown.
uint64_t currentRssBytes();
/// Physical memory of the machine in bytes (sysconf), 0 if unknown.
uint64_t physicalMemoryBytes();
/// "12.3 MiB" style formatting.
std::string formatBytes(uint64_t bytes);

}  // namespace hrad
