#include "hr/budget.h"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "core/memory.h"
#include "hr/receiver_error.h"
#include "hr/solver.h"

namespace hrad::hr {

bool RefinementBudget::stopForTime(HrResult& res) const {
    if (!outOfTime()) return false;
    if (interruptSignal() != 0) {
        if (!res.interrupted)
            spdlog::warn("signal {} received: refinement and iteration stop; the solution so far "
                         "is written, marked interrupted", interruptSignal());
        res.interrupted = true;
        return true;
    }
    if (!res.timeLimitHit)
        spdlog::warn(
            "hr.max_seconds = {} reached: refinement and iteration stop; the solution so far "
            "is the result",
            s_.maxSeconds);
    res.timeLimitHit = true;
    return true;
}

bool RefinementBudget::linkCapHit(uint64_t kept, uint64_t pending, HrResult& res) const {
    const bool hit = kept + pending > s_.maxLinks;
    if (hit && !res.linkCapHit) {
        res.linkCapHit = true;
        spdlog::warn("hr.max_links = {} reached: refinement stops here", s_.maxLinks);
    }
    return hit;
}

uint64_t RefinementBudget::passPeakBytes(uint64_t links, uint64_t samples,
                                         uint64_t elements) const {
    // A judging pass moves the links out of the hierarchy and keeps them,
    // with their receivers, as pending and as kept side by side (two Links
    // and two receiver indices per link; the kept arrays are reserved to the
    // pending size), and their kernel samples likewise. On top of that, the
    // larger of what the decisions hold (per link: ReceiverError and
    // SenderTotal of the links that carry samples, the misplaced power, the
    // decision; receiverErrors() transiently three 8-byte indices per
    // surface link) and what the new links' round holds (two 8-byte offsets
    // per link); per element the leaf ranges, the aggregates' offsets and
    // totals. setLinks() (the sort into rows) stays below this.
    const uint64_t coupling = couplingBytes_ > 0 ? sizeof(uint32_t) + couplingBytes_ : 0;
    const uint64_t kept = 2 * (sizeof(Link) + sizeof(uint32_t) + coupling);
    const uint64_t decisions = std::max<uint64_t>(
        sizeof(ReceiverError) + sizeof(SenderTotal) + sizeof(double) + 1 + 3 * sizeof(uint64_t),
        2 * sizeof(uint64_t) + 1);
    const uint64_t perElement = 2 * sizeof(RGB) + 2 * sizeof(uint64_t) + sizeof(double) + 8;
    return links * (kept + decisions) + 2 * samples * sizeof(KernelSamples) +
           elements * perElement;
}

bool RefinementBudget::roundFits(const Hierarchy& h, const RoundSize& r, uint64_t fixedBytes,
                                 HrResult& res) const {
    // The hierarchy's own limit (32-bit row offsets), with the round's exact count.
    if (r.kept + r.pending + r.made > Hierarchy::kMaxLinks) {
        if (!res.linkCapHit)
            spdlog::warn("{} links would pass the hierarchy's limit of {}: refinement stops here",
                         r.kept + r.pending + r.made, Hierarchy::kMaxLinks);
        res.linkCapHit = true;
        return false;
    }
    if (s_.memoryBudget == 0) return true;
    // Kernel samples for the new links in the share the links so far carry them.
    const uint64_t newSamples =
        r.samples == 0 ? 0
                       : uint64_t(double(r.made) * double(r.samples) / double(r.kept + r.pending));
    const uint64_t perElement = h.numElements() ? h.elementBytes() / h.numElements() : 64;
    // This round: the kept, the pending and the new links side by side, with
    // the pending links' two offsets; then the next pass over the links kept
    // and made.
    const uint64_t round = (r.kept + r.pending + r.made) * (sizeof(Link) + sizeof(uint32_t)) +
                           r.pending * (2 * sizeof(size_t) + 1) +
                           (r.samples + newSamples) * sizeof(KernelSamples);
    const uint64_t next = passPeakBytes(r.kept + r.made, r.keptSamples + newSamples,
                                        h.numElements() + 4 * r.marked);
    const uint64_t estimate =
        fixedBytes + h.elementBytes() + 4 * r.marked * perElement + std::max(round, next);
    if (estimate <= s_.memoryBudget - s_.memoryBudget / 32) return true;
    if (!res.memoryBudgetHit)
        spdlog::warn(
            "memory.budget_mb = {} reached (refinement would need about {}): refinement stops "
            "here; the solution is coarser than the oracle asks",
            s_.memoryBudget >> 20, formatBytes(estimate));
    res.memoryBudgetHit = true;
    return false;
}

}  // namespace hrad::hr
