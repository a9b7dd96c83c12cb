// MGF loading (see mgf_loader.h for what is supported and the choices made).
#include "scene/mgf_loader.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <unordered_map>

#include <glm/mat3x3.hpp>

#include "core/error.h"
#include "core/parse.h"
#include "scene/triangulate.h"

namespace hrad::scene {

int mgfSphereBands(int resolution) { return std::max(2, resolution / 2); }
int mgfTorusBands(int resolution) { return std::max(3, resolution / 2); }

namespace {

// ---------------------------------------------------------------- colour

using Mat3 = glm::dmat3;  // column-major: m[col][row]

Vec3 xyToXYZ(double x, double y) { return {x / y, 1.0, (1.0 - x - y) / y}; }

// RGB -> XYZ matrix for Rec.709 primaries and the given white (Y = 1), the
// standard construction (e.g. Lindbloom, "RGB/XYZ matrices").
Mat3 rgbToXyz(const std::string& white) {
    Mat3 p(xyToXYZ(0.64, 0.33), xyToXYZ(0.30, 0.60), xyToXYZ(0.15, 0.06));
    Vec3 w = white == "D65" ? xyToXYZ(0.3127, 0.3290) : Vec3(1.0, 1.0, 1.0);
    Vec3 s = glm::inverse(p) * w;
    return Mat3(p[0] * s.x, p[1] * s.y, p[2] * s.z);
}

struct Chroma {
    double x = 1.0 / 3.0, y = 1.0 / 3.0;
};

// Wyman, Sloan & Shirley 2013, "Simple Analytic Approximations to the CIE
// XYZ Color Matching Functions" (JCGT 2(2)), multi-lobe piecewise Gaussians.
double g(double l, double mu, double s1, double s2) {
    double t = (l - mu) / (l < mu ? s1 : s2);
    return std::exp(-0.5 * t * t);
}
Vec3 cie1931(double l) {
    double x = 1.056 * g(l, 599.8, 37.9, 31.0) + 0.362 * g(l, 442.0, 16.0, 26.7) -
               0.065 * g(l, 501.1, 20.4, 26.2);
    double y = 0.821 * g(l, 568.8, 46.9, 40.5) + 0.286 * g(l, 530.9, 16.3, 31.1);
    double z = 1.217 * g(l, 437.0, 11.8, 36.0) + 0.681 * g(l, 459.0, 26.0, 13.8);
    return {x, y, z};
}
bool chromaFromXYZ(const Vec3& c, Chroma& out) {
    double s = c.x + c.y + c.z;
    if (!(s > 0) || !(c.y > 0)) return false;
    out = {c.x / s, c.y / s};
    return true;
}

// ---------------------------------------------------------------- transforms

struct Xf {
    Mat3 m{1.0};  ///< rotation * uniform scale * mirror
    Vec3 t{0.0};
    double scale = 1.0;
    bool mirror = false;
    Vec3 point(const Vec3& p) const { return m * p + t; }
    Vec3 normal(const Vec3& n) const {
        Vec3 r = m * n;
        double l = glm::length(r);
        return l > 0 ? r / l : r;
    }
};

/// Applies `inner` first, then `outer`.
Xf compose(const Xf& outer, const Xf& inner) {
    Xf r;
    r.m = outer.m * inner.m;
    r.t = outer.m * inner.t + outer.t;
    r.scale = outer.scale * inner.scale;
    r.mirror = outer.mirror != inner.mirror;
    return r;
}

Xf rotation(int axis, double degrees) {
    double a = degrees * kPi / 180.0, c = std::cos(a), s = std::sin(a);
    Xf x;
    int i = (axis + 1) % 3, j = (axis + 2) % 3;  // counter-clockwise looking down -axis
    x.m[i][i] = c;
    x.m[i][j] = s;
    x.m[j][i] = -s;
    x.m[j][j] = c;
    return x;
}

// ---------------------------------------------------------------- file text

struct Stmt {
    std::vector<std::string> tok;
    int line = 0;
};

struct FileText {
    std::string path;
    std::vector<Stmt> stmts;
    std::vector<size_t> xfEnd;  ///< for an `xf args` statement: index of its closing `xf`
};

std::unique_ptr<FileText> readFile(const std::string& path, const SourceLocation& from) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec))
        throwInputError(from, "'{}' is a folder, not an MGF file", path);
    // Devices and pipes (`i /dev/zero`) would be read without end.
    if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
        throwInputError(from, "'{}' is not a regular file", path);
    std::ifstream in(path, std::ios::binary);
    if (!in) throwInputError(from, "cannot open MGF file '{}'", path);
    auto ft = std::make_unique<FileText>();
    ft->path = path;
    std::string line, acc;
    int lineNo = 0, startLine = 0;
    while (std::getline(in, line)) {
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (acc.empty()) startLine = lineNo;
        if (!line.empty() && line.back() == '\\') {
            line.back() = ' ';
            acc += line;
            continue;
        }
        acc += line;
        std::istringstream ss(acc);
        Stmt st;
        st.line = startLine;
        std::string t;
        while (ss >> t) st.tok.push_back(t);
        acc.clear();
        if (st.tok.empty() || st.tok[0][0] == '#') continue;
        ft->stmts.push_back(std::move(st));
    }
    if (!acc.empty()) {
        std::istringstream ss(acc);
        Stmt st;
        st.line = startLine;
        std::string t;
        while (ss >> t) st.tok.push_back(t);
        if (!st.tok.empty() && st.tok[0][0] != '#') ft->stmts.push_back(std::move(st));
    }
    // Match `xf args` with the bare `xf` that closes it.
    ft->xfEnd.assign(ft->stmts.size(), SIZE_MAX);
    std::vector<size_t> open;
    for (size_t i = 0; i < ft->stmts.size(); ++i) {
        const auto& tk = ft->stmts[i].tok;
        if (tk[0] != "xf") continue;
        if (tk.size() > 1) {
            open.push_back(i);
        } else if (!open.empty()) {
            ft->xfEnd[open.back()] = i;
            open.pop_back();
        } else {
            throwInputError(SourceLocation{path, ft->stmts[i].line, 0},
                            "'xf' ends a transform context that was never opened in this file");
        }
    }
    for (size_t i : open) ft->xfEnd[i] = ft->stmts.size();  // closed by end of file (warned)
    return ft;
}

