// Loader for Ward's Materials and Geometry Format (MGF 1.0, LBL 1995,
// https://floyd.lbl.gov/mgf/mgfhtml/).
//
// Supported: `#` comments, backslash line continuation, `i file [xf args]`
// includes (paths relative to the including file), `xf` transform contexts
// (-t, -rx/-ry/-rz degrees, -s, -mx/-my/-mz, -i N repetition, -a N arrays,
// nested), colour contexts (`c`, `c name`, `c name =`, `c name = template`,
// `cxy`, and approximations of `cspec`, `cct`, `cmix` with one warning),
// material contexts (`m ...` like `c`, `rd`, `ed`, `sides`: a two-sided
// material becomes front/back patch pairs, both sides emitting; `rs`, `ts`,
// `td`, `ir` are ignored with one warning per kind, counted in
// stats.ignoredStatements), vertex contexts (`v name =`, `p`, `n`), faces `f`
// (through addPolygon: MGF hole seams are triangulated correctly), and the
// primitives `sph`, `cyl`, `cone`, `ring`, `torus`, `prism` tessellated with
// `resolution` segments around (spheres and tori use resolution/2 bands).
// Primitive normals face outward, inward for negative radii/length (spec).
// Objects (`o`) are ignored; unknown entities warn once per keyword.
//
// Choices (documented here because the spec leaves them to the renderer):
//  - Vertex names are global; redefinition is allowed. A vertex keeps its
//    untransformed p/n and is transformed by the xf context in force where a
//    face or primitive uses it (as mgflib's translators do).
//  - Faces in a mirroring context (odd number of -m*) are reversed so their
//    front keeps facing the mirrored front.
//  - Colour: CIE xy (Y = 1) -> XYZ -> linear RGB with Rec.709 primaries and
//    the white point `whitePoint` ("E": equal-energy white as Radiance and
//    mgf2rad use, so cxy 1/3 1/3 is neutral grey; or "D65" as sRGB), negative
//    channels clipped to 0, then scaled so that the Y of the RGB equals the
//    magnitude (rd for reflectance, ed for emission).
//  - A reflectance colour whose largest channel reaches 1 (saturated colours,
//    or rd = 1, which MGF allows) is scaled down to 0.999 (warning once per
//    material): solvers need rho < 1. rd outside [0, 1] is an error.
//  - Emission: MGF `ed` is an emitted luminous exitance (lm/m^2); hrad takes
//    it as the radiosity magnitude: E_rgb = ed * colour with luminance 1.
#pragma once

#include <string>

#include "scene/scene.h"

namespace hrad::scene {

struct MgfOptions {
    int resolution = 16;            ///< segments around curved primitives
    std::string whitePoint = "E";   ///< "E" or "D65"
    /// Bound on the faces made and on the statements executed after xf/include
    /// expansion (hostile or mistaken nested -a arrays); exceeding it is an
    /// InputError naming the setting.
    size_t maxFaces = 20'000'000;
    /// Bound on the `i` statements executed, each include counted every time
    /// it runs (a tree of files each including the next twice doubles per
    /// level); exceeding it is an InputError naming mgf.max_includes.
    size_t maxIncludes = 100'000;
    /// `sides` of materials that do not state it. The MGF specification's
    /// default is 2 (Ward's parser: every material starts two-sided), but
    /// RenderPark forces one-sided surfaces unless told otherwise
    /// (-dont-force-onesided), and the MGF scenes in use were modelled as
    /// closed, one-sided geometry; hrad follows RenderPark: 1. An explicit
    /// `sides` statement is always obeyed.
    int defaultSides = 1;
    double clampRho = 0.99;  ///< scene.clamp_rho (scene.h clampReflectance)
};

Scene loadMgf(const std::string& path, const MgfOptions& options = {});

/// CIE xy chromaticity with luminance Y -> linear Rec.709 RGB whose Y equals
/// `luminance` (see above). whitePoint is "E" or "D65".
RGB chromaticityToRgb(double x, double y, double luminance, const std::string& whitePoint = "E");

/// Number of patches the tessellation of each primitive yields at a
/// resolution (for tests): sphere/torus R * max(2|3, R/2), cyl/cone/ring R.
int mgfSphereBands(int resolution);
int mgfTorusBands(int resolution);

}  // namespace hrad::scene
