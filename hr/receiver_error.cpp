#include "hr/receiver_error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <unordered_map>
#include <utility>

namespace hrad::hr {

namespace {
/// The samples `eval(r, s, out)` writes for the link s -> r, packed.
template <class Eval>
KernelSamples linkSamplesBy(const Hierarchy& h, uint32_t r, uint32_t s, Eval eval) {
    static_assert(transport::FormFactorEngine::kMaxKernelSamples <= KernelSamples::kCount);
    transport::ElementRef er{h.patch(r), h.domain(r), h.stableId(r)};
    transport::ElementRef es{h.patch(s), h.domain(s), h.stableId(s)};
    double vals[transport::FormFactorEngine::kMaxKernelSamples];
    int m = eval(er, es, vals);
    return KernelSamples(vals, m);
}
}  // namespace

void leafRanges(const Hierarchy& h, LeafRanges& out) {
    // Children are created after their parents, so one pass from the last
    // element to the first sees every child before its parent; a surface
    // element's four children are consecutive.
    const uint32_t n = h.numElements();
    out.lo.assign(n, RGB(0.0));
    out.hi.assign(n, RGB(0.0));
    for (uint32_t e = n; e-- > 0;) {
        if (h.isCluster(e) || h.patch(e) == kNone) continue;
        const uint32_t fc = h.firstChild(e);
        if (fc == kNone) {
            out.lo[e] = out.hi[e] = h.B(e);
            continue;
        }
        RGB lo(1e300), hi(-1e300);
        for (uint32_t k = fc; k < fc + 4; ++k) {
            lo = glm::min(lo, out.lo[k]);
            hi = glm::max(hi, out.hi[k]);
        }
        out.lo[e] = lo;
        out.hi[e] = hi;
    }
}

namespace {
/// `given`, or leafRanges() of h computed into `own`.
const LeafRanges& rangesOf(const Hierarchy& h, const LeafRanges* given, LeafRanges& own) {
    if (given) return *given;
    leafRanges(h, own);
    return own;
}
}  // namespace

void senderTotals(const Hierarchy& h, const std::vector<uint32_t>& pendingRecv,
                  const std::vector<Link>& pending, const std::vector<uint32_t>& acceptedRecv,
                  const std::vector<Link>& accepted, std::vector<SenderTotal>& out,
                  const LeafRanges* ranges) {
    const uint32_t n = h.numElements();
    LeafRanges ownRanges;
    const LeafRanges& lr = rangesOf(h, ranges, ownRanges);
    const std::vector<RGB>& lo = lr.lo;
    const std::vector<RGB>& hi = lr.hi;
    auto term = [&](uint32_t r, const Link& l) -> double {
        const uint32_t s = l.sender;
        if (h.isCluster(r) || s == kNone || h.isCluster(s) || (l.flags & Link::kOpen) ||
            h.firstChild(s) == kNone)
            return -1.0;
        const RGB spread = glm::max(hi[s] - h.B(s), h.B(s) - lo[s]);
        return h.area(r) * double(l.K) * maxComponent(h.rho(r) * spread);
    };
    std::vector<double> total(n, 0.0);
    std::vector<uint32_t> count(n, 0);
    // Per pending link that carriesKernelSamples() (the only ones term()
    // can evaluate), its term and its sender.
    std::vector<float> own;
    std::vector<uint32_t> ownSender;
    // Only the totals of the senders of those links are read: the accepted
    // links of other senders (most of them, after the first round of a
    // pass) are skipped before their terms are made.
    std::vector<uint8_t> needed(n, 0);
    for (size_t i = 0; i < pending.size(); ++i) {
        const uint32_t s = pending[i].sender;
        if (s < n && h.carriesKernelSamples(pendingRecv[i], pending[i])) needed[s] = 1;
    }
    auto add = [&](const std::vector<uint32_t>& recv, const std::vector<Link>& links, bool keep) {
        for (size_t i = 0; i < links.size(); ++i) {
            if (!keep && !(links[i].sender < n && needed[links[i].sender])) continue;
            double t = term(recv[i], links[i]);
            if (keep && h.carriesKernelSamples(recv[i], links[i])) {
                own.push_back(float(t));
                ownSender.push_back(links[i].sender);
            }
            if (t > 0.0) {
                total[links[i].sender] += t;
                ++count[links[i].sender];
            }
        }
    };
    add(acceptedRecv, accepted, false);
    add(pendingRecv, pending, true);
    out.assign(own.size(), SenderTotal{});
    for (size_t k = 0; k < own.size(); ++k) {
        if (own[k] < 0.f) continue;
        const uint32_t s = ownSender[k];
        out[k] = SenderTotal{float(total[s]), own[k], count[s]};
    }
}

KernelSamples linkKernelSamples(const Hierarchy& h, const transport::FormFactorEngine& engine,
                                uint32_t r, uint32_t s) {
    return linkSamplesBy(h, r, s, [&](const auto& er, const auto& es, double* v) {
        return engine.kernelSamples(er, es, v);
    });
}

KernelSamples linkResidualSamples(const Hierarchy& h, const transport::CouplingEngine& coupling,
                                  uint32_t r, uint32_t s) {
    return linkSamplesBy(h, r, s, [&](const auto& er, const auto& es, double* v) {
        return coupling.residualSamples(er, es, v);
    });
}

namespace {

/// The surface links of the receivers receiverErrors() evaluates, pending
/// (code 2i + 1) and accepted (code 2i), in CSR form by receiver, each with
/// the index of its samples (kNoSamples where none are stored) and, for a
/// pending link, of its entry in the output.
struct ReceiverItems {
    static constexpr uint64_t kNoSamples = ~uint64_t(0);
    std::vector<uint8_t> wanted;
    std::vector<uint64_t> offset, items, itemSamples, itemOut;
};

bool surfaceLinkOf(const Hierarchy& h, uint32_t r, const Link& l) {
    return !h.isCluster(r) && l.sender != kNone && !h.isCluster(l.sender) &&
           !(l.flags & Link::kOpen);
}

ReceiverItems collectReceiverItems(const Hierarchy& h, const std::vector<uint32_t>& pendingRecv,
                                   const std::vector<Link>& pending,
                                   const std::vector<KernelSamples>& pendingSamples,
                                   const std::vector<uint32_t>& acceptedRecv,
                                   const std::vector<Link>& accepted,
                                   const std::vector<KernelSamples>& acceptedSamples,
                                   bool compute) {
    ReceiverItems it;
    const size_t np = pending.size();
    const uint32_t n = h.numElements();
    // Receivers to evaluate: those with a pending surface link; without
    // `compute` (refinement), only those with one that either end's
    // subdivision could refine (no decision reads the others).
    it.wanted.assign(n, 0);
    for (size_t i = 0; i < np; ++i)
        if (surfaceLinkOf(h, pendingRecv[i], pending[i]) &&
            (compute || h.canSubdivide(pendingRecv[i]) || h.canSubdivide(pending[i].sender)))
            it.wanted[pendingRecv[i]] = 1;
    // Counting sort by receiver, stable.
    it.offset.assign(size_t(n) + 1, 0);
    auto count = [&](const std::vector<uint32_t>& recv, const std::vector<Link>& links) {
        for (size_t i = 0; i < links.size(); ++i)
            if (it.wanted[recv[i]] && surfaceLinkOf(h, recv[i], links[i])) ++it.offset[recv[i] + 1];
    };
    count(acceptedRecv, accepted);
    count(pendingRecv, pending);
    for (uint32_t e = 0; e < n; ++e) it.offset[e + 1] += it.offset[e];
    // Samples are stored only for the links that storesKernelSamples(), in
    // link order; outputs one per pending link that carriesKernelSamples().
    it.items.resize(it.offset[n]);
    it.itemSamples.resize(it.offset[n]);
    it.itemOut.resize(it.offset[n]);
    std::vector<uint64_t> fill(it.offset.begin(), it.offset.end() - 1);
    auto place = [&](const std::vector<uint32_t>& recv, const std::vector<Link>& links,
                     const std::vector<KernelSamples>& samples, uint64_t tag) {
        const bool stored = !(samples.empty() && compute);
        uint64_t k = 0, ks = 0;
        for (size_t i = 0; i < links.size(); ++i) {
            if (!h.carriesKernelSamples(recv[i], links[i])) continue;
            const bool has = stored && h.storesKernelSamples(recv[i], links[i]);
            if (it.wanted[recv[i]] && surfaceLinkOf(h, recv[i], links[i])) {
                const uint64_t j = fill[recv[i]]++;
                it.items[j] = 2 * uint64_t(i) + tag;
                it.itemSamples[j] = has ? ks : ReceiverItems::kNoSamples;
                it.itemOut[j] = k;
            }
            ++k;
            ks += has ? 1 : 0;
        }
        HRAD_CHECK(ks == samples.size());
    };
    place(acceptedRecv, accepted, acceptedSamples, 0);
    place(pendingRecv, pending, pendingSamples, 1);
    return it;
}

/// What receiverErrors() reads, for one receiver's evaluation.
struct ReceiverInputs {
    const Hierarchy& h;
    const std::vector<Link>& pending;
    const std::vector<KernelSamples>& pendingSamples;
    const std::vector<Link>& accepted;
    const std::vector<KernelSamples>& acceptedSamples;
    const ReceiverItems& it;
    const LeafRanges& lr;
    bool residualSamples;
    const SampleFn& compute;
};

/// The aggregate of receiver r's links, written to the entries of its
/// pending links in `out`. linkDev and linkSend are scratch.
void evaluateReceiver(const ReceiverInputs& in, uint32_t r, std::vector<float>& linkDev,
                      std::vector<float>& linkSend, std::vector<ReceiverError>& out) {
    constexpr int K = transport::FormFactorEngine::kMaxKernelSamples;
    const Hierarchy& h = in.h;
    const ReceiverItems& it = in.it;
    const RGB rho = h.rho(r);
    // Triangles have 7 sample points, quads 9 (kernelSamplePoints).
    const int m = h.scene().patches[h.patch(r)].kind == scene::PatchKind::Quad ? 9 : 7;
    RGB D[K];
    for (auto& d : D) d = RGB(0.0);
    RGB unsignedPart(0.0), senderSum(0.0);
    uint64_t b = it.offset[r], e = it.offset[r + 1];
    linkDev.assign(e - b, 0.f);
    linkSend.assign(e - b, 0.f);
    for (uint64_t j = b; j < e; ++j) {
        uint64_t code = it.items[j];
        const Link& l = (code & 1) ? in.pending[code >> 1] : in.accepted[code >> 1];
        const uint32_t s = l.sender;
        // The link's samples: stored, computed now, or none (a receiver that
        // cannot subdivide, judged by nothing here). A link without light
        // has zero samples, stored or not (the solver makes none for it).
        KernelSamples computed;
        const KernelSamples* vals = nullptr;
        if (it.itemSamples[j] != ReceiverItems::kNoSamples)
            vals = (code & 1) ? &in.pendingSamples[it.itemSamples[j]]
                              : &in.acceptedSamples[it.itemSamples[j]];
        else if (in.compute) {
            if (l.K > 0) computed = in.compute(r, s);
            vals = &computed;
        }
        // The judged visibility (hr.judge_visibility) and the unoccluded
        // form factor.
        double v = l.vis();
        double Fu = h.unoccludedF(l);
        RGB w = rho * h.B(s) * v;  // rho_r B_s v per channel
        double dev = 0.0, wmax = maxComponent(w);
        // Kernel samples less the link's constant; residual samples are
        // already less the link's polynomial.
        if (vals) {
            const double base = (in.residualSamples ? 0.0 : Fu) - vals->mean();
            const double step = vals->step();
            for (int k = 0; k < m; ++k) {
                double d = vals->deviation(k) * step - base;
                D[k] += w * d;
                dev = std::max(dev, wmax * std::fabs(d));
            }
        }
        if (l.flags & Link::kPartial) {
            // Where the shadow falls on the receiver is unknown: the link's
            // whole transfer may be misplaced. It is bounded with the
            // unoccluded F, not with K (K judged by its own visibility
            // estimate would be biased low among the links kept).
            RGB t = rho * h.B(s) * Fu;
            unsignedPart += t;
            dev += maxComponent(t);
        }
        linkDev[j - b] = float(dev);
        // The sender's own error bound: its average against the extremes of
        // its leaves (any part of it may be the part the receiver sees).
        const RGB sp =
            rho * double(l.K) * glm::max(in.lr.hi[s] - h.B(s), h.B(s) - in.lr.lo[s]);
        senderSum += sp;
        linkSend[j - b] = float(maxComponent(sp));
    }
    double rangeMax = 0.0, devMax = 0.0;
    for (int c = 0; c < 3; ++c) {
        double lo = 1e300, hi = -1e300, dv = 0.0;
        for (int k = 0; k < m; ++k) {
            lo = std::min(lo, D[k][c]);
            hi = std::max(hi, D[k][c]);
            dv = std::max(dv, std::fabs(D[k][c]));
        }
        if (m == 0) lo = hi = 0.0;
        rangeMax = std::max(rangeMax, hi - lo + unsignedPart[c]);
        devMax = std::max(devMax, dv + unsignedPart[c]);
    }
    for (uint64_t j = b; j < e; ++j) {
        if (!(it.items[j] & 1)) continue;
        ReceiverError& o = out[it.itemOut[j]];
        o.range = float(rangeMax);
        o.deviation = float(devMax);
        o.linkDeviation = linkDev[j - b];
        o.links = uint32_t(e - b);
        o.senderSum = float(maxComponent(senderSum));
        o.linkSender = linkSend[j - b];
    }
}

}  // namespace

void receiverErrors(const Hierarchy& h, const std::vector<uint32_t>& pendingRecv,
                    const std::vector<Link>& pending,
                    const std::vector<KernelSamples>& pendingSamples,
                    const std::vector<uint32_t>& acceptedRecv, const std::vector<Link>& accepted,
                    const std::vector<KernelSamples>& acceptedSamples,
                    std::vector<ReceiverError>& out, bool residualSamples, const SampleFn& compute,
                    const LeafRanges* ranges) {
    size_t carriers = 0;
    for (size_t i = 0; i < pending.size(); ++i)
        carriers += h.carriesKernelSamples(pendingRecv[i], pending[i]);
    out.assign(carriers, ReceiverError{});
    const ReceiverItems it =
        collectReceiverItems(h, pendingRecv, pending, pendingSamples, acceptedRecv, accepted,
                             acceptedSamples, bool(compute));
    LeafRanges ownRanges;
    const LeafRanges& lr = rangesOf(h, ranges, ownRanges);
    const ReceiverInputs in{h,  pending, pendingSamples, accepted, acceptedSamples,
                            it, lr,      residualSamples, compute};
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, h.numElements(), 64),
                      [&](const auto& range) {
                          std::vector<float> linkDev, linkSend;
                          for (uint32_t r = range.begin(); r != range.end(); ++r)
                              if (it.wanted[r]) evaluateReceiver(in, r, linkDev, linkSend, out);
                      });
}

