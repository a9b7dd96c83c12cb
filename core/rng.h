// Small deterministic random number generation.
//
// PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient
// Statistically Good Algorithms for Random Number Generation"): 64-bit LCG state
// with an xorshift-rotate output permutation. Streams are chosen from ids so
// that sample positions depend only on what is sampled (an element pair, a
// path index), never on thread scheduling.
#pragma once

#include <cstdint>

namespace hrad {

/// 64-bit finaliser (splitmix64 / Stafford's "Mix13"); used to derive seeds.
constexpr uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

constexpr uint64_t hashIds(uint64_t a, uint64_t b) { return mix64(a * 0x100000001b3ULL ^ mix64(b)); }
constexpr uint64_t hashIds(uint64_t a, uint64_t b, uint64_t c) { return hashIds(hashIds(a, b), c); }
/// `base` drawn under a run's seed (hr.seed): `base` itself for seed 0, the
/// house's fixed seeding, else an independent hash of both, so that repeated
/// runs with different seeds draw independent samples.
constexpr uint64_t reseed(uint64_t base, uint64_t seed) {
    return seed ? hashIds(base, seed) : base;
}

class Pcg32 {
  public:
    Pcg32() { seed(0x853c49e6748fea9bULL, 0xda3e39cb94b95bdbULL); }
    explicit Pcg32(uint64_t seedValue, uint64_t stream = 1) { seed(seedValue, stream); }

    void seed(uint64_t seedValue, uint64_t stream) {
        state_ = 0;
        inc_ = (stream << 1u) | 1u;
        nextU32();
        state_ += seedValue;
        nextU32();
    }

    uint32_t nextU32() {
        uint64_t old = state_;
        state_ = old * 6364136223846793005ULL + inc_;
        auto xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
        auto rot = static_cast<uint32_t>(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31u));
    }

    /// Uniform double in [0, 1) with 53 random bits.
    double nextDouble() {
        uint64_t hi = nextU32(), lo = nextU32();
        return static_cast<double>(((hi << 32) | lo) >> 11) * 0x1.0p-53;
    }

  private:
    uint64_t state_ = 0, inc_ = 1;
};

}  // namespace hrad
