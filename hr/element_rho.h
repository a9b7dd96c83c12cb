// Reflectance per element on textured root patches (hr.texture_rho = element).
//
// A textured root patch's rho(x) varies inside it; its elements then carry
// their own reflectance, the area mean of rho(x) over the element's own UV
// footprint (scene/texture.h elementRho: the quadrature the root patch mean
// uses, over the element's domain, clamped as the loader clamps). Root
// elements keep the patch mean (Patch::rho). The table is kept only for
// elements of textured patches, keyed by the first child of each subdivided
// element (children are allocated four at a time): untextured scenes carry
// one byte per root patch and no per-element memory.
//
// How the solve uses it (hr/hierarchy.h, hr/gather.cpp): an element of a
// textured patch gathers irradiance H (no reflectance applied: gatherRow,
// clusterIrradianceToRoots, lightGathered); push-pull pushes H down and sets
// each leaf to B = E + rho_leaf H_leaf (Cohen & Wallace 1993 eq. 2.54 per
// leaf), then pulls area means of B as for every patch. The light a receiver
// reflects of what a link sends is sum over the leaves below it of
// A_l rho_l (Hierarchy::reflectingArea), not A_r rho_r: the leaves reflect.
// Untextured patches are the constant-rho push of DESIGN.md "Push-pull",
// unchanged bit for bit. hr.texture_rho = patch (the default) keeps one rho
// per root patch everywhere (papers/notes/2026-12-02-textures.md).
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "core/types.h"
#include "scene/element.h"
#include "scene/scene.h"

namespace hrad::hr {

class ElementRho {
  public:
    /// Marks the scene's textured root patches (scene/texture.h patchTexture).
    explicit ElementRho(const scene::Scene& scene);
    /// Whether any root patch is textured (else the table stays empty).
    bool any() const { return any_; }
    bool textured(uint32_t patch) const { return any_ && textured_[patch] != 0; }
    /// Computes the reflectance of the four children of an element of a
    /// textured patch p with domain `parent`, stored at `firstChild`.
    void addChildren(uint32_t firstChild, const scene::Patch& p, const scene::Domain& parent);
    /// The reflectance of child `i` (0..3) of the block at `firstChild`.
    const RGB& child(uint32_t firstChild, uint32_t i) const {
        return rho_[size_t(block_.at(firstChild)) * 4 + i];
    }
    /// Bytes held (the per-patch flags, the blocks and their index).
    uint64_t bytes() const;

  private:
    const scene::Scene* scene_;
    std::vector<uint8_t> textured_;                 ///< per root patch
    std::unordered_map<uint32_t, uint32_t> block_;  ///< first child -> block
    std::vector<RGB> rho_;                          ///< four per block
    bool any_ = false;
};

}  // namespace hrad::hr
