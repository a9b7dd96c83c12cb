// HrSettings: every setting of the hierarchical solver (hr.*, with the
// form-factor, cluster and cluster-link settings it hands on), read from
// Params by fromParams. Each key's meaning, default and range is documented
// where it is read (hr/settings.cpp) and listed by `hrad settings hr.`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cluster/link.h"
#include "cluster/transfer.h"
#include "cluster/tree.h"
#include "core/params.h"
#include "hr/eps_power.h"
#include "transport/formfactor.h"

namespace hrad::hr {

struct HrSettings {
    std::string oracle = "bfa";
    Params oracleParams;  ///< the "oracle.*" keys, prefix stripped
    std::vector<double> epsSchedule;
    double minArea = 0.0;
    double minAreaRel = 1e-5;
    int maxLevel = 14;
    int maxIterations = 100;
    int minIterations = 2;
    double tolerance = 1e-4;
    uint64_t maxLinks = 200'000'000;
    double maxSeconds = 0.0;    ///< hr.max_seconds (0: none)
    uint64_t memoryBudget = 0;  ///< bytes (memory.budget_mb; 0 resolved to 80 % of RAM)
    transport::FormFactorSettings ff;
    cluster::ClusterModel clusterModel = cluster::ClusterModel::Auto;
    cluster::ClusterSettings cluster;
    /// hr.sender_total: error and kv also bound the sender-side error summed
    /// per sender over all its receivers (hr/receiver_error.h SenderTotal).
    bool senderTotal = true;
    /// hr.leaf_estimates: compute error_estimate_leaves / _points after the
    /// solve (hr/receiver_error.h leafAverageError).
    bool leafEstimates = true;
    /// hr.leaf_budget: push ancestors' links down while the leaves' error
    /// (hr/receiver_error.h leafBudgetMarks) exceeds the check's eps (Full)
    /// or that eps beyond the error inside the leaves (Balanced).
    enum class LeafBudget { Off, Full, Balanced };

}  // namespace hrad::hr
