// `kv`: kernel-variation refinement, in the spirit of Bekaert & Willems 1996
// ("Error control for radiosity", EGRW 1996, pp. 153-164).
//
// The paper's text was not available here; this follows the constant-basis
// case of its authors' own implementation (RenderPark's Galerkin radiosity,
// the "deltaK" link error coefficient, citing [BEKA1996]), not the paper's
// general estimate for higher-order bases. With
//     G(x) = A_s * mean_{y in s} cos_x cos_y V(x,y) / (pi |x-y|^2) = F_{dA(x)->s}
// the kernel at receiver point x, a constant link delivering its average F_rs
// varies by
//     dK = max_i |G(x_i) - F_rs| = max(Fmax - F_rs, F_rs - Fmin)
// over the receiver's sample points, and its error estimate is
//     dB = max_c rho_r,c B_s,c dK                   (max over RGB channels)
// times the receiver's importance (1 until computed), accepted when within
// eps (ErrorNorm, oracles/oracle.h): norm = power, A_r dB <= eps * P with P
// the power hr.eps_power names (RenderPark's POWER_ERROR compares with the
// largest emitter's power; the total is used here for the units of `bfa`);
// norm = radiosity, dB <= eps * (largest emitted radiosity) (RenderPark's
// RADIANCE_ERROR). Otherwise the larger element is subdivided (refineLarger,
// as RenderPark does; setting side).
//
// This per-link estimate judges links touching a cluster ([Fmin, Fmax] =
// [0, max(F, Fupper)]). Links between two surfaces are judged by their
// receiver's aggregate (hr/receiver_error.h), kv taking its largest deviation
//     A_r * E_r <= eps * P,   E_r = max_k |D(x_k)|
// where `error` takes the range, so for one receiver kv <= error <= 2 kv; the
// refusal rules are `error`'s (oracles/error_oracle.h).
//
// Settings: oracle.* (`hrad settings oracle.`).
#pragma once

#include "oracles/oracle.h"

namespace hrad::oracles {

class KernelVariationOracle final : public VariationOracle {
  public:
    using VariationOracle::VariationOracle;
    std::string name() const override { return "kv"; }
    double linkError(const LinkEstimate& e) const override;
    double receiverError(const LinkEstimate& e) const override { return e.receiverDeviation; }
};

}  // namespace hrad::oracles
