// The hand-over table (hr/handover.h): one row per hand-over, from the
// lowercase name a transfer model's handOver() gives to its factory.
#include "hr/handover.h"

#include <fmt/format.h>

#include <deque>
#include <mutex>
#include <utility>

#include "core/error.h"
#include "hr/openness_handover.h"

namespace hrad::hr {

namespace {

/// Links hand their light over as the transfer model receives it.
class NoHandOver final : public HandOver {
  public:
    const char* name() const override { return "none"; }
};

struct Table {
    std::mutex mutex;
    std::deque<std::pair<std::string, HandOverFactory>> rows{
        {"none", [](const HandOverContext&) { return std::make_unique<NoHandOver>(); }},
        {"openness", makeOpennessHandOver},
    };
};

Table& table() {
    static Table t;
    return t;
}

}  // namespace

std::vector<std::string> handOverNames() {
    Table& t = table();
    std::lock_guard lock(t.mutex);
    std::vector<std::string> names;
    for (const auto& row : t.rows) names.push_back(row.first);
    return names;
}

std::unique_ptr<HandOver> makeHandOver(const std::string& name, const HandOverContext& ctx) {
    HandOverFactory factory;
    {
        Table& t = table();
        std::lock_guard lock(t.mutex);
        for (const auto& row : t.rows)
            if (row.first == name) factory = row.second;
    }
    // A transfer model named a row that is not there: a bug, not bad input.
    if (!factory)
        throw Error(fmt::format("unknown hand-over '{}'; valid: {}", name,
                                fmt::join(handOverNames(), ", ")));
    return factory(ctx);
}

void registerHandOver(const std::string& name, HandOverFactory factory) {
    HRAD_CHECK(factory);
    Table& t = table();
    std::lock_guard lock(t.mutex);
    for (const auto& row : t.rows) HRAD_CHECK(row.first != name);
    t.rows.emplace_back(name, std::move(factory));
}

}  // namespace hrad::hr
