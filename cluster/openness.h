// How open each surface is towards a sender: the oriented model's hand-over
// of the light a receiving cluster gets to its surfaces (cluster.handover =
// visible; cluster/oriented_model.h).
//
// An oriented receiving cluster hands a link's irradiance to every surface
// below it with that surface's cosine towards the sender (Smits, Arvo &
// Greenberg 1994, sec. 4); the link's visibility is a mean over the
// cluster's surfaces, so a surface hidden inside the cluster (a seat under
// its desk) would get as much as those that hide it. This table gives each
// surface k an openness w_k(u, c) in [0, 1] towards direction u inside
// cluster c: the fraction of M fixed points x_j on the surface from which a
// ray in u's direction bin leaves c's bounding sphere (centre C, radius R)
// without hitting anything, from rays traced once per surface in 16 bins of
// equal solid angle (4 bands uniform in cos theta times 4 sectors), keeping
// the distance to the nearest hit and comparing it with R - (x_j - C).u. One
// table serves every level of the tree. Hand-over then gives surface k
//     K' cos_k(u) w_k(u, c) B_s,   K' = K / W,
//     W = sum_k A_k cos_k(u)+ w_k(u, c) / sum_k A_k cos_k(u)+,
// so the power the link delivers is unchanged and only where it lands moves
// (the receiving side of Sillion 1995's extinction through a cluster's
// volume, measured on the surfaces themselves). Cost: 64 rays and 64 bytes
// per surface (M = 4 points, 16 bins; one byte per distance on a log scale).
// Measurements: papers/notes/2026-12-01-cluster-transfer.md.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "cluster/tree.h"
#include "core/types.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::cluster {

class SurfaceOpenness {
  public:
    static constexpr int kPoints = 4;
    static constexpr int kBands = 4;
    static constexpr int kSectors = 4;
    static constexpr int kBins = kBands * kSectors;

    /// Traces the table for every patch the tree holds (in parallel).
    /// `seed` (hr.seed; 0: the fixed seeding) draws the directions.
    SurfaceOpenness(const scene::Scene& scene, const ClusterTree& tree,
                    const transport::Visibility& visibility, uint64_t seed = 0);

    /// A patch as queries see it: its frame, its fixed points (stratified
    /// on the unit square, mapped by ClusterTree::pointOnPatch) and its row
    /// of quantised distances.
    struct View {
        Vec3 n{0.0}, t{0.0}, b{0.0};
        Vec3 x[kPoints];
        const uint8_t* dist = nullptr;
    };
    View view(uint32_t patch) const;

    /// A patch inside one cluster's sphere: its points relative to the
    /// centre, and the radius (made once per patch and cluster, queried for
    /// every link into the cluster).
    struct Inside {
        Vec3 d[kPoints];
        double radius = 0.0;
    };
    Inside inside(const View& v, const Vec3& center, double radius) const {
        Inside in;
        for (int j = 0; j < kPoints; ++j) in.d[j] = v.x[j] - center;
        in.radius = radius;
        return in;
    }

    /// Openness of a patch towards unit direction u (its cosine with the
    /// normal `cosine`) inside a sphere: the fraction of its points whose ray
    /// in u's bin travels at least R - (x_j - C).u. 0 when u is behind it.
    double openness(const View& v, const Inside& in, const Vec3& u, double cosine) const {
        if (!(cosine > 0)) return 0.0;
        const uint8_t* d = v.dist + bin(v, u, cosine) * kPoints;
        int open = 0;
        for (int j = 0; j < kPoints; ++j)
            open += distance_[d[j]] >= in.radius - glm::dot(in.d[j], u);
        return open * (1.0 / kPoints);
    }

    /// Whether the table's ray from point j in u's bin (its cosine with the
    /// normal `cosine` > 0) travelled at least `reach` before its first hit,
    /// up to the quantisation (the hit's step may reach it). Used as "x_j
    /// sees a point at distance d along u" with reach a fraction of d: the
    /// bin's ray differs from u by up to about 35 degrees, so this tells a
    /// surface hidden right behind another (a shell 2 mm behind a shell) from
    /// one with a clear view, not a sharp shadow.
    bool reaches(const View& v, int j, const Vec3& u, double cosine, double reach) const {
        const uint8_t c = v.dist[bin(v, u, cosine) * kPoints + j];
        return c >= 254 || distance_[c + 1] >= reach;
    }

    uint64_t rays() const { return rays_; }
    double seconds() const { return seconds_; }
    uint64_t memoryBytes() const { return dist_.capacity() * sizeof(uint8_t); }

    /// Bin of a unit direction with cos theta = z > 0 in a frame (t, b, n).
    static int bin(const View& v, const Vec3& u, double z) {
        double x = glm::dot(u, v.t), y = glm::dot(u, v.b);
        int band = z >= 1.0 ? kBands - 1 : int(z * kBands);
        // Sectors of pi/2 counter-clockwise from t (kSectors = 4: the quadrants).
        static_assert(kSectors == 4);
        int sector = y >= 0 ? (x >= 0 ? 0 : 1) : (x < 0 ? 2 : 3);
        return band * kSectors + sector;
    }

  private:
    const scene::Scene* scene_;
    const ClusterTree* tree_;
    /// Per patch (indexed by patch id), kBins x kPoints quantised distances
    /// (quantise()); patches outside the tree stay at 0.
    std::vector<uint8_t> dist_;
    /// The distance each code stands for: the lower end of its step, and
    /// infinity for 255 (no hit within the scene's diagonal).
    double distance_[256];
    uint8_t quantise(bool hit, double t) const;
    uint64_t rays_ = 0;
    double seconds_ = 0.0;
};

}  // namespace hrad::cluster