namespace {

/// The surface links of `links` by receiver (CSR): items[offset[r] ..
/// offset[r + 1]) are the indices of r's links that carry light.
struct LinksByReceiver {
    std::vector<uint64_t> offset, items;
    /// With stored samples: the index in them of link i's, or kNoSample.
    static constexpr uint64_t kNoSample = ~uint64_t(0);
    std::vector<uint64_t> sampleOf;
    LinksByReceiver(const Hierarchy& h, const std::vector<uint32_t>& recv,
                    const std::vector<Link>& links,
                    const std::vector<KernelSamples>* stored = nullptr) {
        if (stored && !stored->empty()) {
            sampleOf.assign(links.size(), kNoSample);
            uint64_t k = 0;
            for (size_t i = 0; i < links.size(); ++i)
                if (h.storesKernelSamples(recv[i], links[i])) sampleOf[i] = k++;
            HRAD_CHECK(k == stored->size());
        }
        const uint32_t n = h.numElements();
        auto surfaceLink = [&](uint32_t r, const Link& l) {
            return !h.isCluster(r) && l.sender != kNone && !h.isCluster(l.sender) &&
                   !(l.flags & Link::kOpen) && l.K > 0;
        };
        offset.assign(size_t(n) + 1, 0);
        for (size_t i = 0; i < links.size(); ++i)
            if (surfaceLink(recv[i], links[i])) ++offset[recv[i] + 1];
        for (uint32_t e = 0; e < n; ++e) offset[e + 1] += offset[e];
        items.resize(offset[n]);
        std::vector<uint64_t> fill(offset.begin(), offset.end() - 1);
        for (size_t i = 0; i < links.size(); ++i)
            if (surfaceLink(recv[i], links[i])) items[fill[recv[i]]++] = i;
    }
};

/// One leaf's errors (leafAverageError): e, the push of its ancestors'
/// links to its average, and, with `points`, D at its kernel sample points
/// with its own links too (without it D holds the ancestors' part only and
/// the leaf's own links are not evaluated), with the Simpson weights of
/// those points. `part(A, eA)` is called for every strict surface ancestor
/// A with links, with its part.
struct LeafError {
    RGB e{0.0};
    RGB D[KernelSamples::kCount];
    double w[KernelSamples::kCount];
    int m = 0;
};
template <class Part>
LeafError leafError(const Hierarchy& h, const LinksByReceiver& by, const std::vector<Link>& links,
                    const transport::FormFactorEngine& engine, uint32_t L, bool points, Part&& part,
                    const std::vector<KernelSamples>* stored = nullptr) {
    LeafError out;
    const scene::Patch& P = h.scene().patches[h.patch(L)];
    const bool quad = P.kind == scene::PatchKind::Quad;
    // The leaf's sample points, once for all the senders.
    Vec3 x[transport::FormFactorEngine::kMaxKernelSamples];
    const int m = engine.kernelSamplePoints({h.patch(L), h.domain(L), h.stableId(L)}, x);
    double F[transport::FormFactorEngine::kMaxKernelSamples];
    // Tensor Simpson on a parallelogram (corners 1, edge midpoints 4,
    // centroid 16, over 36) and its triangle counterpart (3, 8, 27 over 60),
    // in kernelSamplePoints' order: corner i, midpoint of edge i, ..., centroid.
    out.m = m;
    HRAD_CHECK(m == (quad ? 9 : 7));
    for (int k = 0; k < out.m; ++k)
        out.w[k] = k == out.m - 1
                       ? (quad ? 16.0 / 36 : 27.0 / 60)
                       : ((k & 1) ? (quad ? 4.0 / 36 : 8.0 / 60) : (quad ? 1.0 / 36 : 3.0 / 60));
    for (auto& d : out.D) d = RGB(0.0);
    for (uint32_t A = points ? L : h.parent(L); A != kNone && !h.isCluster(A); A = h.parent(A)) {
        if (by.offset[A + 1] == by.offset[A]) continue;
        RGB eA(0.0);
        for (uint64_t j = by.offset[A]; j < by.offset[A + 1]; ++j) {
            const uint64_t i = by.items[j];
            const Link& l = links[i];
            // The leaf's own links carry their samples where stored (the
            // same points, the same sender).
            const bool own = A == L && !by.sampleOf.empty() && by.sampleOf[i] != by.kNoSample;
            if (own) {
                const KernelSamples& ks = (*stored)[by.sampleOf[i]];
                for (int k = 0; k < m; ++k) F[k] = ks[k];
            } else {
                const uint32_t s = l.sender;
                engine.kernelSamplesAt(x, m, P.normal, {h.patch(s), h.domain(s), h.stableId(s)}, F);
            }
            // K = v F_l, v the visibility K carries.
            const double v = h.carriedVisibility(l), K = double(l.K);
            const RGB B = h.B(l.sender);
            double mean = 0.0;
            for (int k = 0; k < m; ++k) {
                mean += out.w[k] * F[k];
                out.D[k] += B * (v * F[k] - K);
            }
            eA += B * (v * mean - K);
        }
        if (A != L) {
            out.e += eA;
            part(A, eA);
        }
    }
    return out;
}

}  // namespace

