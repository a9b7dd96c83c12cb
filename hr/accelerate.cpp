#include "hr/accelerate.h"

#include <algorithm>
#include <cmath>

#include "core/timer.h"
#include "hr/solver.h"

namespace hrad::hr {

namespace {
// A judging pass that refines at most this share of the links leaves its
// iteration quiet for relaxation and extrapolation (header, "Relaxation" and
// "Extrapolation"): with lazy refinement a slowly brightening scene is judged
// every iteration, and on the bathroom 1 to 56 of 1.4 M links were refined in
// most iterations after the first sixteen, which held both back while its
// reflected power still rose by 0.1 % per iteration.
constexpr double kQuietRefinement = 1e-4;

/// The root patches that carry at least `share` of the change of the last
/// two iterations (A_p max_c |B_p - previous_p| plus `lastChange`_p, the
/// same one iteration earlier, which it updates; two iterations, so that both
/// surfaces of a facing pair whose light alternates between them are
/// found), the fewest that do, when they are at most `fraction` of all root
/// patches; empty otherwise. In index order.
std::vector<uint32_t> concentratedChange(const Hierarchy& h, const std::vector<RGB>& previous,
                                         std::vector<double>& lastChange, double share,
                                         double fraction) {
    const uint32_t np = uint32_t(previous.size());
    const uint32_t most = uint32_t(std::min<double>(fraction * double(np), double(np)));
    std::vector<uint32_t> hot;
    lastChange.resize(np, 0.0);
    std::vector<double> d(np);
    double total = 0.0;
    for (uint32_t p = 0; p < np; ++p) {
        const double now = h.area(p) * maxComponent(glm::abs(h.B(p) - previous[p]));
        d[p] = now + lastChange[p];
        lastChange[p] = now;
        total += d[p];
    }
    if (most == 0) return hot;
    if (!(total > 0.0)) return hot;
    std::vector<uint32_t> idx(np);
    for (uint32_t p = 0; p < np; ++p) idx[p] = p;
    auto larger = [&](uint32_t a, uint32_t b) { return d[a] > d[b] || (d[a] == d[b] && a < b); };
    std::nth_element(idx.begin(), idx.begin() + (most - 1), idx.end(), larger);
    idx.resize(most);
    std::sort(idx.begin(), idx.end(), larger);
    double sum = 0.0;
    for (uint32_t p : idx) {
        hot.push_back(p);
        sum += d[p];
        if (sum >= share * total) break;
    }
    if (sum < share * total) hot.clear();
    std::sort(hot.begin(), hot.end());
    return hot;
}

}  // namespace

IterationAccelerator::IterationAccelerator(const HrSettings& s, const Hierarchy& h)
    : s_(s), np_(h.numPatches()) {
    relaxOn_ = s.relaxShare > 0.0 && h.basisSize() == 1 &&
               uint64_t(s.relaxFraction * double(np_)) > 0;
}

bool IterationAccelerator::quiet(uint64_t refined, uint64_t links) {
    return refined == 0 || double(refined) <= kQuietRefinement * double(links);
}

void IterationAccelerator::relax(Hierarchy& h, bool quiet, IterationRecord& rec,
                                 const RGB& lastReflected) {
    // The change history restarts after a refinement that is not quiet.
    if (!quiet) prevRootChange_.clear();
    if (!relaxOn_ || !quiet || prevRoots_.size() != np_) return;
    std::vector<uint32_t> hot =
        concentratedChange(h, prevRoots_, prevRootChange_, s_.relaxShare, s_.relaxFraction);
    if (hot.empty()) return;
    Timer tx;
    // A tenth of the tolerance, in power (the last iteration's reflected
    // power sets the scale).
    const double target = 0.1 * s_.tolerance * maxComponent(glm::abs(lastReflected));
    Hierarchy::RelaxResult rx =
        h.relax(hot, s_.relaxSweeps, std::max<uint64_t>(h.iterationLinkReads(), 1), target);
    rec.gatherSeconds += tx.seconds();
    if (rx.sweeps == 0) return;
    rec.relaxedPatches = uint32_t(hot.size());
    rec.relaxSweeps = rx.sweeps;
    // A relaxation that did not reach its target leaves the sequence
    // irregular: the tail estimate takes the slowest step of its window, and
    // no extrapolation follows right after it.
    rec.relaxIncomplete = !rx.reached;
    if (rec.relaxIncomplete) sinceExtrapolation_ = 0;
}

RGB IterationAccelerator::extrapolate(Hierarchy& h, bool quiet, IterationRecord& rec,
                                      const RGB& reflectedIn, const RGB& lastReflected) {
    RGB reflected = reflectedIn;
    if (!s_.extrapolate) return reflected;
    RGB change = reflected - lastReflected, ratio(0.0), factor(0.0);
    quietIterations_ = quiet ? quietIterations_ + 1 : 0;
    bool ok = quietIterations_ >= 2 && sinceExtrapolation_ >= 2 &&
              previousB_.size() == h.allB().size();
    for (int c = 0; c < 3; ++c) {
        ratio[c] = lastChange_[c] != 0.0 ? change[c] / lastChange_[c] : 0.0;
        const bool stable = ratio[c] > 0.0 && ratio[c] < 0.99999 &&
                            std::fabs(ratio[c] - lastRatio_[c]) <= 0.05 * ratio[c];
        // A channel whose power no longer changes needs nothing.
        if (change[c] == 0.0) continue;
        if (!stable) ok = false;
        factor[c] = ratio[c] / (1.0 - ratio[c]);
    }
    lastRatio_ = ratio;
    lastChange_ = change;
    ++sinceExtrapolation_;
    if (ok && maxComponent(factor) > 0.0) {
        if (h.basisSize() > 1)
            h.extrapolateLeaves(previousB_, previousHi_, factor);
        else
            h.extrapolateLeaves(previousB_, factor);
        rec.extrapolation = maxComponent(factor);
        sinceExtrapolation_ = 0;
        // The extrapolated state starts a new geometric sequence.
        lastChange_ = h.reflectedPower() - lastReflected;
        lastRatio_ = RGB(0.0);
        reflected = h.reflectedPower();
    }
    previousB_ = h.allB();
    if (h.basisSize() > 1) previousHi_ = h.allHi();
    return reflected;
}

void IterationAccelerator::remember(const Hierarchy& h) {
    if (!relaxOn_) return;
    prevRoots_.resize(np_);
    for (uint32_t p = 0; p < np_; ++p) prevRoots_[p] = h.B(p);
}

}  // namespace hrad::hr
