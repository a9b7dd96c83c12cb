// Ray-cast images of a radiosity field.
//
// One primary ray per pixel sample through transport::Visibility::intersect;
// the hit point is mapped back to the patch's parametric (u,v) with
// scene::patchInverse, and the field is reconstructed there:
//   - interpolated (default): smooth, C0 vertex radiosity across element and
//     root-patch borders of one surface, T-vertices anchored, creases and
//     material borders kept sharp (render/smooth.h, Cohen & Wallace 1993
//     ch. 10; Baum et al. 1991);
//   - flat: the value of the leaf containing (u,v), i.e. RadiosityField::at —
//     exactly what the solver computed, for inspecting elements.
// The image stores radiosity B (W/m^2), not radiance: for diffuse surfaces the
// radiance is B/pi, a constant factor that exposure absorbs.
//
// Settings (Params keys below a prefix, "render" by default):
//   width        int     512     image width in pixels
//   height       int     512     image height in pixels
//                                Precedence (RenderSettings::adoptFilm): both
//                                set: as set; when the scene's own camera is
//                                used and has a film (Mitsuba sensor):
//                                neither set: the film's size, one set: the
//                                other from the film's aspect (rounded);
//                                otherwise the 512 default for what is unset
//   spp          int     1       samples per pixel: 1 = pixel centre; a square
//                                k*k = stratified jitter; otherwise uniform
//                                jitter; seeded by the pixel (deterministic)
//   max_samples  int     2^26    refuse a render of more than width x height x
//                                spp samples (checked before allocating)
//   interpolate  bool    true    vertex interpolation (see above); false = flat
//   crease_angle double  30      smooth across root-patch borders whose
//                                normals differ by at most this (degrees)
//   back_faces   string  "black" what a ray hitting a patch from behind shows:
//                                "black" (patches are one-sided: no radiosity
//                                leaves the back) or "front" (the front's B)
//   eye, target  string  unset   an explicit pinhole camera, "x, y, z" in scene
//                                units (TOML: "render.eye" = "278, 273, -800");
//                                both or neither. Unset: the scene's own
//                                camera, else render/camera.h cameraFor
//   up           string  "0,1,0" with eye/target: the up direction
//   fov          double  40      with eye/target: vertical field of view, degrees
//   reconstruction string "interpolated" | "flat" (= interpolate false) |
//                                "final-gather" |
//                                "path-traced" (render/final_gather.h, with
//                                gather_rays, shadow_rays, seed); path-traced
//                                ignores the field: the Monte Carlo reference |
//                                "lightmap": the smooth field baked into the
//                                atlas of render.lightmap_* (radiosity texels),
//                                each pixel looked up in it (what a viewer of
//                                lightmap.glb sees, up to its tone map)
//   textures     string  "on"    "on": textured patches show E + rho(x) H, H =
//                                (B - E) / rho_bar the solved irradiance and
//                                rho(x) the bilinear texel (render/texturing.h);
//                                the path tracer and final gather use rho(x)
//                                at every hit. "off": the solved B
//   texture_filter string "mip"  "mip": rho(x) mip-mapped over the sample's
//                                footprint (ray differentials, trilinear;
//                                render/texturing.h), "bilinear": rho(x) at
//                                the hit alone. Flat, interpolated and
//                                lightmap-less pictures only
//   background   string  "environment" what primary rays that hit nothing
//                                show: "environment" the scene's environment
//                                lights (constant, envmap) along the ray, as
//                                radiosity pi L like every pixel (B = pi x
//                                radiance), in every reconstruction; "black".
//                                Without an environment they are black either
//                                way. With the sky shown, Image::surface holds
//                                each pixel's share of samples that hit a
//                                surface: the automatic exposure
//                                (render/image.h) and the error maps
//                                (render/error_map.h) count surfaces only
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/params.h"
#include "render/image.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/visibility.h"
#include "render/final_gather.h"
#include "render/smooth.h"
#include "render/lightmap.h"
#include "render/texturing.h"

namespace hrad::render {

struct RenderSettings {
    int width = 512, height = 512;
    bool interpolate = true;
    enum class Reconstruction { Flat, Interpolated, FinalGather, PathTraced, Lightmap };
    Reconstruction reconstruction = Reconstruction::Interpolated;
    SmoothSettings smooth;  ///< render.crease_angle
    /// reconstruction = lightmap: the atlas (render.lightmap_*) baked from the
    /// smooth field, each pixel its bilinear lookup (render/lightmap.h).
    LightmapSettings lightmap;
    GatherSettings gather;
    bool showProgress = false;  ///< progress bar for final-gather / path-traced
    int spp = 1;
    int64_t maxSamples = int64_t(1) << 26;  ///< render.max_samples: width x height x spp bound
    bool backFacesBlack = true;
    /// render.background = environment: misses show the environment (above).
    bool backgroundEnvironment = true;
    /// render.textures: textured patches show E + rho(x) H (render/texturing.h).
    bool textures = true;
    /// render.texture_filter (render/texturing.h).
    TextureFilter textureFilter = TextureFilter::Mip;
    std::optional<scene::Camera> camera;  ///< render.eye/target/up/fov when set
    bool widthSet = false, heightSet = false;  ///< render.width / render.height given
    SourceLocation budgetWhere;                ///< where spp or max_samples was set, for errors

    static RenderSettings fromParams(const Params& params, const std::string& prefix = "render");
    /// Takes the image size from the scene camera's film (Mitsuba sensors)
    /// where the user set none, by the precedence above; no change with an
    /// explicit camera (render.eye) or a camera without a film. Checks
    /// width x height x spp against max_samples again: a film too large for
    /// the budget is an error at the film's file:line.
    void adoptFilm(const scene::Scene& scene);
    std::string describe() const;
};

/// settings.camera when set, else render::cameraFor(scene, visibility).
scene::Camera chooseCamera(const scene::Scene& scene, const transport::Visibility& visibility,
                           const RenderSettings& settings);

Image renderField(const scene::Scene& scene, const transport::Visibility& visibility,
                  const scene::RadiosityField& field, const scene::Camera& camera,
                  const RenderSettings& settings);
/// One image per field, with each primary ray cast once and every field
/// evaluated at its hit (what renderField gives for each, pixel for pixel).
std::vector<Image> renderFields(const scene::Scene& scene, const transport::Visibility& visibility,
                                const std::vector<const scene::RadiosityField*>& fields,
                                const scene::Camera& camera, const RenderSettings& settings);

}  // namespace hrad::render
