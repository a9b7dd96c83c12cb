#include "render/render.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <sstream>
#include <unordered_map>

#include "core/error.h"
#include "core/log.h"
#include "core/rng.h"
#include "core/log.h"
#include "render/camera.h"
#include "render/texturing.h"
#include "scene/element.h"
#include "transport/light_irradiance.h"

namespace hrad::render {

using scene::Domain;
using scene::ElementKey;
using scene::PatchKind;

namespace {

/// render.eye / target / up / fov: an explicit pinhole camera, or none.
std::optional<scene::Camera> readExplicitCamera(const Params& params,
                                                const std::function<std::string(const char*)>& key) {
    // "x, y, z" -> Vec3; errors at the setting's file:line.
    auto vec = [&](const std::string& k, const std::string& def) {
        std::string text = params.getString(k, def);  // documented below
        std::istringstream in(text);
        Vec3 v(0.0);
        char comma = 0;
        bool ok = bool(in >> v.x) && bool(in >> comma) && comma == ',' && bool(in >> v.y) &&
                  bool(in >> comma) && comma == ',' && bool(in >> v.z);
        in >> std::ws;
        if (!ok || !in.eof() || !std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
            throwInputError(params.where(k), "'{}' = '{}' is not a vector \"x, y, z\"", k, text);
        return v;
    };
    const std::string eyeKey = key("eye"), targetKey = key("target"), upKey = key("up"),
                      fovKey = key("fov");
    // Recorded (with their docs) whether or not the camera is explicit.
    params.getString({eyeKey,
                      "explicit camera: eye position \"x, y, z\" (unset: the scene's camera or an "
                      "automatic one)"},
                     "");
    params.getString({targetKey, "explicit camera: point looked at \"x, y, z\" (with the eye)"},
                     "");
    params.getString({upKey, "explicit camera: up vector \"x, y, z\""}, "0, 1, 0");
    params.getDouble({fovKey, "explicit camera: vertical field of view, degrees"},
                     scene::Camera{}.fovYDegrees, 0.0, 179.0, true);
    if (params.has(eyeKey) != params.has(targetKey))
        throwInputError(params.where(params.has(eyeKey) ? eyeKey : targetKey),
                        "an explicit camera needs both '{}' and '{}'", eyeKey, targetKey);
    if (params.has(eyeKey)) {
        scene::Camera c;
        c.eye = vec(eyeKey, "");
        c.target = vec(targetKey, "");
        c.up = vec(upKey, "0, 1, 0");
        c.fovYDegrees =
            params.getDouble({fovKey, "explicit camera: vertical field of view, degrees"},
                             c.fovYDegrees, 0.0, 179.0, true);
        Vec3 f = c.target - c.eye;
        if (!(glm::length(f) > 0))
            throwInputError(params.where(targetKey), "'{}' equals '{}'", targetKey, eyeKey);
        if (!(glm::length(glm::cross(f, c.up)) > 1e-12 * glm::length(f) * glm::length(c.up)))
            throwInputError(params.where(params.has(upKey) ? upKey : eyeKey),
                            "'{}' is parallel to the view direction (or zero)", upKey);
        return c;
    } else {
        for (const std::string& k : {upKey, fovKey})
            if (params.has(k))
                throwInputError(params.where(k), "'{}' needs an explicit camera ('{}' and '{}')",
                                k, eyeKey, targetKey);
    }
    return std::nullopt;
}

}  // namespace

RenderSettings RenderSettings::fromParams(const Params& params, const std::string& prefix) {
    Params::Scope scope(params, "render");
    const std::function<std::string(const char*)> key = [&](const char* k) {
        return prefix.empty() ? std::string(k) : prefix + "." + k;
    };
    RenderSettings s;
    s.width = int(
        params.getInt({key("width"), "image width in pixels (0: the scene's film or automatic)"},
                      s.width, 1, 32768));
    s.height = int(
        params.getInt({key("height"), "image height in pixels (0: the scene's film or automatic)"},
                      s.height, 1, 32768));
    s.widthSet = params.has(key("width"));
    s.heightSet = params.has(key("height"));
    s.spp = int(params.getInt({key("spp"), "render: samples per pixel"}, s.spp, 1, 65536));
    s.maxSamples = params.getInt(
        {key("max_samples"), "render: width x height x spp at most (a resource bound)"},
        s.maxSamples, 1, int64_t(1) << 40);
    if (params.has(key("max_samples"))) s.budgetWhere = params.where(key("max_samples"));
    else if (params.has(key("spp"))) s.budgetWhere = params.where(key("spp"));
    // Checked before any image is allocated or ray cast: the cost of a render
    // is width x height x spp primary rays.
    int64_t samples = int64_t(s.width) * s.height * s.spp;
    if (samples > s.maxSamples) {
        std::string at = params.has(key("spp")) ? key("spp") : params.has(key("width")) ? key("width") : key("height");
        throwInputError(params.where(at),
                        "{}x{} pixels x {} spp = {} samples, more than {} = {}; lower the size or spp, "
                        "or raise the setting",
                        s.width, s.height, s.spp, samples, key("max_samples"), s.maxSamples);
    }
    s.interpolate = params.getBool(
        {key("interpolate"),
         "render: smooth (C0) vertex radiosity, Gouraud; false: flat elements"},
        s.interpolate);
    const std::string rec =
        params.getEnum({key("reconstruction"),
                        "image reconstruction: interpolated (smooth), flat, final-gather, "
                        "path-traced or lightmap"},
                       s.interpolate ? "interpolated" : "flat",
                       {"flat", "interpolated", "final-gather", "path-traced", "lightmap"});
    // Only an interpolate given explicitly can contradict the reconstruction.
    if (params.has(key("interpolate")) && s.interpolate != (rec == "interpolated") && rec != "lightmap")
        throwInputError(params.where(key("reconstruction")), "'{}' = '{}' contradicts '{}' = {}",
                        key("reconstruction"), rec, key("interpolate"), s.interpolate);
    s.smooth.creaseDegrees = params.getDouble(
        {key("crease_angle"),
         "smooth reconstruction: largest angle (degrees) between the normals of root patches "
         "smoothed across"},
        s.smooth.creaseDegrees, 0.0, 180.0);
    s.reconstruction = rec == "interpolated"   ? Reconstruction::Interpolated
                       : rec == "final-gather" ? Reconstruction::FinalGather
                       : rec == "path-traced"  ? Reconstruction::PathTraced
                       : rec == "lightmap"     ? Reconstruction::Lightmap
                                               : Reconstruction::Flat;
    s.lightmap = LightmapSettings::fromParams(params, prefix);
    s.lightmap.texels = LightmapSettings::Texels::Radiosity;  // what the picture shows
    s.interpolate = s.reconstruction == Reconstruction::Interpolated;
    s.gather.gatherRays =
        int(params.getInt({key("gather_rays"), "render final-gather: gather rays per pixel"},
                          s.gather.gatherRays, 1, 1 << 20));
    s.gather.shadowRays = int(
        params.getInt({key("shadow_rays"), "render final-gather and path-traced: shadow rays per emitter and draws of each importance-sampled environment, per sample"},
                      s.gather.shadowRays, 1, 1 << 16));
    s.gather.seed = uint64_t(params.getInt(
        {key("seed"), "render: seed of final-gather and path-traced rays"}, 0, 0, INT64_MAX));
    s.textures = params.getEnum({key("textures"), kTexturesDoc}, "on", {"on", "off"}) == "on";
    s.gather.textures = s.textures;
    s.textureFilter = params.getEnum({key("texture_filter"), kTextureFilterDoc}, "mip",
                                     {"bilinear", "mip"}) == "mip"
                          ? TextureFilter::Mip
                          : TextureFilter::Bilinear;
    s.backFacesBlack =
        params.getEnum({key("back_faces"), "render: back faces black, or shaded as front faces"},
                       "black", {"black", "front"}) == "black";
    s.backgroundEnvironment =
        params.getEnum({key("background"),
                        "render: what primary rays that hit nothing show: the environment (its "
                        "radiance L as radiosity pi L) or black"},
                       "environment", {"environment", "black"}) == "environment";
    s.camera = readExplicitCamera(params, key);
    return s;
}

void RenderSettings::adoptFilm(const scene::Scene& scene) {
    if (camera || !scene.camera || scene.camera->filmWidth <= 0 || scene.camera->filmHeight <= 0) return;
    if (widthSet && heightSet) return;
    const scene::Camera& c = *scene.camera;
    const double aspect = double(c.filmWidth) / c.filmHeight;
    if (!widthSet && !heightSet) {
        width = c.filmWidth;
        height = c.filmHeight;
    } else if (widthSet) {
        height = int(std::clamp(std::lround(width / aspect), 1L, 32768L));
    } else {
        width = int(std::clamp(std::lround(height * aspect), 1L, 32768L));
    }
    int64_t samples = int64_t(width) * height * spp;
    if (samples > maxSamples)
        throwInputError(budgetWhere.known() ? budgetWhere : c.filmWhere,
                        "{}x{} pixels (from the scene's {}x{} film) x {} spp = {} samples, more than "
                        "render.max_samples = {}; set --width/--height (render.width/height), lower "
                        "render.spp or raise render.max_samples",
                        width, height, c.filmWidth, c.filmHeight, spp, samples, maxSamples);
}

std::string RenderSettings::describe() const {
    std::string cam = "auto";
    if (camera)
        cam = fmt::format("eye=({},{},{}) target=({},{},{}) up=({},{},{}) fov={}", camera->eye.x,
                          camera->eye.y, camera->eye.z, camera->target.x, camera->target.y,
                          camera->target.z, camera->up.x, camera->up.y, camera->up.z,
                          camera->fovYDegrees);
    std::string rec = reconstruction == Reconstruction::FinalGather
                          ? fmt::format(" reconstruction=final-gather gather_rays={} shadow_rays={} seed={}",
                                        gather.gatherRays, gather.shadowRays, gather.seed)
                      : reconstruction == Reconstruction::PathTraced
                          ? fmt::format(" reconstruction=path-traced shadow_rays={} seed={}",
                                        gather.shadowRays, gather.seed)
                      : reconstruction == Reconstruction::Lightmap
                          ? fmt::format(" reconstruction=lightmap lightmap_size={} lightmap_density={}",
                                        lightmap.size, lightmap.density)
                          : std::string();
    return fmt::format("width={} height={} spp={} interpolate={} crease_angle={} back_faces={} "
                       "background={} textures={} texture_filter={} camera={}{}",
                       width, height, spp, interpolate, smooth.creaseDegrees,
                       backFacesBlack ? "black" : "front",
                       backgroundEnvironment ? "environment" : "black", textures ? "on" : "off",
                       textureFilter == TextureFilter::Mip ? "mip" : "bilinear", cam, rec);
}

scene::Camera chooseCamera(const scene::Scene& scene, const transport::Visibility& visibility,
                           const RenderSettings& settings) {
    return settings.camera ? *settings.camera : cameraFor(scene, visibility);
}

namespace {

/// render.background: what a primary ray that hits nothing shows. With an
/// environment shown, every image also records the share of each pixel's
/// samples that hit a surface (Image::surface), so that the automatic
/// exposure and the error maps see the surfaces, not the sky.
class Background {
  public:
    Background(const scene::Scene& scene, const RenderSettings& settings)
        : scene_(scene),
          shown_(settings.backgroundEnvironment && transport::hasEnvironment(scene)) {}
    bool shown() const { return shown_; }
    /// The environment along dir as radiosity: pi L (an image holds B = pi x radiance).
    RGB miss(const Vec3& dir) const {
        return 3.14159265358979323846 * transport::environmentRadiance(scene_, dir);
    }
    void prepare(std::vector<Image>& img) const {
        if (shown_)
            for (Image& i : img) i.surface.assign(i.pixels.size(), 1.0f);
    }
    void record(std::vector<Image>& img, int x, int y, int hits, int spp) const {
        if (shown_)
            for (Image& i : img) i.surface[size_t(y) * size_t(i.width) + size_t(x)] = float(hits) / float(spp);
    }

