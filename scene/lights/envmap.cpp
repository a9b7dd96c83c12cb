// Environment map (Mitsuba 3 `envmap`): radiance at infinity from a
// latitude-longitude (equirectangular) image, times `scale`, turned by
// `to_world` (a rotation; light.h LightSpec).
//
// Mapping (Mitsuba 3's, src/emitters/envmap.cpp, uv_to_direction and the
// plugin reference's "coordinate conventions" figure): a direction d in the
// map's frame has theta = acos(d.y) (the image's top row is +y) and phi =
// atan2(d.x, -d.z); u = phi / 2 pi across the image (u = 0 looks along -z,
// u = 1/4 along +x), v = theta / pi down it; d = (sin phi sin theta,
// cos theta, -cos phi sin theta). World directions are toWorld * d.
// Texels: nearest, each texel (i, j) the constant radiance of the cell
// phi in 2 pi [i, i+1) / W, theta in pi [j, j+1) / H. Mitsuba puts row j's
// centre at v = j / (H - 1) and interpolates bilinearly; here rows are
// centred at (j + 1/2) / H (at most half a texel apart) and constant, so
// the radiance, the sampling density and the closed-form test sums (sum of
// L_ij times the cell's cosine integral) describe the same function.
//
// Sampling (Pharr, Jakob & Humphreys, pbrt-v4 sec. 12.5.2 "Image infinite
// lights", with sec. A.5's 2D piecewise-constant distribution; own code):
// cell (i, j) is drawn with probability lum(L_ij) Omega_ij / F, F = sum of
// lum Omega over all cells, Omega_ij = (2 pi / W)(cos theta_j - cos
// theta_j+1) the cell's solid angle (the exact integral of pbrt's sin theta
// weight over the row), by a marginal over rows and a conditional over the
// row's columns; inside the cell the direction is uniform in solid angle
// (cos theta and phi linear in the remapped u). So pdf(w) = lum(L(w)) / F,
// constant per cell with no 1 / sin theta at the poles, and sample()'s
// value = L(w) / pdf(w) = L(w) F / lum(L(w)): a constant map gives 4 pi L on
// every sample, the `constant` light's value. A map that varies is
// importanceSampled(): the solvers' environment estimates add these
// directions to their cosine ones (transport/light_irradiance.h); a uniform
// map is estimated as the `constant` light is, by cosine directions alone.
//
// power(R): as `constant`'s with the map's solid-angle mean radiance.
// Memory: the decoded texels count against texture.max_mb (scene/texture.h);
// the sampling tables add 8 bytes per texel (double CDFs) that it does not count.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>

#include "scene/lights/light.h"
#include "scene/texture.h"

namespace hrad::scene {

namespace {

class EnvmapLight final : public Light {
  public:
    EnvmapLight(Texture map, double scale, const glm::dmat3& toWorld)
        : map_(std::move(map)),
          scale_(scale),
          toWorld_(toWorld),
          toLocal_(glm::transpose(toWorld)) {
        buildDistribution();
    }
    const char* name() const override { return "envmap"; }
    bool isDelta() const override { return false; }
    bool atInfinity() const override { return true; }

    LightSample sample(const Vec3&, double u1, double u2) const override {
        const int W = map_.width, H = map_.height;
        const int j = pick(rowCdf_.data(), H, u1);
        const int i = pick(&colCdf_[size_t(j) * size_t(W + 1)], W, u2);
        const double c0 = cosTheta(j), c1 = cosTheta(j + 1);
        const double z = c0 + u1 * (c1 - c0), s = std::sqrt(std::max(0.0, 1 - z * z));
        const double phi = 2 * kPi * (i + u2) / W;
        const Vec3 d(std::sin(phi) * s, z, -std::cos(phi) * s);
        const RGB L = texel(i, j);
        return LightSample{toWorld_ * d, std::numeric_limits<double>::infinity(),
                           L * (total_ / luminance(L))};
    }
    RGB radiance(const Vec3& w) const override {
        int i, j;
        cellOf(w, i, j);
        return texel(i, j);
    }
    double pdf(const Vec3& w) const override {
        int i, j;
        cellOf(w, i, j);
        return luminance(texel(i, j)) / total_;
    }
    bool importanceSampled() const override { return varies_; }
    double power(double R) const override { return 4 * kPi * kPi * R * R * maxComponent(mean_); }
    std::string describe() const override {
        return fmt::format(
            "envmap '{}' {} x {}, scale {}, mean L = ({:.4g}, {:.4g}, {:.4g}) W/m^2/sr",
            std::filesystem::path(map_.file).filename().string(), map_.width, map_.height, scale_,
            mean_.r, mean_.g, mean_.b);
    }

  private:
    Texture map_;
    double scale_;
    glm::dmat3 toWorld_, toLocal_;
    std::vector<double> rowCdf_;  ///< H + 1 entries, 0 .. 1
    std::vector<double> colCdf_;  ///< per row W + 1 entries, 0 .. 1 (conditional on the row)
    double total_ = 0;            ///< F = sum lum(L_ij) Omega_ij
    RGB mean_{0.0};               ///< solid-angle mean radiance
    bool varies_ = false;  ///< some texel differs from another (else cosine directions are exact)

