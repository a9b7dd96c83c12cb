// Mitsuba 3 XML scene loader (pugixml), also reading the Mitsuba 0.5/0.6
// files of Bitterli's "Rendering Resources" (camelCase names such as
// `toWorld`, `diffuseReflectance` are read as their Mitsuba 3 snake_case
// spelling, as Mitsuba 3's upgrade path does).
//
// Reference: the Mitsuba 3 documentation, "Scene XML file format" and the
// plugin reference (shapes, BSDFs, emitters, sensors); Jakob et al.,
// Mitsuba 3 renderer, 2022.
//
// What becomes what:
//   shapes     obj and ply (through hrad's OBJ and PLY loaders; the XML BSDF,
//              not the .mtl, gives the material), serialized (.serialized,
//              scene/mitsuba_serialized.h), rectangle ([-1,1]^2, z = 0),
//              disk (unit disk, z = 0), cube ([-1,1]^3), sphere (center,
//              radius), cylinder (p0, p1, radius, open like Mitsuba's), each
//              with `to_world` and `flip_normals`. Analytic shapes are
//              tessellated with `mitsuba.resolution` segments around and then
//              scaled about their centre/axis so that the polygon area equals
//              the exact area: emitted power pi L A then matches the path
//              tracer's. `shapegroup` + `instance` (instance transform times
//              the shape's), `ref`/`id` (forward references allowed, as
//              cbox-rgb.xml needs), `default` and `$name` substitution in
//              every attribute (values from `mitsuba.param.NAME` settings win
//              over `default`), `include` (relative to the including file).
//   transforms `matrix` (16 or 9 values, row-major), `translate`, `rotate`
//              (axis + angle in degrees), `scale`, `lookat`, applied in
//              order (each one left-multiplies). A singular, non-finite or
//              malformed transform is an error.
//   materials  reflectance rho, the rule per BSDF (one warning per material
//              when the rule loses something):
//                diffuse, roughdiffuse   reflectance (Mitsuba's default 0.5)
//                plastic, roughplastic,  diffuse_reflectance (default 0.5):
//                pplastic                the glossy coat is dropped
//                conductor,              specular_reflectance x F0, F0 the
//                roughconductor          normal-incidence Fresnel reflectance
//                                        ((eta-1)^2+k^2)/((eta+1)^2+k^2) of the
//                                        given eta, k (Born & Wolf, Principles
//                                        of Optics, sec. 14.2); without eta/k
//                                        F0 = 1 (Mitsuba's default "none" is a
//                                        perfect mirror; named metals are not
//                                        tabulated: warning)
//                principled(thin)        base_color (default 0.5)
//                twosided                its (front) nested BSDF, two-sided
//                mask, bumpmap,          their nested BSDF (opacity and
//                normalmap               bump ignored)
//                blendbsdf               (1 - weight) first + weight second
//                dielectric, thin/rough- transparent: the shape is NOT added
//                dielectric, null        (a path tracer sees through it; as
//                                        an opaque patch it would block the
//                                        light it transmits)
//                measured, hair, ...     mitsuba.default_rho grey
//              A shape without BSDF is diffuse 0.5 (Mitsuba's default).
//              Colours: rgb (linear), srgb (sRGB-decoded), float, spectrum;
//              texture: a bitmap as the diffuse albedo (diffuse reflectance,
//              plastic diffuse_reflectance, principled base_color, also under
//              twosided/mask/bumpmap) is kept as the material's texture
//              (scene/texture.h: sRGB-decoded unless `raw`, wrap_mode; UVs of
//              obj, ply (flip_tex_coords) and serialized meshes, rectangles,
//              cubes, disks, spheres and cylinders in Mitsuba 3's
//              parametrisations; each patch gets its own mean); any
//              other bitmap is replaced by its mean over all texels, with a
//              warning; checkerboard the mean of its two colours. A bitmap
//              that is missing or unreadable gets mitsuba.texture_rho grey
//              with a warning naming the file; decoded texels count against
//              texture.max_mb (an error, checked from the header). Channels
//              >= 1 become scene.clamp_rho with a warning (path-tracer
//              scenes often use 1.0; 0 makes them an error), as in every format.
//              `twosided` sets Material::twoSided; emitsBothSides stays false
//              since Mitsuba area lights emit from the front only.
//   spectra    "lambda:value, ..." lists (piecewise linear, zero outside) or
//              one value; CIE 1931 XYZ by the analytic fit of Wyman, Sloan &
//              Shirley 2013 (JCGT 2(2), eq. 2), 1 nm steps, then linear sRGB
//              (IEC 61966-2-1 matrix). Emission is normalised by the integral
//              of y-bar (equal-energy white, as Mitsuba 3's RGB modes do);
//              reflectance is further divided per channel by the RGB of a
//              constant-1 spectrum, so that flat spectra stay neutral
//              greys (Mitsuba weights reflectances by D65 for the same end).
//   emitters   `area` on any shape: radiance L -> radiosity E = pi L. point,
//              spot, directional, envmap, constant, projector and area lights
//              no shape uses: one warning each, naming file:line (ignored).
//   camera     the first `perspective` (or `thinlens`) sensor: fov with
//              fov_axis x / y / diagonal / smaller / larger (default x) and the
//              film's width/height (default 768 x 576) give the vertical fov;
//              the film size becomes Camera::filmWidth/filmHeight (the default
//              image size of hrad solve/render) and the axis Camera::fovAxis
//              (an image of another aspect keeps the fov along that axis);
//              focal_length (default "50mm") uses a 36 x 24 mm film diagonal;
//              to_world (lookat or matrix) gives eye, target, up, and
//              Scene::upAxis is the up vector's dominant axis (Y when there
//              is no sensor).
// Renderer-only elements (integrator, sampler, rfilter; of the film all but
// width and height) are ignored;
// media get a warning. An unknown element or plugin type is an error listing
// the known ones.
//
// Settings (Params keys):
//   mitsuba.resolution  int    24    segments around disk/sphere/cylinder
//                                    (3..4096; spheres have half as many rings)
//   mitsuba.default_rho double 0.5   grey of BSDFs without a diffuse albedo
//   mitsuba.texture_rho double 0.5   grey of textures that cannot be read or
//                                    are not evaluated (e.g. bitmap-driven
//                                    procedural types other than checkerboard)
//   mitsuba.max_faces   int    2e7   most faces the scene may yield
//   mitsuba.max_inflated_mb int 1024 most bytes .serialized meshes inflate to
//   mitsuba.param.NAME  string       value of $NAME (overrides <default>)
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "scene/scene.h"

namespace hrad::scene {

struct MitsubaOptions {
    int resolution = 24;
    double clampRho = 0.99;  ///< scene.clamp_rho (scene.h clampReflectance)
    double defaultRho = 0.5;
    double textureRho = 0.5;
    uint64_t maxFaces = 20000000;
    uint64_t maxInflatedBytes = uint64_t(1024) << 20;  ///< mitsuba.max_inflated_mb
    uint64_t textureBudget = uint64_t(2048) << 20;  ///< texture.max_mb, decoded bytes
    std::map<std::string, std::string> params;  ///< $NAME values from settings
};

/// Loads a Mitsuba XML scene; throws InputError with FILE:LINE on bad input.
Scene loadMitsuba(const std::string& path, const MitsubaOptions& options = {});

}  // namespace hrad::scene
