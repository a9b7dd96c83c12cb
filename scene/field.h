// RadiosityField: the one interface through which solutions are compared,
// rendered and exported (DESIGN.md "Data flow").
//
// Every solver (hierarchical, full matrix, Monte Carlo) produces a field that
// is piecewise constant over quadtree elements of the scene's root patches
// (scene/element.h). Because all of them subdivide the same parametric
// domains the same way, the exact average of a field over any element of any
// other field is a sum over nested keys, never a resampling.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <unordered_map>
#include <vector>

#include "scene/basis.h"
#include "scene/element.h"
#include "scene/scene.h"

namespace hrad::scene {

class RadiosityField {
  public:
    virtual ~RadiosityField() = default;
    virtual const Scene& scene() const = 0;
    /// Radiosity of the leaf that contains parametric point (u,v) of `patch`.
    virtual RGB at(uint32_t patch, double u, double v) const = 0;
    /// Exact area-weighted average of the field over element `key` of `patch`.
    virtual RGB average(uint32_t patch, ElementKey key) const = 0;
    /// Calls fn(key, B) for each leaf element of `patch`.
    virtual void forEachLeaf(uint32_t patch,
                             const std::function<void(ElementKey, const RGB&)>& fn) const = 0;

    /// Value at local coordinates (a, b) (scene/element.h domainParam) of leaf
    /// `key` of `patch`, whose value forEachLeaf reported as `leafValue`. A
    /// piecewise constant field returns leafValue; a field with a polynomial
    /// basis on its elements (hr.basis) evaluates the leaf's polynomial, so
    /// exports show it at the elements' corners.
    virtual RGB leafPoint(uint32_t patch, ElementKey key, const RGB& leafValue, double a,
                          double b) const {
        (void)patch, (void)key, (void)a, (void)b;
        return leafValue;
    }

    /// Degree of the polynomial basis on the leaves (scene/basis.h; 0: the
    /// field is piecewise constant and forEachLeaf says all there is).
    virtual int basisDegree() const { return 0; }
    /// A leaf's basis coefficients after the mean (c_1 .. c_{n-1}, n =
    /// basisSize(basisDegree())), written to `out`; what a saved solution
    /// needs besides forEachLeaf's means. Nothing for degree 0.
    virtual void leafHigherCoefficients(uint32_t patch, ElementKey key, RGB* out) const {
        (void)patch, (void)key, (void)out;
    }

    /// Total radiosity power sum_leaves B * A (RGB).
    RGB totalPower() const;

    /// Which reflectance the leaves of textured root patches were solved
    /// with: the patch's texture mean (false: every solver's default) or
    /// each leaf's own (true: hr.texture_rho = element, scene/texture.h
    /// elementRho over the leaf's domain). A leaf's irradiance is then
    /// (B - E) / elementRho, not (B - E) / rho_patch (render/texturing.h
    /// LeafReflectance). Set by whoever runs the solver (experiments/), kept
    /// by LeafField copies and solution files (reference/cache.h).
    bool leafTextureRho() const { return leafTextureRho_; }
    void setLeafTextureRho(bool on) { leafTextureRho_ = on; }

  private:
    bool leafTextureRho_ = false;
};

/// A field on a uniform subdivision: patch i is split to level levels[i]
/// (4^level elements, keys 4^L .. 2*4^L-1, stored contiguously).
class UniformField : public RadiosityField {
  public:
    UniformField(const Scene& scene, std::vector<uint8_t> levels);

    const Scene& scene() const override { return *scene_; }
    RGB at(uint32_t patch, double u, double v) const override;
    RGB average(uint32_t patch, ElementKey key) const override;
    void forEachLeaf(uint32_t patch,
                     const std::function<void(ElementKey, const RGB&)>& fn) const override;