LeafErrorTotals leafErrorTotals(const Hierarchy& h, const std::vector<uint32_t>& recv,
                                const std::vector<Link>& links,
                                const transport::FormFactorEngine& engine, bool points,
                                const std::vector<KernelSamples>* stored,
                                std::vector<double>* shares) {
    const LinksByReceiver by(h, recv, links, points ? stored : nullptr);
    // Per chunk of elements, added in chunk order (deterministic); a chunk's
    // leaves share most of their ancestors, whose shares it sums first.
    const uint32_t n = h.numElements(), chunk = 256;
    const uint32_t chunks = (n + chunk - 1) / chunk;
    std::vector<double> avg(chunks, 0.0), point(chunks, 0.0);
    std::vector<std::vector<std::pair<uint32_t, double>>> parts(shares ? chunks : 0);
    tbb::parallel_for(uint32_t(0), chunks, [&](uint32_t c) {
        std::unordered_map<uint32_t, double> local;
        for (uint32_t L = c * chunk; L < std::min(n, (c + 1) * chunk); ++L) {
            if (h.isCluster(L) || !h.isLeaf(L)) continue;
            const RGB rho = h.rho(L);
            const double area = h.area(L);
            const LeafError le = leafError(
                h, by, links, engine, L, points,
                [&](uint32_t A, const RGB& eA) {
                    if (shares && h.canSubdivide(A))
                        local[A] += area * std::fabs(luminance(rho * eA));
                },
                points ? stored : nullptr);
            avg[c] += area * std::fabs(luminance(rho * le.e));
            if (points) {
                double p = 0.0;
                for (int k = 0; k < le.m; ++k) p += le.w[k] * std::fabs(luminance(rho * le.D[k]));
                point[c] += area * p;
            }
        }
        if (shares) {
            parts[c].assign(local.begin(), local.end());
            std::sort(parts[c].begin(), parts[c].end());
        }
    });
    LeafErrorTotals t;
    for (uint32_t c = 0; c < chunks; ++c) {
        t.leaves += avg[c];
        t.points += point[c];
    }
    if (shares) {
        shares->assign(n, 0.0);
        for (const auto& p : parts)
            for (const auto& [A, v] : p) (*shares)[A] += v;
    }
    return t;
}