// ---------------------------------------------------------------- loader

struct MgfMaterial {
    double rd = 0.0, ed = 0.0;
    Chroma rdColour, edColour;
    int sides = 1;        ///< MGF `sides`: 2 = seen (and lit) from both sides
    int sceneIndex = -1;  ///< scene material for the current values, -1 = stale
};

struct MgfVertex {
    Vec3 p{0.0}, n{0.0};
    bool hasP = false, hasN = false;
};

class MgfLoader {
  public:
    MgfLoader(const MgfOptions& o) : opt_(o), toXyz_(rgbToXyz(o.whitePoint)), toRgb_(glm::inverse(toXyz_)) {
        unnamedColour_ = Chroma{};
        colour_ = &unnamedColour_;
        unnamedMaterial_.sides = o.defaultSides;
        material_ = &unnamedMaterial_;
    }

    Scene run(const std::string& path) {
        scene_.name = path;
        scene_.source = "mgf";
        scene_.upAxis = 2;
        const FileText& ft = file(path, SourceLocation{path, 0, 0});
        exec(ft, 0, ft.stmts.size(), Xf{}, 0, 1.0);
        if (scene_.patches.size() > opt_.maxFaces)
            throwInputError(SourceLocation{path, 0, 0},
                            "the scene has {} faces, more than mgf.max_faces = {}; raise the "
                            "setting to load it", scene_.patches.size(), opt_.maxFaces);
        return std::move(scene_);
    }

    RGB toRgb(const Chroma& c, double lum) const {
        if (lum <= 0) return RGB(0.0);
        RGB rgb = toRgb_ * xyToXYZ(c.x, c.y);
        rgb = glm::max(rgb, RGB(0.0));
        double y = (toXyz_ * rgb).y;
        if (!(y > 0)) return RGB(lum);
        return rgb * (lum / y);
    }

  private:
    const MgfOptions& opt_;
    Mat3 toXyz_, toRgb_;
    Scene scene_;
    std::map<std::string, std::unique_ptr<FileText>> files_;
    std::map<std::string, Chroma> colours_;
    Chroma unnamedColour_;
    Chroma* colour_;
    std::map<std::string, MgfMaterial> materials_;
    MgfMaterial unnamedMaterial_;
    MgfMaterial* material_;
    std::string materialName_ = "mgf_default";
    std::unordered_map<std::string, MgfVertex> vertices_;
    MgfVertex* vertex_ = nullptr;
    size_t executed_ = 0;  ///< statements executed so far, after expansion
    size_t includes_ = 0;  ///< `i` statements executed so far, repeats counted

    const FileText& file(const std::string& path, const SourceLocation& from) {
        std::error_code ec;
        std::filesystem::path canon = std::filesystem::weakly_canonical(path, ec);
        std::string key = ec ? std::filesystem::path(path).lexically_normal().string() : canon.string();
        auto it = files_.find(key);
        if (it != files_.end()) return *it->second;
        auto ft = readFile(path, from);
        const FileText& ref = *ft;
        files_[key] = std::move(ft);
        return ref;
    }

    // One line per kind, with how often it occurred (core/warning_log.h).
    void warnOnce(const std::string& kind, const std::string& msg) {
        scene_.stats.warnings.add(kind, msg);
    }

    [[noreturn]] void fail(const FileText& f, const Stmt& s, const std::string& msg) const {
        throw InputError(SourceLocation{f.path, s.line, 0}, msg);
    }

