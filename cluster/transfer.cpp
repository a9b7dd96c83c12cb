// The cluster transfer model table: one row per model, from lowercase name
// to the model (cluster/transfer_model.h). `auto` is a name without a model
// of its own (hr/solver.cpp resolves it per scene before the solve).
#include "cluster/transfer.h"

#include <fmt/format.h>

#include <deque>
#include <mutex>

#include "cluster/isotropic_model.h"
#include "cluster/none_model.h"
#include "cluster/oriented_model.h"
#include "core/error.h"

namespace hrad::cluster {

namespace {
struct Row {
    std::string name;
    ClusterModel id;
    const TransferModel* model;  ///< null for auto
};

/// The models are stateless: one instance each serves every solve.
const NoneModel kNoneModel;
const IsotropicModel kIsotropicModel;
const OrientedModel kOrientedModel;

struct Table {
    std::mutex mutex;
    std::deque<Row> rows{
        {"auto", ClusterModel::Auto, nullptr},
        {"none", ClusterModel::None, &kNoneModel},
        {"isotropic", ClusterModel::Isotropic, &kIsotropicModel},
        {"oriented", ClusterModel::Oriented, &kOrientedModel},
    };
    /// Models added by registerTransferModel (tests), owned here.
    std::deque<std::unique_ptr<TransferModel>> added;
};

Table& table() {
    static Table t;
    return t;
}

const Row* find(ClusterModel m) {
    Table& t = table();
    std::lock_guard lock(t.mutex);
    for (const Row& r : t.rows)
        if (r.id == m) return &r;
    return nullptr;
}
}  // namespace

std::vector<std::string> clusterModelNames() {
    Table& t = table();
    std::lock_guard lock(t.mutex);
    std::vector<std::string> names;
    for (const Row& r : t.rows) names.push_back(r.name);
    return names;
}

ClusterModel parseClusterModel(const std::string& name) {
    {
        Table& t = table();
        std::lock_guard lock(t.mutex);
        for (const Row& r : t.rows)
            if (r.name == name) return r.id;
    }
    throw InputError({}, fmt::format("unknown cluster model '{}'; valid: {}", name,
                                     fmt::join(clusterModelNames(), ", ")));
}

const char* clusterModelName(ClusterModel m) {
    const Row* r = find(m);
    return r ? r->name.c_str() : "?";
}

const TransferModel& transferModel(ClusterModel m) {
    const Row* r = find(m);
    HRAD_CHECK(r && r->model);
    return *r->model;
}

ClusterModel registerTransferModel(const std::string& name, std::unique_ptr<TransferModel> model) {
    HRAD_CHECK(model);
    Table& t = table();
    std::lock_guard lock(t.mutex);
    for (const Row& r : t.rows) HRAD_CHECK(r.name != name);
    const auto id = ClusterModel(uint8_t(ClusterModel::Auto) + uint8_t(t.added.size()) + 1);
    t.added.push_back(std::move(model));
    t.rows.push_back({name, id, t.added.back().get()});
    return id;
}

}  // namespace hrad::cluster