double leafAverageError(const Hierarchy& h, const std::vector<uint32_t>& recv,
                        const std::vector<Link>& links, const transport::FormFactorEngine& engine,
                        double* pointwise, const std::vector<KernelSamples>* stored) {
    if (h.basisDegree() > 0) {
        if (pointwise) *pointwise = std::numeric_limits<double>::quiet_NaN();
        return std::numeric_limits<double>::quiet_NaN();
    }
    const LeafErrorTotals t = leafErrorTotals(h, recv, links, engine, true, stored);
    const double reflected = luminance(h.reflectedPower());
    if (pointwise) *pointwise = reflected > 0 ? t.points / reflected : 0.0;
    return reflected > 0 ? t.leaves / reflected : 0.0;
}

double uncoveredLightShare(const Hierarchy& h, const std::vector<uint32_t>& recv,
                           const std::vector<RGB>& light) {
    const std::vector<Link>& links = h.links();
    HRAD_CHECK(light.size() == links.size() && recv.size() == links.size());
    double all = 0.0, out = 0.0;
    for (size_t i = 0; i < links.size(); ++i) {
        const double p = std::fabs(luminance(light[i]));
        all += p;
        const uint32_t s = links[i].sender;
        if (h.isCluster(recv[i]) || (s != kNone && h.isCluster(s))) out += p;
    }
    return all > 0 ? out / all : 0.0;
}

std::vector<uint8_t> leafBudgetMarks(const std::vector<double>& shares, double excess) {
    if (!(excess > 0.0)) return {};
    const uint32_t n = uint32_t(shares.size());
    std::vector<uint32_t> order;
    for (uint32_t A = 0; A < n; ++A)
        if (shares[A] > 0) order.push_back(A);
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
        return shares[a] != shares[b] ? shares[a] > shares[b] : a < b;
    });
    if (order.empty()) return {};
    std::vector<uint8_t> marks(n, 0);
    double covered = 0.0;
    for (uint32_t A : order) {
        if (covered >= excess) break;
        marks[A] = 1;
        covered += shares[A];
    }
    return marks;
}

}  // namespace hrad::hr