    double num(const FileText& f, const Stmt& s, size_t i) const {
        if (i >= s.tok.size()) fail(f, s, fmt::format("'{}' is missing argument {}", s.tok[0], i));
        const std::string& t = s.tok[i];
        auto v = parseFiniteDouble(t);  // strict: whole token, finite (core/parse.h)
        if (!v) fail(f, s, fmt::format("'{}': malformed or non-finite number '{}'", s.tok[0], t));
        return *v;
    }

    void needArgs(const FileText& f, const Stmt& s, size_t lo, size_t hi) const {
        size_t n = s.tok.size() - 1;
        if (n < lo || n > hi) {
            if (lo == hi)
                fail(f, s, fmt::format("'{}' takes {} argument(s), got {}", s.tok[0], lo, n));
            fail(f, s, fmt::format("'{}' takes {} to {} arguments, got {}", s.tok[0], lo, hi, n));
        }
    }

    const MgfVertex& vert(const FileText& f, const Stmt& s, const std::string& name, bool needNormal = false) {
        auto it = vertices_.find(name);
        if (it == vertices_.end()) fail(f, s, fmt::format("'{}' refers to undefined vertex '{}'", s.tok[0], name));
        if (!it->second.hasP)  // mgflib's default vertex is at the origin (C_DEFVERTEX)
            warnOnce("no-p", fmt::format("{}:{}: vertex '{}' has no position (p); using the origin as "
                                         "mgflib does", f.path, s.line, name));
        if (needNormal && !(it->second.hasN && glm::length(it->second.n) > 0))
            fail(f, s, fmt::format("'{}' needs a normal (n) on vertex '{}'", s.tok[0], name));
        return it->second;
    }

    uint32_t currentMaterial() {
        MgfMaterial& m = *material_;
        if (m.sceneIndex >= 0) return uint32_t(m.sceneIndex);
        Material mat;
        mat.name = materialName_;
        mat.rho = toRgb(m.rdColour, m.rd);
        const RGB given = mat.rho;
        switch (clampReflectance(mat.rho, opt_.clampRho)) {  // scene.h: one rule for every format
            case RhoCheck::Clamped:
                warnOnce("saturated:" + materialName_,
                         fmt::format("material '{}': rd = {} with its colour has a channel >= 1: {}",
                                     materialName_, m.rd, clampedNote(opt_.clampRho)));
                break;
            case RhoCheck::TooLarge: {
                // Braced: the location's lifetime ends inside this case.
                const SourceLocation where{scene_.name, 0, 0};
                throwInputError(where,
                                "material '{}': rd = {} with its colour is ({:.6g}, {:.6g}, {:.6g}), "
                                ">= 1 ({})",
                                materialName_, m.rd, given.r, given.g, given.b, kClampRhoHint);
            }
            case RhoCheck::Fine: break;
        }
        mat.emission = toRgb(m.edColour, m.ed);
        // MGF spec: `sides 2` makes the material visible from both sides; an
        // emitting two-sided material emits from both (as RenderPark's twins).
        mat.twoSided = m.sides == 2;
        mat.emitsBothSides = mat.twoSided;
        m.sceneIndex = int(scene_.addMaterial(mat));
        return uint32_t(m.sceneIndex);
    }

