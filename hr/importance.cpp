// Importance on the hierarchy (hr/importance.h): sources, the adjoint
// sweeps, the weights.
#include "hr/importance.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/error.h"
#include "hr/hierarchy.h"
#include "scene/element.h"
#include "transport/visibility.h"

namespace hrad::hr {

namespace {

std::string trim(const std::string& s) {
    const size_t a = s.find_first_not_of(" \t");
    if (a == std::string::npos) return "";
    return s.substr(a, s.find_last_not_of(" \t") + 1 - a);
}

uint32_t parsePatchId(const std::string& t, const std::string& item, const SourceLocation& where) {
    char* end = nullptr;
    const unsigned long long v = std::strtoull(t.c_str(), &end, 10);
    if (t.empty() || !end || *end != '\0' || t[0] == '-' || v >= UINT32_MAX)
        throwInputError(where, "hr.importance_regions: '{}': '{}' is not a patch id", item, t);
    return uint32_t(v);
}

void parseItem(const std::string& item, const SourceLocation& where, ImportanceRegions& out) {
    std::istringstream ss(item);
    std::string word;
    ss >> word;
    std::vector<std::string> args;
    for (std::string a; ss >> a;) args.push_back(a);
    if (word == "all" && args.empty()) {
        out.all = true;
    } else if (word == "material" && args.size() == 1) {
        out.materials.push_back(args[0]);
    } else if (word == "patch" && args.size() == 1) {
        const size_t dash = args[0].find('-');
        const uint32_t a = parsePatchId(args[0].substr(0, dash), item, where);
        const uint32_t b =
            dash == std::string::npos ? a : parsePatchId(args[0].substr(dash + 1), item, where);
        if (b < a) throwInputError(where, "hr.importance_regions: '{}': empty range", item);
        out.patchRanges.emplace_back(a, b);
    } else if (word == "box" && args.size() == 6) {
        double v[6];
        for (int k = 0; k < 6; ++k) {
            char* end = nullptr;
            v[k] = std::strtod(args[k].c_str(), &end);
            if (!end || *end != '\0' || !std::isfinite(v[k]))
                throwInputError(where, "hr.importance_regions: '{}': '{}' is not a number", item,
                                args[k]);
        }
        const Vec3 lo(v[0], v[1], v[2]), hi(v[3], v[4], v[5]);
        if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z))
            throwInputError(where, "hr.importance_regions: '{}': the box's first corner must be "
                                   "its lower one", item);
        out.boxes.emplace_back(lo, hi);
    } else {
        throwInputError(where,
                        "hr.importance_regions: '{}' is not 'all', 'material NAME', 'patch N', "
                        "'patch N-M' or 'box x0 y0 z0 x1 y1 z1'",
                        item);
    }
}

/// Visits the top nodes of h: the root cluster, or every root patch.
template <class F>
void forEachTop(const Hierarchy& h, F&& f) {
    if (h.numClusters() > 0)
        f(h.rootCluster());
    else
        for (uint32_t p = 0; p < h.numPatches(); ++p) f(p);
}

/// Pulls leaf densities y up: yhat (area-weighted mean) and rhoY
/// (sum over leaves of rho_l A_l y_l) per node; returns node e's (A yhat, rhoY).
std::pair<double, double> pull(const Hierarchy& h, uint32_t e, const std::vector<double>& y,
                               const std::vector<double>& rho, std::vector<double>& yhat,
                               std::vector<double>& rhoY) {
    const uint32_t nc = h.numChildren(e);
    double ay = 0.0, ry = 0.0;
    if (nc == 0) {
        ay = h.area(e) * y[e];
        ry = rho[e] * ay;
    } else {
        for (uint32_t i = 0; i < nc; ++i) {
            const auto [a, r] = pull(h, h.child(e, i), y, rho, yhat, rhoY);
            ay += a;
            ry += r;
        }
    }
    yhat[e] = h.area(e) > 0 ? ay / h.area(e) : 0.0;
    rhoY[e] = ry;
    return {ay, ry};
}

/// Pushes gathered densities g down: each leaf's new density is its source
/// plus every ancestor's (and its own) gathered density.
void push(const Hierarchy& h, uint32_t e, double above, const std::vector<double>& g,
          const std::vector<double>& y0, std::vector<double>& y) {
    const double here = above + g[e];
    const uint32_t nc = h.numChildren(e);
    if (nc == 0) {
        y[e] = y0[e] + here;
        return;
    }
    for (uint32_t i = 0; i < nc; ++i) push(h, h.child(e, i), here, g, y0, y);
}

}  // namespace

ImportanceRegions ImportanceRegions::parse(const std::string& text, const SourceLocation& where) {
    ImportanceRegions out;
    out.where = where;
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ';')) {
        item = trim(item);
        if (!item.empty()) parseItem(item, where, out);
    }
    return out;
}