  private:
    const scene::Scene& scene_;
    bool shown_;
};

/// Final gather / path tracing: parallel over 16 x 16 tiles; every sample's
/// random sequence is seeded by (seed, pixel, sample), so the image does not
/// depend on the tiling or on the threads.
std::vector<Image> renderGathered(const scene::Scene& scene, const transport::Visibility& visibility,
                                  const std::vector<const scene::RadiosityField*>& fields,
                                  const scene::Camera& camera, const RenderSettings& settings) {
    const size_t nf = fields.size();
    const bool path = settings.reconstruction == RenderSettings::Reconstruction::PathTraced;
    Gatherer gatherer(scene, visibility, settings.gather);
    CameraFrame frame(camera, settings.width, settings.height);
    std::vector<Image> img(nf, Image(settings.width, settings.height));
    const Background background(scene, settings);
    background.prepare(img);
    const int spp = settings.spp, tile = 16;
    const int tx = (settings.width + tile - 1) / tile, ty = (settings.height + tile - 1) / tile;
    // Final gather with mip: the texel at the pixel's hit filtered over the
    // camera sample's footprint (texturing.h); the path tracer keeps bilinear.
    std::optional<TextureShading> shading;
    if (!path && settings.textures && settings.textureFilter == TextureFilter::Mip && !scene.textures.empty())
        shading.emplace(scene, TextureFilter::Mip);
    const TextureShading* tex = shading && shading->any() ? &*shading : nullptr;
    const double step = 1.0 / std::sqrt(double(spp));  // as renderFields
    ProgressBar bar(path ? "path tracing" : "final gather", uint64_t(tx) * ty, settings.showProgress);
    tbb::parallel_for(tbb::blocked_range<int>(0, tx * ty, 1), [&](const tbb::blocked_range<int>& r) {
        std::vector<RGB> sum(nf);
        for (int t = r.begin(); t != r.end(); ++t) {
            const int x0 = (t % tx) * tile, y0 = (t / tx) * tile;
            for (int y = y0; y < std::min(y0 + tile, settings.height); ++y)
                for (int x = x0; x < std::min(x0 + tile, settings.width); ++x) {
                    std::fill(sum.begin(), sum.end(), RGB(0.0));
                    const uint64_t pixel = uint64_t(y) * uint64_t(settings.width) + uint64_t(x);
                    int hits = 0;
                    for (int s = 0; s < spp; ++s) {
                        Pcg32 rng(hashIds(settings.gather.seed, pixel, uint64_t(s)));
                        double jx = spp > 1 ? rng.nextDouble() : 0.5;
                        double jy = spp > 1 ? rng.nextDouble() : 0.5;
                        Vec3 dir = frame.direction(x + jx, y + jy);
                        transport::RayHit hit = visibility.intersect(frame.eye, dir);
                        if (!hit.hit) {
                            if (background.shown())
                                for (size_t f = 0; f < nf; ++f) sum[f] += background.miss(dir);
                            continue;
                        }
                        ++hits;
                        const scene::Patch& p = scene.patches[hit.patch];
                        if (glm::dot(dir, p.normal) > 0) {
                            if (settings.backFacesBlack) continue;
                        }
                        std::optional<RGB> texel;
                        if (tex && scene::patchTexture(scene, p)) {
                            const Vec2 uv = scene::clampToPatchDomain(p.kind, scene::patchInverse(p, hit.point));
                            const ParamFootprint fp =
                                footprintOnPatch(p, frame.eye, frame.direction(x + jx + step, y + jy),
                                                 frame.direction(x + jx, y + jy + step), uv);
                            texel = tex->texel(hit.patch, uv.x, uv.y, &fp);
                        }
                        for (size_t f = 0; f < nf; ++f) {
                            // Each field gets the same random sequence.
                            Pcg32 g = rng;
                            sum[f] += path ? gatherer.pathTraced(hit.patch, hit.point, g)
                                           : gatherer.finalGather(*fields[f], hit.patch, hit.point, g,
                                                                  texel ? &*texel : nullptr);
                        }
                    }
                    for (size_t f = 0; f < nf; ++f) img[f].at(x, y) = sum[f] / double(spp);
                    background.record(img, x, y, hits, spp);
                }
            bar.add(1);
        }
    });
    bar.done();
    return img;
}

/// What one field shows at a camera sample: its lightmap's texel, or its
/// (smooth or flat) value with the texture (render/texturing.h; with each
/// leaf's own reflectance where the field says so).
struct FieldPicture {
    const scene::RadiosityField* field = nullptr;
    std::unique_ptr<LeafReflectance> leafRho;
    std::unique_ptr<VertexInterpolation> interp;
    std::optional<Lightmap> lightmap;

