// Accelerating the gather iteration on the hierarchy: Gauss-Seidel relaxation
// of a few root patches (relax, hr.relax_share) and extrapolation of the
// geometric tail (extrapolateLeaves, hr.extrapolate); total powers.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "hr/hierarchy.h"

namespace hrad::hr {

Hierarchy::RelaxResult Hierarchy::relax(const std::vector<uint32_t>& roots, int maxSweeps,
                                        uint64_t linkBudget, double target) {
    HRAD_CHECK(nb_ == 1);
    RelaxResult out;
    if (roots.empty() || maxSweeps <= 0) return out;
    const uint32_t np = numPatches();
    // The local system: the rows below each root, and the clusters above the
    // roots (ancestors), whose radiosities and moments the roots change and
    // whose links hand the roots irradiance.
    std::vector<uint32_t> rows, rowBegin, stack, ancestors;
    uint64_t linksPerSweep = 0;
    for (uint32_t root : roots) {
        rowBegin.push_back(uint32_t(rows.size()));
        stack.assign(1, root);
        while (!stack.empty()) {
            uint32_t e = stack.back();
            stack.pop_back();
            rows.push_back(e);
            linksPerSweep += linkEnd(e) - linkBegin(e);
            if (firstChild_[e] != kNone)
                for (uint32_t c = 0; c < 4; ++c) stack.push_back(firstChild_[e] + c);
        }
        for (uint32_t c = parent_[root]; c != kNone; c = parent_[c]) ancestors.push_back(c);
    }
    rowBegin.push_back(uint32_t(rows.size()));
    std::sort(ancestors.begin(), ancestors.end());
    ancestors.erase(std::unique(ancestors.begin(), ancestors.end()), ancestors.end());
    // By area: clusters gather as a whole; by cosine, links hand each root its share.
    const bool isotropic = !transfer_->receivesByCosine();
    if (isotropic)
        for (uint32_t c : ancestors) linksPerSweep += linkEnd(c) - linkBegin(c);
    else
        for (uint32_t root : roots)  // oriented: every link into an ancestor, per root
            for (uint32_t c = parent_[root]; c != kNone; c = parent_[c])
                linksPerSweep += linkEnd(c) - linkBegin(c);
    std::vector<RGB> down = numClusters_ ? clusterDown() : std::vector<RGB>();
    std::vector<RGB> fromAbove(roots.size(), RGB(0.0));
    std::vector<PushFrame> frames;
    double c1 = 0.0, c2 = 0.0;  // the changes of the last two sweeps
    while (out.sweeps < maxSweeps && out.linkReads + linksPerSweep <= linkBudget) {
        if (!ancestors.empty()) {
            // Clusters above the roots: pull (children first: pre-order
            // indices, so backwards), gather (isotropic clusters gather as a
            // whole), hand down (parents first).
            for (size_t i = ancestors.size(); i-- > 0;) pullCluster(ancestors[i] - np);
            // Isotropic clusters gather as a whole; oriented ones gather
            // only their stand-ins (gatherRow), handed down the same way.
            if (isotropic || hasStandIns_) {
                for (uint32_t c : ancestors) gatherRow(c);
                for (uint32_t c : ancestors) {
                    uint32_t parent = parent_[c];
                    down[c - np] = gathered_[c] + (parent == kNone ? RGB(0.0) : down[parent - np]);
                }
            }
            for (size_t k = 0; k < roots.size(); ++k)
                fromAbove[k] = clusterIrradianceAt(roots[k], down, nullptr);
        }
        // Gauss-Seidel over the roots: each gathers from the radiosities the
        // roots before it have just computed, then pushes and pulls.
        double change = 0.0;
        for (size_t k = 0; k < roots.size(); ++k) {
            for (uint32_t i = rowBegin[k]; i < rowBegin[k + 1]; ++i) gatherRow(rows[i]);
            const RGB before = B_[roots[k]];
            pushPullRoot(roots[k], fromAbove[k], frames);
            change += area_[roots[k]] * maxComponent(glm::abs(B_[roots[k]] - before));
        }
        ++out.sweeps;
        out.linkReads += linksPerSweep;
        // The change still to come: a geometric tail with the rate over two
        // sweeps (a pair of facing surfaces alternates within one).
        bool done = change == 0.0;
        if (out.sweeps >= 3 && c2 > 0.0) {
            double q = std::sqrt(change / c2);
            done = done || (q < 1.0 && change * q / (1.0 - q) < target);
        }
        c2 = c1;
        c1 = change;
        if (done) {
            out.reached = true;
            break;
        }
    }
    if (numClusters_) pullClusters();
    return out;
}

void Hierarchy::extrapolateLeaves(const std::vector<RGB>& previous,
                                  const std::vector<RGB>& previousHi, const RGB& factor) {
    if (nb_ == 1) {
        extrapolateLeaves(previous, factor);
        return;
    }
    HRAD_CHECK(previous.size() == B_.size() && previousHi.size() == hi_.size());
    const uint32_t n = numElements(), np = numPatches(), first = np + numClusters_;
    const size_t m = size_t(nb_ - 1);
    for (uint32_t e = 0; e < n; ++e) {
        if (!isLeaf(e)) continue;
        B_[e] += factor * (B_[e] - previous[e]);
        for (size_t a = 0; a < m; ++a)
            hi_[size_t(e) * m + a] +=
                factor * (hi_[size_t(e) * m + a] - previousHi[size_t(e) * m + a]);
    }
    for (uint32_t e = n; e-- > first;)
        if (firstChild_[e] != kNone) pullPolynomial(e);
    for (uint32_t e = 0; e < np; ++e)
        if (firstChild_[e] != kNone) pullPolynomial(e);
    if (numClusters_) pullClusters();
}

void Hierarchy::extrapolateLeaves(const std::vector<RGB>& previous, const RGB& factor) {
    HRAD_CHECK(previous.size() == B_.size());
    const uint32_t n = numElements(), np = numPatches(), first = np + numClusters_;
    for (uint32_t e = 0; e < n; ++e)
        if (isLeaf(e)) B_[e] += factor * (B_[e] - previous[e]);
    // Pull: sub-elements are allocated after their parents, so a descending
    // sweep sees children before parents; root patches last.
    auto pullOne = [&](uint32_t e) {
        uint32_t fc = firstChild_[e];
        if (fc == kNone) return;
        RGB sum(0.0);
        double a = 0.0;
        for (uint32_t c = fc; c < fc + 4; ++c) {
            sum += area_[c] * B_[c];
            a += area_[c];
        }
        B_[e] = sum / a;
    };
    for (uint32_t e = n; e-- > first;) pullOne(e);
    for (uint32_t e = 0; e < np; ++e) pullOne(e);
    if (numClusters_) pullClusters();
}

RGB Hierarchy::reflectedPower() const {
    RGB s(0.0);
    for (uint32_t e = 0; e < numElements(); ++e)
        if (isLeaf(e)) s += area_[e] * (B_[e] - scene_->patches[patch_[e]].emission);
    return s;
}

RGB Hierarchy::radiosityPower() const {
    RGB s(0.0);
    for (uint32_t e = 0; e < numElements(); ++e)
        if (isLeaf(e)) s += area_[e] * B_[e];
    return s;
}

}  // namespace hrad::hr