const char* importanceModeName(ImportanceSettings::Mode m) {
    switch (m) {
        case ImportanceSettings::Mode::Off: return "off";
        case ImportanceSettings::Mode::Camera: return "camera";
        case ImportanceSettings::Mode::Regions: return "regions";
    }
    return "?";
}

ImportanceSettings ImportanceSettings::fromParams(const Params& p) {
    ImportanceSettings s;
    const std::string mode = p.getEnum(
        {"hr.importance",
         "importance-driven refinement (Smits, Arvo & Salesin 1992; hr/importance.h): off, the "
         "render camera's pixels, or hr.importance_regions"},
        "off", {"off", "camera", "regions"});
    s.mode = mode == "camera" ? Mode::Camera : mode == "regions" ? Mode::Regions : Mode::Off;
    s.where = p.where("hr.importance");
    const std::string regions = p.getString(
        {"hr.importance_regions",
         "the importance's regions: items separated by ';': all, material NAME, patch N, "
         "patch N-M, box x0 y0 z0 x1 y1 z1"},
        "");
    s.regions = ImportanceRegions::parse(regions, p.where("hr.importance_regions"));
    if (s.mode == Mode::Regions && trim(regions).empty())
        throwInputError(s.where, "hr.importance = regions needs hr.importance_regions");
    if (s.mode != Mode::Regions && !trim(regions).empty())
        throwInputError(p.where("hr.importance_regions"),
                        "hr.importance_regions is read only with hr.importance = regions");
    s.pixels = int(p.getInt({"hr.importance_pixels",
                             "hr.importance = camera: the longer side of the importance image "
                             "(one primary ray per pixel)"},
                            256, 4, 8192));
    s.tolerance = p.getDouble({"hr.importance_tolerance",
                               "relative change of the total importance that ends the adjoint's "
                               "sweeps"},
                              1e-6, 0.0, 0.1, true);
    return s;
}

std::vector<ImportanceHit> cameraHits(const scene::Scene& scene,
                                      const transport::Visibility& visibility,
                                      const scene::Camera& camera, int width, int height) {
    // The pinhole of render/camera.h CameraFrame: x right, y down, pixel centres.
    const Vec3 forward = glm::normalize(camera.target - camera.eye);
    Vec3 r = glm::cross(forward, camera.up);
    if (glm::length(r) < 1e-9 * glm::length(camera.up))
        r = glm::cross(forward, std::fabs(forward.y) < 0.9 ? Vec3(0, 1, 0) : Vec3(1, 0, 0));
    const Vec3 right = glm::normalize(r), up = glm::cross(right, forward);
    const double tanHalfY = std::tan(0.5 * camera.fovYDegreesFor(width, height) * kPi / 180.0);
    const double aspect = double(width) / double(height);
    std::vector<ImportanceHit> hits;
    for (int py = 0; py < height; ++py)
        for (int px = 0; px < width; ++px) {
            const double sx = (2.0 * (px + 0.5) / width - 1.0) * tanHalfY * aspect;
            const double sy = (1.0 - 2.0 * (py + 0.5) / height) * tanHalfY;
            const Vec3 d = glm::normalize(forward + sx * right + sy * up);
            const transport::RayHit hit = visibility.intersect(camera.eye, d);
            if (!hit.hit) continue;
            const scene::Patch& patch = scene.patches[hit.patch];
            if (glm::dot(patch.normal, d) >= 0) continue;  // a back face: seen black
            const Vec2 uv = scene::clampToPatchDomain(patch.kind, scene::patchInverse(patch, hit.point));
            hits.push_back({hit.patch, float(uv.x), float(uv.y)});
        }
    return hits;
}

bool ImportanceField::selected(const Hierarchy& h, uint32_t leaf) const {
    const ImportanceRegions& g = s_.regions;
    if (g.all) return true;
    const uint32_t p = h.patch(leaf);
    for (const auto& [a, b] : g.patchRanges)
        if (p >= a && p <= b) return true;
    const scene::Scene& sc = h.scene();
    const scene::Patch& patch = sc.patches[p];
    for (const std::string& m : g.materials)
        if (patch.material < sc.materials.size() && sc.materials[patch.material].name == m)
            return true;
    if (!g.boxes.empty()) {
        const Vec3 c = scene::elementCentroid(patch, h.domain(leaf));
        for (const auto& [lo, hi] : g.boxes)
            if (c.x >= lo.x && c.y >= lo.y && c.z >= lo.z && c.x <= hi.x && c.y <= hi.y &&
                c.z <= hi.z)
                return true;
    }
    return false;
}