    void prepare(const scene::RadiosityField& f, const RenderSettings& settings) {
        field = &f;
        const bool fromLightmap = settings.reconstruction == RenderSettings::Reconstruction::Lightmap;
        if (settings.textures && f.leafTextureRho()) {
            leafRho = std::make_unique<LeafReflectance>(f);
            if (!leafRho->any()) leafRho.reset();
        }
        if (settings.interpolate || fromLightmap)
            interp = std::make_unique<VertexInterpolation>(f, settings.smooth, leafRho.get());
        if (fromLightmap) {
            LightmapSettings ls = settings.lightmap;
            ls.textures = settings.textures;
            ls.filter = settings.textureFilter;
            lightmap = bakeLightmap(f, ls, interp.get());
        }
    }

    RGB at(uint32_t patch, const Vec2& uv, const TextureShading* tex, const ParamFootprint* fp) const {
        if (lightmap) return lightmap->sample(lightmap->uv(patch, uv.x, uv.y));  // texture in the texels
        if (tex && leafRho && leafRho->covers(patch)) {
            // Each leaf's own rho (texturing.h): shade H.
            const RGB H = interp ? interp->at(patch, uv.x, uv.y) : leafRho->irradianceAt(patch, uv.x, uv.y);
            return tex->shadeIrradiance(patch, uv.x, uv.y, H, fp);
        }
        const RGB B = interp ? interp->at(patch, uv.x, uv.y) : field->at(patch, uv.x, uv.y);
        return tex ? tex->shade(patch, uv.x, uv.y, B, fp) : B;
    }
};

}  // namespace

Image renderField(const scene::Scene& scene, const transport::Visibility& visibility,
                  const scene::RadiosityField& field, const scene::Camera& camera,
                  const RenderSettings& settings) {
    return std::move(renderFields(scene, visibility, {&field}, camera, settings)[0]);
}

std::vector<Image> renderFields(const scene::Scene& scene, const transport::Visibility& visibility,
                                const std::vector<const scene::RadiosityField*>& fields,
                                const scene::Camera& camera, const RenderSettings& settings) {
    const size_t nf = fields.size();
    if (settings.reconstruction == RenderSettings::Reconstruction::FinalGather ||
        settings.reconstruction == RenderSettings::Reconstruction::PathTraced)
        return renderGathered(scene, visibility, fields, camera, settings);
    std::vector<FieldPicture> pictures(nf);
    for (size_t f = 0; f < nf; ++f) {
        HRAD_CHECK(&fields[f]->scene() == &scene ||
                   fields[f]->scene().patches.size() == scene.patches.size());
        pictures[f].prepare(*fields[f], settings);
    }
    std::optional<TextureShading> shading;
    if (settings.textures && !scene.textures.empty()) shading.emplace(scene, settings.textureFilter);
    const TextureShading* tex = shading && shading->any() ? &*shading : nullptr;
    const bool mip = tex && tex->filter() == TextureFilter::Mip;
    CameraFrame frame(camera, settings.width, settings.height);
    std::vector<Image> img(nf, Image(settings.width, settings.height));
    const Background background(scene, settings);
    background.prepare(img);
    const int spp = settings.spp;
    const int strata = int(std::lround(std::sqrt(double(spp))));
    const bool stratified = strata * strata == spp;
    // The ray differential's step: the spacing of the samples in a pixel
    // (PBR 3rd ed. section 10.1.1 scales differentials by 1 / sqrt(spp)).
    const double step = 1.0 / std::sqrt(double(spp));

    // Progress with an estimate of the time left (core/log.h), per image row;
    // silent under --log quiet and for renders under a second.
    ProgressBar progress("render", uint64_t(settings.height),
                         spdlog::should_log(spdlog::level::info));
    tbb::parallel_for(
        tbb::blocked_range<int>(0, settings.height), [&](const tbb::blocked_range<int>& r) {
            std::vector<RGB> sum(nf);
            for (int y = r.begin(); y != r.end(); ++y, progress.add(1)) {
                for (int x = 0; x < settings.width; ++x) {
                    Pcg32 rng(hashIds(uint64_t(x), uint64_t(y)));
                    std::fill(sum.begin(), sum.end(), RGB(0.0));
                    int hits = 0;
                    for (int s = 0; s < spp; ++s) {
                        double jx = 0.5, jy = 0.5;
                        if (spp > 1) {
                            jx = rng.nextDouble();
                            jy = rng.nextDouble();
                            if (stratified) {
                                jx = ((s % strata) + jx) / strata;
                                jy = ((s / strata) + jy) / strata;
                            }
                        }
                        Vec3 dir = frame.direction(x + jx, y + jy);
                        transport::RayHit hit = visibility.intersect(frame.eye, dir);
                        if (!hit.hit) {
                            if (background.shown())
                                for (size_t f = 0; f < nf; ++f) sum[f] += background.miss(dir);
                            continue;
                        }
                        ++hits;
                        const scene::Patch& p = scene.patches[hit.patch];
                        if (settings.backFacesBlack && glm::dot(dir, p.normal) > 0) continue;
                        Vec2 uv = scene::clampToPatchDomain(p.kind, scene::patchInverse(p, hit.point));
                        ParamFootprint fp;
                        if (mip)
                            fp = footprintOnPatch(p, frame.eye, frame.direction(x + jx + step, y + jy),
                                                  frame.direction(x + jx, y + jy + step), uv);
                        for (size_t f = 0; f < nf; ++f)
                            sum[f] += pictures[f].at(hit.patch, uv, tex, mip ? &fp : nullptr);
                    }
                    for (size_t f = 0; f < nf; ++f) img[f].at(x, y) = sum[f] / double(spp);
                    background.record(img, x, y, hits, spp);
                }
            }
        });
    return img;
}

}  // namespace hrad::render