    double cosTheta(int j) const { return std::cos(kPi * j / map_.height); }
    double cellSolidAngle(int j) const {
        return 2 * kPi / map_.width * (cosTheta(j) - cosTheta(j + 1));
    }
    RGB texel(int i, int j) const {
        const float* p = &map_.texels[(size_t(j) * size_t(map_.width) + size_t(i)) * 3];
        return scale_ * RGB(p[0], p[1], p[2]);
    }

    /// The cell of world direction w (nearest texel).
    void cellOf(const Vec3& w, int& i, int& j) const {
        const Vec3 d = toLocal_ * w;
        const double len = glm::length(d);
        const double y = len > 0 ? std::clamp(d.y / len, -1.0, 1.0) : 1.0;
        double u = std::atan2(d.x, -d.z) / (2 * kPi);
        if (u < 0) u += 1;
        const double v = std::acos(y) / kPi;
        i = std::clamp(int(u * map_.width), 0, map_.width - 1);
        j = std::clamp(int(v * map_.height), 0, map_.height - 1);
    }

    /// The bin k of a cumulative table cdf[0 .. n] (cdf[0] = 0, cdf[n] = 1)
    /// with cdf[k] <= u < cdf[k+1]; u is remapped to its place in the bin.
    /// Empty bins are never drawn (u = 1 falls back to the last full one).
    static int pick(const double* cdf, int n, double& u) {
        int k = int(std::upper_bound(cdf + 1, cdf + n + 1, u) - (cdf + 1));
        k = std::min(k, n - 1);
        while (k > 0 && cdf[k + 1] == cdf[k]) --k;
        const double lo = cdf[k], hi = cdf[k + 1];
        u = std::clamp((u - lo) / (hi - lo), 0.0, 1.0);
        return k;
    }

    void buildDistribution();
};

void EnvmapLight::buildDistribution() {
    const int W = map_.width, H = map_.height;
    rowCdf_.assign(size_t(H) + 1, 0.0);
    colCdf_.assign(size_t(W + 1) * size_t(H), 0.0);
    RGB sum(0.0);
    for (int j = 0; j < H; ++j) {
        const double omega = cellSolidAngle(j);
        double* cdf = &colCdf_[size_t(j) * size_t(W + 1)];
        double row = 0;
        for (int i = 0; i < W; ++i) {
            const RGB L = texel(i, j);
            row += luminance(L) * omega;
            cdf[i + 1] = row;
            sum += omega * L;
            varies_ = varies_ || L != texel(0, 0);
        }
        for (int i = 1; i <= W && row > 0; ++i) cdf[i] /= row;
        if (row > 0) cdf[W] = 1.0;
        rowCdf_[size_t(j) + 1] = rowCdf_[size_t(j)] + row;
    }
    total_ = rowCdf_.back();
    for (double& c : rowCdf_) c /= total_;
    rowCdf_.back() = 1.0;
    mean_ = sum / (4 * kPi);
}

/// The linear part of to_world as a rotation: orthogonal up to a uniform
/// scale (which does not change directions), else an error.
glm::dmat3 rotationOf(const LightSpec& s) {
    const glm::dmat3& m = s.toWorld;
    const double scale = std::cbrt(std::abs(glm::determinant(m)));
    if (!(scale > 0) || !std::isfinite(scale))
        throwInputError(s.where, "envmap light: to_world is singular");
    const glm::dmat3 r = m / scale;
    const glm::dmat3 e = glm::transpose(r) * r;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            if (std::abs(e[a][b] - (a == b ? 1.0 : 0.0)) > 1e-6)
                throwInputError(s.where,
                                "envmap light: to_world must be a rotation (with at most a uniform "
                                "scale); it shears or scales unevenly");
    return r;
}

}  // namespace

std::shared_ptr<const Light> makeEnvmapLight(const LightSpec& s) {
    if (s.filename.empty()) throwInputError(s.where, "envmap light needs a 'filename'");
    if (!(s.scale > 0) || !std::isfinite(s.scale))
        throwInputError(s.where, "envmap light: scale must be finite and > 0 (it is {})", s.scale);
    const glm::dmat3 rot = rotationOf(s);
    TextureBudget own;
    std::string why;
    // 8/16-bit images are sRGB-decoded as Mitsuba's Bitmap does; HDR and
    // OpenEXR are linear as stored.
    std::optional<Texture> map = decodeTextureFile(s.filename, TextureEncoding::Srgb,
                                                   s.budget ? *s.budget : own, s.where, why);
    if (!map) throwInputError(s.where, "envmap light: cannot read '{}': {}", s.filename, why);
    if (!(maxComponent(map->mean) > 0))
        throwInputError(s.where, "envmap light: '{}' is black (a light that sends nothing)",
                        s.filename);
    return std::make_shared<EnvmapLight>(std::move(*map), s.scale, rot);
}

}  // namespace hrad::scene