std::vector<double> ImportanceField::sources(const Hierarchy& h, bool everything) const {
    std::vector<double> y0(h.numElements(), 0.0);
    const uint32_t first = h.numPatches() + h.numClusters();
    auto surfaceLeaf = [&](uint32_t e) { return (e < h.numPatches() || e >= first) && h.isLeaf(e); };
    if (everything || s_.mode == ImportanceSettings::Mode::Regions) {
        for (uint32_t e = 0; e < h.numElements(); ++e)
            if (surfaceLeaf(e) && (everything || selected(h, e))) y0[e] = 1.0;
        return y0;
    }
    // Camera: each hit's share at the leaf that holds it, as a density.
    const scene::Scene& sc = h.scene();
    for (const ImportanceHit& hit : hits_) {
        uint32_t e = hit.patch;
        while (h.numChildren(e) > 0)
            e = h.child(e, uint32_t(scene::childContaining(sc.patches[hit.patch].kind,
                                                           h.domain(e), hit.u, hit.v)));
        y0[e] += hitScale_;
    }
    for (uint32_t e = 0; e < h.numElements(); ++e)
        if (y0[e] > 0) y0[e] /= h.area(e);
    return y0;
}

std::vector<double> ImportanceField::adjoint(const Hierarchy& h, const std::vector<double>& y0,
                                             const std::vector<uint32_t>& recv,
                                             const std::vector<Link>& links) {
    const uint32_t n = h.numElements();
    std::vector<double> rho(n, 0.0), y = y0, yhat(n, 0.0), rhoY(n, 0.0), g(n, 0.0);
    const uint32_t first = h.numPatches() + h.numClusters();
    for (uint32_t e = 0; e < n; ++e)
        if (e < h.numPatches() || e >= first) rho[e] = luminance(h.rho(e));
    constexpr int kMaxSweeps = 2000;
    for (sweeps_ = 0; sweeps_ < kMaxSweeps; ++sweeps_) {
        forEachTop(h, [&](uint32_t t) { pull(h, t, y, rho, yhat, rhoY); });
        // The transposed gather: link r <- s hands rho_r K_rs A_r yhat_r to s.
        std::fill(g.begin(), g.end(), 0.0);
        for (size_t i = 0; i < links.size(); ++i) {
            const uint32_t s = links[i].sender;
            if (s == kNone || s == recv[i] || !(links[i].K > 0)) continue;
            g[s] += double(links[i].K) * rhoY[recv[i]];
        }
        for (uint32_t e = 0; e < n; ++e) g[e] = h.area(e) > 0 ? g[e] / h.area(e) : 0.0;
        std::vector<double> next(n, 0.0);
        forEachTop(h, [&](uint32_t t) { push(h, t, 0.0, g, y0, next); });
        double change = 0.0, total = 0.0;
        for (uint32_t e = 0; e < n; ++e) {
            change += h.area(e) * std::fabs(next[e] - y[e]);
            total += h.area(e) * next[e];
        }
        y.swap(next);
        if (!(change > s_.tolerance * total)) break;
    }
    forEachTop(h, [&](uint32_t t) { pull(h, t, y, rho, yhat, rhoY); });
    return yhat;
}

void ImportanceField::solve(const Hierarchy& h, const transport::Visibility* visibility,
                            const std::vector<uint32_t>& recv, const std::vector<Link>& links) {
    if (s_.mode == ImportanceSettings::Mode::Camera && !traced_) {
        if (!s_.camera || !visibility)
            throwInputError(s_.where, "hr.importance = camera needs a camera (the render camera: "
                                      "hrad solve or sweep)");
        const double aspect = s_.width > 0 && s_.height > 0 ? double(s_.width) / s_.height : 1.0;
        const int w = aspect >= 1 ? s_.pixels : std::max(1, int(std::lround(s_.pixels * aspect)));
        const int ht = aspect >= 1 ? std::max(1, int(std::lround(s_.pixels / aspect))) : s_.pixels;
        hits_ = cameraHits(h.scene(), *visibility, *s_.camera, w, ht);
        std::vector<uint8_t> seen(h.numPatches(), 0);
        double visibleArea = 0.0;
        for (const ImportanceHit& hit : hits_)
            if (!seen[hit.patch]) {
                seen[hit.patch] = 1;
                visibleArea += h.area(hit.patch);
            }
        if (hits_.empty())
            throwInputError(s_.where, "hr.importance = camera: the camera sees no front face");
        // Mean density 1 over the root patches seen: 1/N per pixel, scaled.
        hitScale_ = visibleArea / double(hits_.size());
        traced_ = true;
    }
    yhat_ = adjoint(h, sources(h, false), recv, links);
    const int sourceSweeps = sweeps_;
    const std::vector<double> uhat = adjoint(h, sources(h, true), recv, links);
    sweeps_ = std::max(sweeps_, sourceSweeps);
    w_.assign(yhat_.size(), 0.0);
    for (size_t e = 0; e < w_.size(); ++e) w_[e] = uhat[e] > 0 ? yhat_[e] / uhat[e] : 0.0;
}

double ImportanceField::weight(const Hierarchy& h, uint32_t e) const {
    while (e >= w_.size() && e != kNone) e = h.parent(e);
    return e == kNone ? 1.0 : w_[e];
}

}  // namespace hrad::hr