    /// Adds a face made by statement s. Transforms can overflow finite input
    /// (nested `xf -s 1e200`): such a face is an error at the statement, not
    /// a "non-finite vertex" for the scene check to find without a line.
    void emit(const FileText& f, const Stmt& s, const std::vector<Vec3>& poly, uint32_t material) {
        for (const Vec3& v : poly)
            if (!(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z)))
                fail(f, s, fmt::format("'{}' makes a vertex with non-finite coordinates (transform "
                                       "overflow?)", s.tok[0]));
        addPolygon(scene_, poly, material);
    }

    // Parses xf arguments into the list of transforms (one per array element).
    std::vector<Xf> parseXf(const FileText& f, const Stmt& s, size_t first) const {
        struct Segment {
            int count = 1;  // array count (or 1 for the prefix)
            bool array = false;
            std::vector<Xf> ops;
        };
        std::vector<Segment> segs(1);
        size_t i = first;
        int repeat = 1;           // current -i count
        std::vector<Xf> pending;  // ops since the last -i
        // `-i N` repeats the transforms since the previous -i/-a N times: one
        // composed transform P^N, not N copies of the list.
        auto flushRepeat = [&]() {
            Xf once;
            for (const auto& o : pending) once = compose(o, once);
            Xf all;
            for (int r = 0; r < repeat; ++r) all = compose(once, all);
            segs.back().ops.push_back(all);
            pending.clear();
            repeat = 1;
        };
        while (i < s.tok.size()) {
            const std::string& a = s.tok[i];
            Xf x;
            if (a == "-t") {
                x.t = Vec3(num(f, s, i + 1), num(f, s, i + 2), num(f, s, i + 3));
                i += 4;
            } else if (a == "-rx" || a == "-ry" || a == "-rz") {
                x = rotation(a[2] - 'x', num(f, s, i + 1));
                i += 2;
            } else if (a == "-s") {
                double sc = num(f, s, i + 1);
                if (!(sc != 0)) fail(f, s, "xf: scale factor must be non-zero");
                x.m = Mat3(std::fabs(sc));
                x.scale = std::fabs(sc);
                if (sc < 0) {  // a negative scale is a point reflection: odd in 3D
                    x.m = Mat3(sc);
                    x.mirror = true;
                }
                i += 2;
            } else if (a == "-mx" || a == "-my" || a == "-mz") {
                x.m[a[2] - 'x'][a[2] - 'x'] = -1.0;
                x.mirror = true;
                i += 1;
            } else if (a == "-i" || a == "-a") {
                double nv = num(f, s, i + 1);
                if (!(nv >= 1 && std::floor(nv) == nv && nv < 1e6))
                    fail(f, s, fmt::format("xf: {} needs a positive integer count", a));
                flushRepeat();
                if (a == "-i") {
                    repeat = int(nv);
                } else {
                    segs.push_back(Segment{int(nv), true, {}});
                }
                i += 2;
                continue;
            } else {
                fail(f, s, fmt::format("xf: unknown transform argument '{}'", a));
            }
            pending.push_back(x);
        }
        flushRepeat();
        // The number of array elements is the product of the -a counts: check
        // it against mgf.max_faces before building the list.
        double copies = 1.0;
        for (const auto& sg : segs) copies *= sg.count;
        if (copies > double(opt_.maxFaces))
            fail(f, s, fmt::format("xf: the -a arrays make {:.0f} copies, more than mgf.max_faces = {} "
                                   "(raise the setting to load it)",
                                   copies, opt_.maxFaces));
        // Element transform = A_k^{i_k} o ... o A_1^{i_1} o B (left to right):
        // the prefix B applies once, each array segment i times for element i.
        std::vector<Xf> result(1);
        for (const auto& sg : segs) {
            Xf seg;
            for (const auto& o : sg.ops) seg = compose(o, seg);
            std::vector<Xf> next;
            for (const auto& base : result) {
                if (!sg.array) {
                    next.push_back(compose(seg, base));
                    continue;
                }
                Xf cur = base;
                for (int k = 0; k < sg.count; ++k) {
                    next.push_back(cur);
                    cur = compose(seg, cur);
                }
            }
            result = std::move(next);
        }
        return result;
    }

    /// A body of `statements` statements run `copies` times executes at least
    /// copies * statements statements: refused up front when that exceeds
    /// mgf.max_faces (the executed-statement counter would stop it later, after
    /// allocating up to mgf.max_faces faces).
    void checkExpansion(const FileText& f, const Stmt& s, double copies, size_t statements) const {
        double total = copies * double(statements);
        if (total > double(opt_.maxFaces))
            fail(f, s, fmt::format("'{}' expands to {} copies of {} statements ({:.3g} in all), more "
                                   "than mgf.max_faces = {}; raise the setting to load it",
                                   s.tok[0], copies, statements, total, opt_.maxFaces));
    }

    /// `copies`: how many times this range runs (the product of the enclosing
    /// array counts), for the expansion bound.
    void exec(const FileText& f, size_t begin, size_t end, const Xf& xf, int depth, double copies) {
        if (depth > 64) throwInputError(SourceLocation{f.path, 0, 0}, "include/xf nesting deeper than 64 (a cycle?)");
        for (size_t i = begin; i < end; ++i) {
            const Stmt& s = f.stmts[i];
            const std::string& k = s.tok[0];
            // Bounded expansion: statements executed after xf/include expansion
            // and faces made are both held to mgf.max_faces, so that nested
            // arrays (xf -a 999999 twice: 10^12 copies) stop with an error
            // early instead of running for hours.
            if (++executed_ > opt_.maxFaces)
                fail(f, s, fmt::format("xf/include expansion executes more than mgf.max_faces = {} "
                                       "statements (nested -a/-i arrays?); raise the setting to load it",
                                       opt_.maxFaces));
            if (scene_.patches.size() > opt_.maxFaces)
                fail(f, s, fmt::format("the scene has more than mgf.max_faces = {} faces; raise the "
                                       "setting to load it", opt_.maxFaces));
            if (k == "xf") {
                if (s.tok.size() == 1) fail(f, s, "unmatched 'xf'");  // cannot happen: matched in readFile
                size_t close = f.xfEnd[i];
                if (close >= f.stmts.size())
                    warnOnce("xf-eof", fmt::format("{}:{}: 'xf' context not closed before end of file", f.path, s.line));
                size_t bodyEnd = std::min(close, f.stmts.size());
                std::vector<Xf> list = parseXf(f, s, 1);
                checkExpansion(f, s, copies * double(list.size()), bodyEnd - i - 1);
                for (const Xf& x : list) exec(f, i + 1, bodyEnd, compose(xf, x), depth + 1, copies * double(list.size()));
                i = std::min(close, f.stmts.size());
            } else if (k == "i") {
                if (s.tok.size() < 2) fail(f, s, "'i' needs a file name");
                // Included files are read once, but a tree of files each
                // including the next twice runs 2^depth includes: each one
                // counted, before its file is looked up (issue 64: 46 s).
                if (++includes_ > opt_.maxIncludes)
                    fail(f, s, fmt::format("more than mgf.max_includes = {} include statements executed "
                                           "(an include fan-out?); raise the setting to load it",
                                           opt_.maxIncludes));
                std::filesystem::path p(s.tok[1]);
                if (p.is_relative()) p = std::filesystem::path(f.path).parent_path() / p;
                std::error_code ec;
                if (!std::filesystem::exists(p, ec)) {  // scene.missing (scene/missing_files.h)
                    scene_.stats.missingFiles.add(SourceLocation{f.path, s.line, 0}, "included file",
                                                  p.string());
                    continue;
                }
                const FileText& inc = file(p.string(), SourceLocation{f.path, s.line, 0});
                if (s.tok.size() > 2) {
                    std::vector<Xf> list = parseXf(f, s, 2);
                    checkExpansion(f, s, copies * double(list.size()), inc.stmts.size());
                    for (const Xf& x : list) exec(inc, 0, inc.stmts.size(), compose(xf, x), depth + 1, copies * double(list.size()));
                } else {
                    checkExpansion(f, s, copies, inc.stmts.size());
                    exec(inc, 0, inc.stmts.size(), xf, depth + 1, copies);
                }
            } else if (k == "c") {
                colourContext(f, s);
            } else if (k == "cxy") {
                needArgs(f, s, 2, 2);
                double x = num(f, s, 1), y = num(f, s, 2);
                // mgflib's limits: x, y >= 0, x + y <= 1.
                if (!(x >= 0 && y >= 0 && x + y <= 1.0 + 1e-6))
                    fail(f, s, fmt::format("cxy: ({}, {}) is not a valid chromaticity", x, y));
                if (y < 1e-4) {  // no luminance direction (real data: hospital/blokken2.mgf)
                    warnOnce("cxy-y0", fmt::format("{}:{}: cxy {} {} has y ~ 0; using neutral white", f.path,
                                                   s.line, x, y));
                    *colour_ = Chroma{};
                } else {
                    *colour_ = Chroma{x, y};
                }
            } else if (k == "cspec") {
                spectrum(f, s);
            } else if (k == "cct") {
                needArgs(f, s, 1, 1);
                double T = num(f, s, 1);
                if (!(T > 0)) fail(f, s, "cct: temperature must be > 0");
                Vec3 xyz(0.0);
                for (double l = 380; l <= 780; l += 5) {
                    double lm = l * 1e-9;  // Planck's law (relative)
                    double b = 1.0 / (std::pow(lm, 5) * (std::exp(1.4387769e-2 / (lm * T)) - 1.0));
                    xyz += b * cie1931(l);
                }
                chromaFromXYZ(xyz, *colour_);
                warnOnce("cct", fmt::format("{}:{}: 'cct' converted with an analytic CIE 1931 fit "
                                            "(Wyman et al. 2013)", f.path, s.line));
            } else if (k == "cmix") {
                if (s.tok.size() < 3 || (s.tok.size() - 1) % 2 != 0) fail(f, s, "cmix needs weight/colour pairs");
                Vec3 xyz(0.0);
                for (size_t a = 1; a + 1 < s.tok.size(); a += 2) {
                    double w = num(f, s, a);
                    auto it = colours_.find(s.tok[a + 1]);
                    if (it == colours_.end()) fail(f, s, fmt::format("cmix: undefined colour '{}'", s.tok[a + 1]));
                    xyz += w * xyToXYZ(it->second.x, it->second.y);
                }
                if (!chromaFromXYZ(xyz, *colour_)) fail(f, s, "cmix: weights give no colour");
            } else if (k == "m") {
                materialContext(f, s);
            } else if (k == "rd" || k == "ed") {
                needArgs(f, s, 1, 1);
                double v = num(f, s, 1);
                // MGF allows rd in [0, 1]; rd = 1 becomes 0.999 in currentMaterial()
                // (rho must stay below 1 for the solvers), rd > 1 is an error.
                if (k == "rd" && !(v >= 0 && v <= 1))
                    fail(f, s, fmt::format("material '{}': rd = {} must be in [0, 1]", materialName_, v));
                if (k == "ed" && !(v >= 0)) fail(f, s, fmt::format("material '{}': ed = {} must be >= 0", materialName_, v));
                if (k == "rd") {
                    material_->rd = v;
                    material_->rdColour = *colour_;
                } else {
                    material_->ed = v;
                    material_->edColour = *colour_;
                }
                material_->sceneIndex = -1;
            } else if (k == "sides") {
                needArgs(f, s, 1, 1);
                if (!material_) fail(f, s, "'sides' outside a material context");
                double v = num(f, s, 1);
                if (v != 1.0 && v != 2.0) fail(f, s, fmt::format("sides = {} must be 1 or 2", s.tok[1]));
                material_->sides = int(v);
                material_->sceneIndex = -1;
            } else if (k == "rs" || k == "ts" || k == "td" || k == "ir") {
                ++scene_.stats.ignoredStatements;
                warnOnce("ignored:" + k, fmt::format("{}:{}: MGF '{}' is ignored (hrad models diffuse "
                                                     "reflection and emission only)", f.path, s.line, k));
            } else if (k == "v") {
                vertexContext(f, s);
            } else if (k == "p" || k == "n") {
                needArgs(f, s, 3, 3);
                if (!vertex_) fail(f, s, fmt::format("'{}' outside a vertex context", k));
                Vec3 v(num(f, s, 1), num(f, s, 2), num(f, s, 3));
                if (k == "p") {
                    vertex_->p = v;
                    vertex_->hasP = true;
                } else {
                    vertex_->n = v;
                    vertex_->hasN = true;
                }
            } else if (k == "f") {
                if (s.tok.size() < 4) fail(f, s, "'f' needs at least 3 vertices");
                std::vector<Vec3> poly;
                poly.reserve(s.tok.size() - 1);
                for (size_t a = 1; a < s.tok.size(); ++a) poly.push_back(xf.point(vert(f, s, s.tok[a]).p));
                if (xf.mirror) std::reverse(poly.begin(), poly.end());
                emit(f, s, poly, currentMaterial());
            } else if (k == "sph" || k == "cyl" || k == "cone" || k == "ring" || k == "torus" || k == "prism") {
                primitive(f, s, xf);
            } else if (k == "o") {
                // Object names are not used.
            } else {
                ++scene_.stats.ignoredStatements;
                warnOnce("unknown:" + k, fmt::format("{}:{}: unknown MGF entity '{}' ignored", f.path, s.line, k));
            }
        }
    }

    void colourContext(const FileText& f, const Stmt& s) {
        size_t n = s.tok.size() - 1;
        if (n == 0) {
            unnamedColour_ = Chroma{};
            colour_ = &unnamedColour_;
        } else if (n == 1) {
            auto it = colours_.find(s.tok[1]);
            if (it == colours_.end()) fail(f, s, fmt::format("undefined colour '{}'", s.tok[1]));
            colour_ = &it->second;
        } else if (s.tok[2] == "=" && n <= 3) {
            Chroma init;
            if (n == 3) {
                auto it = colours_.find(s.tok[3]);
                if (it == colours_.end()) fail(f, s, fmt::format("undefined colour template '{}'", s.tok[3]));
                init = it->second;
            }
            colour_ = &(colours_[s.tok[1]] = init);
        } else {
            fail(f, s, "malformed 'c' (expected: c [name [= [template]]])");
        }
    }

    void materialContext(const FileText& f, const Stmt& s) {
        size_t n = s.tok.size() - 1;
        if (n == 0) {
            unnamedMaterial_ = MgfMaterial{};
            unnamedMaterial_.sides = opt_.defaultSides;
            material_ = &unnamedMaterial_;
            materialName_ = "mgf_default";
        } else if (n == 1) {
            auto it = materials_.find(s.tok[1]);
            if (it == materials_.end()) fail(f, s, fmt::format("undefined material '{}'", s.tok[1]));
            material_ = &it->second;
            materialName_ = s.tok[1];
        } else if (s.tok[2] == "=" && n <= 3) {
            MgfMaterial init;
            init.sides = opt_.defaultSides;
            if (n == 3) {
                auto it = materials_.find(s.tok[3]);
                if (it == materials_.end()) fail(f, s, fmt::format("undefined material template '{}'", s.tok[3]));
                init = it->second;
            }
            init.sceneIndex = -1;
            material_ = &(materials_[s.tok[1]] = init);
            materialName_ = s.tok[1];
        } else {
            fail(f, s, "malformed 'm' (expected: m [name [= [template]]])");
        }
    }

    void vertexContext(const FileText& f, const Stmt& s) {
        size_t n = s.tok.size() - 1;
        if (n == 0) {
            vertex_ = nullptr;
        } else if (n == 1) {
            auto it = vertices_.find(s.tok[1]);
            if (it == vertices_.end()) fail(f, s, fmt::format("undefined vertex '{}'", s.tok[1]));
            vertex_ = &it->second;
        } else if (s.tok[2] == "=" && n <= 3) {
            MgfVertex init;
            if (n == 3) {
                auto it = vertices_.find(s.tok[3]);
                if (it == vertices_.end()) fail(f, s, fmt::format("undefined vertex template '{}'", s.tok[3]));
                init = it->second;
            }
            vertex_ = &(vertices_[s.tok[1]] = init);
        } else {
            fail(f, s, "malformed 'v' (expected: v name [= [template]])");
        }
    }

    void spectrum(const FileText& f, const Stmt& s) {
        if (s.tok.size() < 5) fail(f, s, "cspec needs lambda_min lambda_max and at least 2 values");
        double l0 = num(f, s, 1), l1 = num(f, s, 2);
        if (!(l1 > l0)) fail(f, s, "cspec: lambda_max must exceed lambda_min");
        size_t nv = s.tok.size() - 3;
        Vec3 xyz(0.0);
        for (size_t k = 0; k < nv; ++k) {
            double v = num(f, s, 3 + k);
            if (v < 0) {  // measurement noise in real data (Materials/illums.mgf)
                warnOnce("cspec-negative", fmt::format("{}:{}: negative cspec values clipped to 0", f.path, s.line));
                v = 0;
            }
            xyz += v * cie1931(l0 + (l1 - l0) * double(k) / double(nv - 1));
        }
        if (!chromaFromXYZ(xyz, *colour_)) *colour_ = Chroma{};
        warnOnce("cspec", fmt::format("{}:{}: 'cspec' converted to a chromaticity with an analytic CIE "
                                      "1931 fit (Wyman et al. 2013)", f.path, s.line));
    }

    // Adds `poly`, reversed when its normal points away from `facing`.
    void emitFacing(const FileText& f, const Stmt& s, std::vector<Vec3> poly, const Vec3& facing, uint32_t m) {
        if (glm::dot(newellNormal(poly), facing) < 0) std::reverse(poly.begin(), poly.end());
        emit(f, s, poly, m);
    }

    static void basis(const Vec3& axis, Vec3& u, Vec3& w) {
        Vec3 a = std::fabs(axis.x) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
        u = glm::normalize(glm::cross(a, axis));
        w = glm::cross(axis, u);
    }

    void primitive(const FileText& f, const Stmt& s, const Xf& xf) {
        const std::string& k = s.tok[0];
        const int R = opt_.resolution;
        uint32_t m = currentMaterial();
        const double sc = xf.scale;
        if (k == "sph") {
            needArgs(f, s, 2, 2);
            Vec3 c = xf.point(vert(f, s, s.tok[1]).p);
            double r = num(f, s, 2) * sc;
            if (r == 0) fail(f, s, "sph: radius must be non-zero");
            // Past 1e150 the faces' areas overflow and they were dropped as
            // degenerate without a word (issue 64).
            if (!(std::fabs(r) <= 1e150) || !(glm::length(c) <= 1e150))
                fail(f, s, fmt::format("sph: radius {:.3g} or centre beyond 1e150: face areas would "
                                       "overflow", r));
            double sign = r > 0 ? 1.0 : -1.0;
            r = std::fabs(r);
            int nb = mgfSphereBands(R);
            auto P = [&](int j, int i) {
                double th = kPi * j / nb, ph = 2 * kPi * i / R;
                return c + r * Vec3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
            };
            for (int j = 0; j < nb; ++j)
                for (int i = 0; i < R; ++i) {
                    std::vector<Vec3> poly;
                    if (j == 0)
                        poly = {P(0, 0), P(1, i), P(1, i + 1)};
                    else if (j == nb - 1)
                        poly = {P(j, i), P(nb, 0), P(j, i + 1)};
                    else
                        poly = {P(j, i), P(j + 1, i), P(j + 1, i + 1), P(j, i + 1)};
                    Vec3 cen(0.0);
                    for (auto& p : poly) cen += p;
                    emitFacing(f, s, poly, sign * (cen / double(poly.size()) - c), m);
                }
        } else if (k == "cyl" || k == "cone") {
            bool cyl = k == "cyl";
            needArgs(f, s, cyl ? 3 : 4, cyl ? 3 : 4);
            Vec3 a = xf.point(vert(f, s, s.tok[1]).p);
            double r1 = num(f, s, 2) * sc;
            Vec3 b = xf.point(vert(f, s, s.tok[3]).p);
            double r2 = cyl ? r1 : num(f, s, 4) * sc;
            if ((r1 > 0 && r2 < 0) || (r1 < 0 && r2 > 0)) fail(f, s, fmt::format("{}: radii must have the same sign", k));
            if (r1 == 0 && r2 == 0) fail(f, s, fmt::format("{}: radii are both zero", k));
            double sign = (r1 < 0 || r2 < 0) ? -1.0 : 1.0;
            r1 = std::fabs(r1);
            r2 = std::fabs(r2);
            double h = glm::length(b - a);
            if (!(h > 0)) fail(f, s, fmt::format("{}: end points coincide", k));
            Vec3 ax = (b - a) / h, u, w;
            basis(ax, u, w);
            for (int i = 0; i < R; ++i) {
                double p0 = 2 * kPi * i / R, p1 = 2 * kPi * (i + 1) / R, pm = 0.5 * (p0 + p1);
                Vec3 d0 = std::cos(p0) * u + std::sin(p0) * w, d1 = std::cos(p1) * u + std::sin(p1) * w;
                Vec3 dm = std::cos(pm) * u + std::sin(pm) * w;
                std::vector<Vec3> poly;
                if (r1 > 0) poly.push_back(a + r1 * d0);
                if (r1 > 0) poly.push_back(a + r1 * d1);
                else poly.push_back(a);
                if (r2 > 0) poly.push_back(b + r2 * d1);
                if (r2 > 0) poly.push_back(b + r2 * d0);
                else poly.push_back(b);
                // Outward normal of the slanted side in the (radial, axial) plane.
                emitFacing(f, s, poly, sign * (h * dm + (r1 - r2) * ax), m);
            }
        } else if (k == "ring" || k == "torus") {
            needArgs(f, s, 3, 3);
            const MgfVertex& v = vert(f, s, s.tok[1], true);
            // The ring faces along the (transformed) vertex normal.
            Vec3 c = xf.point(v.p), ax = xf.normal(v.n);
            double r0 = num(f, s, 2) * sc, r1 = num(f, s, 3) * sc;
            Vec3 u, w;
            basis(ax, u, w);
            if (k == "ring") {
                if (!(r0 >= 0 && r1 > r0)) fail(f, s, "ring: needs 0 <= rmin < rmax");
                for (int i = 0; i < R; ++i) {
                    double p0 = 2 * kPi * i / R, p1 = 2 * kPi * (i + 1) / R;
                    Vec3 d0 = std::cos(p0) * u + std::sin(p0) * w, d1 = std::cos(p1) * u + std::sin(p1) * w;
                    if (r0 == 0)
                        emitFacing(f, s, {c, c + r1 * d0, c + r1 * d1}, ax, m);
                    else
                        emitFacing(f, s, {c + r0 * d0, c + r1 * d0, c + r1 * d1, c + r0 * d1}, ax, m);
                }
            } else {
                if ((r0 > 0 && r1 < 0) || (r0 < 0 && r1 > 0)) fail(f, s, "torus: radii must have the same sign");
                double sign = (r0 < 0 || r1 < 0) ? -1.0 : 1.0;
                r0 = std::fabs(r0);
                r1 = std::fabs(r1);
                if (!(r1 > r0)) fail(f, s, "torus: |rmax| must exceed |rmin|");
                double major = 0.5 * (r0 + r1), minor = 0.5 * (r1 - r0);
                int nb = mgfTorusBands(R);
                auto P = [&](int i, int j) {
                    double ph = 2 * kPi * i / R, th = 2 * kPi * j / nb;
                    Vec3 d = std::cos(ph) * u + std::sin(ph) * w;
                    return c + (major + minor * std::cos(th)) * d + minor * std::sin(th) * ax;
                };
                for (int i = 0; i < R; ++i)
                    for (int j = 0; j < nb; ++j) {
                        std::vector<Vec3> poly = {P(i, j), P(i + 1, j), P(i + 1, j + 1), P(i, j + 1)};
                        double pm = 2 * kPi * (i + 0.5) / R;
                        Vec3 ring = c + major * (std::cos(pm) * u + std::sin(pm) * w);
                        Vec3 cen = 0.25 * (poly[0] + poly[1] + poly[2] + poly[3]);
                        emitFacing(f, s, poly, sign * (cen - ring), m);
                    }
            }
        } else {  // prism v1 ... vn length
            if (s.tok.size() < 5) fail(f, s, "prism needs at least 3 vertices and a length");
            std::vector<Vec3> base;
            for (size_t a = 1; a + 1 < s.tok.size(); ++a) base.push_back(xf.point(vert(f, s, s.tok[a]).p));
            if (xf.mirror) std::reverse(base.begin(), base.end());
            double len = num(f, s, s.tok.size() - 1) * sc;
            Vec3 nn = newellNormal(base);
            if (!(glm::length(nn) > 0)) fail(f, s, "prism: base polygon has no area");
            // mgflib extrudes away from the base's front: the base faces out.
            Vec3 d = -len * glm::normalize(nn);
            size_t nv = base.size();
            emit(f, s, base, m);
            std::vector<Vec3> top;
            for (size_t a = nv; a-- > 0;) top.push_back(base[a] + d);
            emit(f, s, top, m);
            for (size_t a = 0; a < nv; ++a) {
                const Vec3& p = base[a];
                const Vec3& q = base[(a + 1) % nv];
                emit(f, s, {q, p, p + d, q + d}, m);
            }
        }
    }
};

}  // namespace

RGB chromaticityToRgb(double x, double y, double luminance, const std::string& whitePoint) {
    MgfOptions o;
    o.whitePoint = whitePoint;
    MgfLoader l(o);
    return l.toRgb(Chroma{x, y}, luminance);
}

Scene loadMgf(const std::string& path, const MgfOptions& options) {
    MgfLoader loader(options);
    return loader.run(path);
}

}  // namespace hrad::scene