    int level(uint32_t patch) const { return levels_[patch]; }
    size_t numElements() const { return values_.size(); }
    /// Index of the first element of `patch` in the flat arrays.
    size_t offset(uint32_t patch) const { return offsets_[patch]; }
    size_t count(uint32_t patch) const { return offsets_[patch + 1] - offsets_[patch]; }
    RGB& value(size_t index) { return values_[index]; }
    const RGB& value(size_t index) const { return values_[index]; }
    double area(size_t index) const { return areas_[index]; }
    /// Key of element `local` (0-based within its patch).
    ElementKey key(uint32_t patch, size_t local) const {
        return (ElementKey(1) << (2 * levels_[patch])) + local;
    }
    std::vector<RGB>& values() { return values_; }
    const std::vector<RGB>& values() const { return values_; }

  private:
    const Scene* scene_;
    std::vector<uint8_t> levels_;
    std::vector<size_t> offsets_;
    std::vector<RGB> values_;
    std::vector<double> areas_;
};

/// Level per patch so that every element has area <= maxArea (level capped at
/// maxLevel); with maxArea <= 0 every patch gets `level`.
std::vector<uint8_t> uniformLevels(const Scene& scene, int level, double maxArea,
                                   int maxLevel = 12);

/// A field given by an explicit list of leaves per patch (any quadtree cut of
/// each root patch): a copy of another field's leaves, or a solution read
/// back from a file (reference/cache.h loadSolution). Lookups descend the key
/// tree through a hash set of the leaves.
class LeafField final : public RadiosityField {
  public:
    struct Leaf {
        ElementKey key;
        RGB value;  ///< the mean over the leaf (c_0 of its polynomial)
    };
    /// `leaves[p]` must tile patch p exactly (no overlaps, no holes):
    /// checked, hrad::Error otherwise. With `degree` > 0 the leaves carry
    /// polynomials of that degree (scene/basis.h): `higher[p]` holds, leaf
    /// after leaf, the n - 1 coefficients after the mean of each leaf of
    /// patch p (n = basisSize(degree)); evaluation and averages over parts of
    /// a leaf then follow the polynomial, as in the solver's field.
    LeafField(const Scene& scene, std::vector<std::vector<Leaf>> leaves, int degree = 0,
              std::vector<std::vector<RGB>> higher = {});
    /// The leaves of `field` (on the same scene), with their polynomials.
    explicit LeafField(const RadiosityField& field);
    ~LeafField() override;

    const Scene& scene() const override { return *scene_; }
    RGB at(uint32_t patch, double u, double v) const override;
    RGB average(uint32_t patch, ElementKey key) const override;
    void forEachLeaf(uint32_t patch,
                     const std::function<void(ElementKey, const RGB&)>& fn) const override;
    RGB leafPoint(uint32_t patch, ElementKey key, const RGB& leafValue, double a,
                  double b) const override;
    int basisDegree() const override { return degree_; }
    void leafHigherCoefficients(uint32_t patch, ElementKey key, RGB* out) const override;
    const std::vector<Leaf>& leaves(uint32_t patch) const { return leaves_[patch]; }
    size_t numLeaves() const;

  private:
    /// The polynomial of leaf `i` of `patch` at its local coordinates (a, b).
    RGB evaluate(uint32_t patch, size_t i, double a, double b) const;
    /// Index in leaves_[patch] of the leaf equal to or containing `key`, or -1
    /// when `key` is an interior node.
    int64_t leafAtOrAbove(uint32_t patch, ElementKey key) const;
    RGB averageBelow(uint32_t patch, ElementKey key, double* area) const;

    const Scene* scene_;
    std::vector<std::vector<Leaf>> leaves_;
    std::vector<std::unordered_map<ElementKey, uint32_t>> index_;
    int degree_ = 0;
    std::unique_ptr<BasisSet> basis_;       ///< degree_ > 0
    std::vector<std::vector<RGB>> higher_;  ///< per patch, (n - 1) per leaf
};

}  // namespace hrad::scene
