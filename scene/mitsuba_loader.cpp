// Mitsuba 3 XML loader (see mitsuba_loader.h for what maps to what).
#include "scene/mitsuba_loader.h"

#include <ImfArray.h>
#include <ImfRgbaFile.h>
#include <png.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>

#include <glm/gtc/matrix_transform.hpp>
#include <pugixml.hpp>
// Debian libstb-dev: the implementation is in libstb.so (no STB_IMAGE_IMPLEMENTATION here).
#include <stb/stb_image.h>

#include "core/error.h"
#include "scene/mitsuba_serialized.h"
#include "scene/obj_loader.h"
#include "scene/ply_loader.h"
#include "scene/texture.h"
#include "scene/triangulate.h"

namespace hrad::scene {

namespace {

namespace fs = std::filesystem;
constexpr double kPi = std::numbers::pi;

// ---------------------------------------------------------------------------
// Colour science.

/// Piecewise Gaussian g(x; mu, s1, s2) of Wyman, Sloan & Shirley 2013, eq. 2.
double pg(double x, double mu, double s1, double s2) {
    double t = (x - mu) / (x < mu ? s1 : s2);
    return std::exp(-0.5 * t * t);
}

/// CIE 1931 2-degree colour matching functions, multi-lobe fit of Wyman,
/// Sloan & Shirley, "Simple Analytic Approximations to the CIE XYZ Color
/// Matching Functions", JCGT 2(2), 2013, eq. 2.
Vec3 cieXyz(double nm) {
    double x = 1.056 * pg(nm, 599.8, 37.9, 31.0) + 0.362 * pg(nm, 442.0, 16.0, 26.7) -
               0.065 * pg(nm, 501.1, 20.4, 26.2);
    double y = 0.821 * pg(nm, 568.8, 46.9, 40.5) + 0.286 * pg(nm, 530.9, 16.3, 31.1);
    double z = 1.217 * pg(nm, 437.0, 11.8, 36.0) + 0.681 * pg(nm, 459.0, 26.0, 13.8);
    return {x, y, z};
}

/// XYZ -> linear sRGB (IEC 61966-2-1, D65 white).
RGB xyzToLinearSrgb(const Vec3& c) {
    return {3.2404542 * c.x - 1.5371385 * c.y - 0.4985314 * c.z,
            -0.9692660 * c.x + 1.8760108 * c.y + 0.0415560 * c.z,
            0.0556434 * c.x - 0.2040259 * c.y + 1.0572252 * c.z};
}

using Samples = std::vector<std::pair<double, double>>;  // (nm, value), sorted

/// XYZ of a piecewise-linear spectrum (zero outside its samples), normalised
/// by the integral of y-bar: equal-energy white of value 1 has Y = 1.
Vec3 spectrumXyz(const Samples& s) {
    Vec3 sum(0.0);
    double ySum = 0.0;
    for (int nm = 360; nm <= 830; ++nm) {
        Vec3 cmf = cieXyz(nm);
        ySum += cmf.y;
        double v = 0.0;
        if (nm >= s.front().first && nm <= s.back().first) {
            auto it = std::lower_bound(s.begin(), s.end(), double(nm),
                                       [](const auto& a, double b) { return a.first < b; });
            if (it->first == nm || it == s.begin()) {
                v = it->second;
            } else {
                auto lo = it - 1;
                double t = (nm - lo->first) / (it->first - lo->first);
                v = lo->second + t * (it->second - lo->second);
            }
        }
        sum += v * cmf;
    }
    return sum / ySum;
}

RGB spectrumToRgb(const Samples& s, bool emission) {
    RGB rgb = xyzToLinearSrgb(spectrumXyz(s));
    if (!emission) {
        // A flat reflectance spectrum maps to the same neutral grey.
        Samples flat{{360.0, 1.0}, {830.0, 1.0}};
        rgb /= xyzToLinearSrgb(spectrumXyz(flat));
    }
    return glm::max(rgb, RGB(0.0));
}

double srgbToLinear(double v) {
    // IEC 61966-2-1 transfer function.
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// ---------------------------------------------------------------------------
// XML files with line numbers.

struct XmlFile {
    std::string path;
    pugi::xml_document doc;
    std::vector<size_t> lineStarts;  ///< byte offset of each line's start

    int lineOf(ptrdiff_t offset) const {
        if (offset < 0) return 0;
        auto it = std::upper_bound(lineStarts.begin(), lineStarts.end(), size_t(offset));
        return int(it - lineStarts.begin());
    }
};

struct Node {
    pugi::xml_node n;
    const XmlFile* f = nullptr;
    explicit operator bool() const { return bool(n); }
    const void* key() const { return n.internal_object(); }
};

/// Mitsuba 0.5/0.6 camelCase names -> Mitsuba 3 snake_case ("toWorld" ->
/// "to_world", "intIOR" -> "int_ior").
std::string snakeCase(const std::string& s) {
    std::string out;
    for (size_t i = 0; i < s.size(); ++i) {
        char c = s[i];
        if (std::isupper((unsigned char)c)) {
            if (i > 0 && std::islower((unsigned char)s[i - 1])) out += '_';
            out += char(std::tolower((unsigned char)c));
        } else {
            out += c;
        }
    }
    return out;
}

const std::vector<std::string> kShapeTypes = {"obj", "ply", "serialized", "rectangle", "disk", "cube",
                                              "sphere", "cylinder", "instance", "shapegroup"};
// Mitsuba shapes hrad cannot turn into polygons: warned about, not added.
const std::vector<std::string> kUnsupportedShapes = {"bsplinecurve", "linearcurve", "sdfgrid",
                                                     "ellipsoids", "ellipsoidsmesh", "hair",
                                                     "heightfield"};
const std::vector<std::string> kBsdfTypes = {
    "diffuse",     "roughdiffuse", "plastic",    "roughplastic",   "pplastic",  "conductor",
    "roughconductor", "principled", "principledthin", "twosided", "mask",      "bumpmap",
    "normalmap",   "blendbsdf",    "dielectric", "thindielectric", "roughdielectric", "null",
    "measured",    "hair",         "polarizer",  "retarder",       "circular",  "coating",
    "roughcoating", "phong",       "ward",       "difftrans"};
const std::vector<std::string> kEmitterTypes = {"area",   "point",    "spot",   "directional",
                                                "envmap", "constant", "projector", "sunsky",
                                                "directionalarea", "sun", "sky"};
const std::vector<std::string> kTopTags = {"shape",   "bsdf",   "texture", "emitter", "sensor",
                                           "integrator", "sampler", "film", "rfilter", "medium",
                                           "phase",   "volume", "spectrum", "default", "include",
                                           "path"};

std::string joinNames(const std::vector<std::string>& v) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
    return s;
}

bool contains(const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
}

struct BsdfInfo {
    RGB rho{0.5};
    int32_t texture = -1;  ///< the diffuse albedo's bitmap (Scene::textures), -1 none
    bool twoSided = false;
    bool transparent = false;
};

class Loader {
  public:
    explicit Loader(const MitsubaOptions& o) : opt_(o), params_(o.params) { budget_.maxBytes = o.textureBudget; }

    Scene run(const std::string& path) {
        scene_.source = "mitsuba";
        scene_.upAxis = 1;
        const XmlFile& root = parse(path, SourceLocation{});
        collect(root, root.doc.document_element(), 0);
        for (const Node& n : top_) topLevel(n);
        for (const auto& [id, n] : ids_)
            if (std::string(n.n.name()) == "emitter" && !usedEmitters_.count(n.key()) &&
                attr(n, "type") == "area")
            {
                warn(n, fmt::format("area emitter '{}' is attached to no shape: ignored", id));
                scene_.stats.dropEmitter("area emitter on no shape", where(n));
            }
        if (scene_.patches.empty()) {
            // Nothing left: the missing files are the news (throws if any).
            scene_.stats.missingFiles.apply(false, scene_.stats.warnings);
            throwInputError(SourceLocation{path, 0, 0}, "the scene has no shape hrad can use");
        }
        return std::move(scene_);
    }

  private:
    const MitsubaOptions& opt_;
    Scene scene_;
    std::map<std::string, std::string> params_;
    std::deque<std::unique_ptr<XmlFile>> files_;
    static constexpr int kMaxXmlDepth = 128;       ///< element nesting, any file
    static constexpr int kMaxXmlParses = 10000;    ///< files parsed, includes counted each time
    static constexpr uint64_t kMaxXmlBytes = uint64_t(512) << 20;  ///< bytes parsed, likewise
    int parses_ = 0;
    uint64_t parsedBytes_ = 0;
    std::vector<std::string> includeStack_;
    std::vector<Node> top_;
    std::map<std::string, Node> ids_;
    std::map<const void*, BsdfInfo> bsdfs_;
    std::map<std::pair<const void*, const void*>, uint32_t> materials_;
    std::set<const void*> usedEmitters_;
    std::set<std::string> warnedOnce_;
    uint64_t shapesVisited_ = 0;  ///< shapes met, through instances included
    uint64_t inflated_ = 0;       ///< bytes .serialized meshes inflated to so far
    bool haveCamera_ = false;
    /// (file, raw) -> the texture's mean, or why it could not be read.
    /// (file [+ "#raw"], wrap) -> the texture's index in scene_.textures
    /// (-1: not decoded, with why).
    std::map<std::pair<std::string, int>, std::pair<int32_t, std::string>> textureCache_;
    TextureBudget budget_;
    /// The bitmap the last colour property read was (-1: none): a diffuse
    /// albedo that is a bitmap keeps it as its texture.
    int32_t lastBitmap_ = -1;
    size_t lastBitmapNote_ = 0;  ///< its "-> its mean" note, dropped when it is kept
    uint64_t faces_ = 0;

    // --- locations, warnings, errors -------------------------------------

    SourceLocation loc(const Node& n) const {
        return SourceLocation{n.f->path, n.f->lineOf(n.n.offset_debug()), 0};
    }
    std::string where(const Node& n) const { return loc(n).str(); }
    template <typename... Args>
    [[noreturn]] void fail(const Node& n, fmt::format_string<Args...> f, Args&&... args) const {
        throwInputError(loc(n), f, std::forward<Args>(args)...);
    }
    /// Counted, not repeated (core/warning_log.h): an element seen again
    /// through instances, or the same problem on other elements, adds to one
    /// line (10^8 instances of a skipped shape held 7.6 GiB of warnings, issue 64).
    void warn(const Node& n, const std::string& msg) {
        scene_.stats.warnings.push_back(fmt::format("{}: warning: {}", where(n), msg));
    }

    // --- parsing and includes --------------------------------------------

    const XmlFile& parse(const std::string& path, const SourceLocation& from) {
        auto file = std::make_unique<XmlFile>();
        file->path = path;
        std::ifstream in(path, std::ios::binary);
        if (!in) throwInputError(from.known() ? from : SourceLocation{path, 0, 0}, "cannot open '{}'", path);
        std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        parsedBytes_ += text.size();
        if (parsedBytes_ > kMaxXmlBytes)
            throwInputError(from.known() ? from : SourceLocation{path, 0, 0},
                            "more than {} MiB of XML parsed through <include> (an include fan-out?)",
                            kMaxXmlBytes >> 20);
        file->lineStarts.push_back(0);
        for (size_t i = 0; i < text.size(); ++i)
            if (text[i] == '\n') file->lineStarts.push_back(i + 1);
        pugi::xml_parse_result r = file->doc.load_buffer(text.data(), text.size(),
                                                         pugi::parse_default, pugi::encoding_utf8);
        if (!r)
            throwInputError(SourceLocation{path, file->lineOf(r.offset), 0}, "malformed XML: {}",
                            r.description());
        // The loader's passes recurse over elements: bound the nesting
        // first (pugixml's walker is iterative; 200,000 nested elements
        // overflowed the stack, issue 64).
        struct DepthWalker : pugi::xml_tree_walker {
            ptrdiff_t offset = -1;
            bool for_each(pugi::xml_node& n) override {
                if (depth() < kMaxXmlDepth) return true;
                offset = n.offset_debug();
                return false;
            }
        } walker;
        file->doc.traverse(walker);
        if (walker.offset >= 0)
            throwInputError(SourceLocation{path, file->lineOf(walker.offset), 0},
                            "elements nested deeper than {} levels", kMaxXmlDepth);
        // Each include is parsed where it appears: a tree of files each
        // including the next twice would parse 2^depth files.
        if (++parses_ > kMaxXmlParses)
            throwInputError(from.known() ? from : SourceLocation{path, 0, 0},
                            "more than {} files parsed through <include> (an include fan-out?)",
                            kMaxXmlParses);
        pugi::xml_node root = file->doc.document_element();
        if (!root || std::string(root.name()) != "scene")
            throwInputError(SourceLocation{path, root ? file->lineOf(root.offset_debug()) : 1, 0},
                            "the root element must be <scene>, not <{}>", root ? root.name() : "");
        files_.push_back(std::move(file));
        return *files_.back();
    }

    /// First pass over the document tree, includes expanded: defaults, ids,
    /// and the top-level elements in order.
    void collect(const XmlFile& f, pugi::xml_node root, int depth) {
        for (pugi::xml_node c = root.first_child(); c; c = c.next_sibling()) {
            if (c.type() != pugi::node_element) continue;
            Node n{c, &f};
            std::string tag = c.name();
            if (tag == "default") {
                std::string name = rawAttr(n, "name"), value = rawAttr(n, "value");
                if (!params_.count(name)) params_[name] = value;
            } else if (tag == "include") {
                std::string rel = attr(n, "filename");
                fs::path p = filePath(n, rel);
                std::error_code ec;
                if (fs::exists(p, ec) && !fs::is_regular_file(p, ec))
                    fail(n, "included file '{}' is not a regular file", p.string());
                if (!fs::exists(p, ec)) {  // scene.missing (scene/missing_files.h)
                    scene_.stats.missingFiles.add(loc(n), "included file", p.string());
                    continue;
                }
                std::string canon = fs::weakly_canonical(p, ec).string();
                if (contains(includeStack_, canon)) fail(n, "'{}' includes itself (include cycle)", rel);
                if (depth >= 32) fail(n, "includes nested deeper than 32 levels");
                includeStack_.push_back(canon);
                const XmlFile& sub = parse(p.string(), loc(n));
                collect(sub, sub.doc.document_element(), depth + 1);
                includeStack_.pop_back();
            } else {
                if (!contains(kTopTags, tag))
                    fail(n, "unknown element <{}> (expected one of {})", tag, joinNames(kTopTags));
                top_.push_back(n);
                registerIds(n);
            }
        }
    }

    void registerIds(const Node& n) {
        if (std::string(n.n.name()) == "ref") return;
        if (pugi::xml_attribute id = n.n.attribute("id")) {
            std::string name = id.value();
            auto [it, inserted] = ids_.emplace(name, n);
            if (!inserted && it->second.n != n.n)
                fail(n, "id '{}' is defined twice (first at {})", name, where(it->second));
        }
        for (pugi::xml_node c = n.n.first_child(); c; c = c.next_sibling())
            if (c.type() == pugi::node_element) registerIds(Node{c, n.f});
    }

    std::string rawAttr(const Node& n, const char* name) const {
        pugi::xml_attribute a = n.n.attribute(name);
        if (!a) fail(n, "<{}> needs the attribute '{}'", n.n.name(), name);
        return a.value();
    }

    /// Attribute value with $name substitution.
    std::string attr(const Node& n, const char* name) const { return substitute(n, rawAttr(n, name)); }

    std::string substitute(const Node& n, const std::string& s) const {
        std::string out;
        for (size_t i = 0; i < s.size(); ++i) {
            if (s[i] != '$') {
                out += s[i];
                continue;
            }
            size_t j = i + 1;
            while (j < s.size() && (std::isalnum((unsigned char)s[j]) || s[j] == '_')) ++j;
            std::string key = s.substr(i + 1, j - i - 1);
            if (key.empty()) {
                out += '$';
                continue;
            }
            auto it = params_.find(key);
            if (it == params_.end())
                fail(n, "undefined parameter '${}' (give it with <default name=\"{}\" value=...> or the "
                     "setting mitsuba.param.{})", key, key, key);
            out += it->second;
            i = j - 1;
        }
        return out;
    }

    Node resolve(const Node& ref) const {
        std::string id = attr(ref, "id");
        auto it = ids_.find(id);
        if (it == ids_.end()) fail(ref, "reference to undefined id '{}'", id);
        return it->second;
    }

    // --- numbers and properties ------------------------------------------

    std::vector<double> numbers(const Node& n, const std::string& text, const char* what) const {
        std::vector<double> v;
        const char* p = text.c_str();
        for (;;) {
            while (*p && (std::isspace((unsigned char)*p) || *p == ',')) ++p;
            if (!*p) break;
            char* end = nullptr;
            double x = std::strtod(p, &end);
            if (end == p || !std::isfinite(x)) fail(n, "{}: '{}' is not a list of finite numbers", what, text);
            v.push_back(x);
            p = end;
        }
        return v;
    }
    double number(const Node& n, const char* a) const {
        std::vector<double> v = numbers(n, attr(n, a), a);
        if (v.size() != 1) fail(n, "attribute '{}' must be one number, not '{}'", a, attr(n, a));
        return v[0];
    }
    Vec3 vec3Attr(const Node& n, const char* a) const {
        std::vector<double> v = numbers(n, attr(n, a), a);
        if (v.size() != 3) fail(n, "attribute '{}' must be three numbers, not '{}'", a, attr(n, a));
        return {v[0], v[1], v[2]};
    }

    /// The child property element named `name` (snake_case), or none.
    Node prop(const Node& plugin, const std::string& name) const {
        for (pugi::xml_node c = plugin.n.first_child(); c; c = c.next_sibling())
            if (c.type() == pugi::node_element && c.attribute("name") &&
                snakeCase(c.attribute("name").value()) == name)
                return Node{c, plugin.f};
        return Node{};
    }
    double floatProp(const Node& plugin, const std::string& name, double def) const {
        Node p = prop(plugin, name);
        if (!p) return def;
        return number(p, "value");
    }
    std::string stringProp(const Node& plugin, const std::string& name, const std::string& def) const {
        Node p = prop(plugin, name);
        return p ? attr(p, "value") : def;
    }
    bool boolProp(const Node& plugin, const std::string& name, bool def) const {
        Node p = prop(plugin, name);
        if (!p) return def;
        std::string v = attr(p, "value");
        if (v == "true") return true;
        if (v == "false") return false;
        fail(p, "boolean '{}' must be true or false, not '{}'", name, v);
    }
    Vec3 pointProp(const Node& plugin, const std::string& name, Vec3 def) const {
        Node p = prop(plugin, name);
        if (!p) return def;
        if (p.n.attribute("value")) return vec3Attr(p, "value");
        Vec3 r(0.0);
        const char* axes[3] = {"x", "y", "z"};
        for (int k = 0; k < 3; ++k)
            if (p.n.attribute(axes[k])) r[k] = number(p, axes[k]);
        return r;
    }
    /// A file named in the scene: absolute, else relative to the file that
    /// names it, else relative to the main scene file (Mitsuba's file
    /// resolver searches the main scene's folder: cbox-rgb.xml includes
    /// fragments/shapes.xml, which names meshes/... from the main folder).
    std::string filePath(const Node& n, const std::string& rel) const {
        fs::path p(rel);
        if (p.is_absolute()) return rel;
        std::error_code ec;
        fs::path local = fs::path(n.f->path).parent_path() / p;
        if (fs::exists(local, ec)) return local.string();
        fs::path main = fs::path(files_.front()->path).parent_path() / p;
        if (fs::exists(main, ec)) return main.string();
        return local.string();
    }

    /// A colour property (rgb, srgb, spectrum, float, texture, ref) as linear
    /// RGB; notes collect what was approximated.
    std::optional<RGB> colorProp(const Node& plugin, const std::string& name, bool emission,
                                 std::vector<std::string>& notes) {
        Node p = prop(plugin, name);
        if (!p) return std::nullopt;
        return color(p, name, emission, notes);
    }

    RGB color(Node p, const std::string& name, bool emission, std::vector<std::string>& notes) {
        std::string tag = p.n.name();
        if (tag == "ref") {
            p = resolve(p);
            tag = p.n.name();
        }
        if (tag == "rgb" || tag == "color") {
            std::vector<double> v = numbers(p, attr(p, "value"), "rgb value");
            if (v.size() == 1) return RGB(v[0]);
            if (v.size() != 3) fail(p, "rgb '{}' needs 1 or 3 values", name);
            return {v[0], v[1], v[2]};
        }
        if (tag == "srgb") {
            std::string s = attr(p, "value");
            RGB c;
            if (!s.empty() && s[0] == '#') {
                if (s.size() != 7) fail(p, "srgb '{}' must be #RRGGBB", s);
                for (int k = 0; k < 3; ++k) {
                    char* end = nullptr;
                    std::string hex = s.substr(1 + 2 * k, 2);
                    long x = std::strtol(hex.c_str(), &end, 16);
                    if (*end) fail(p, "srgb '{}' is not a hex colour", s);
                    c[k] = x / 255.0;
                }
            } else {
                std::vector<double> v = numbers(p, s, "srgb value");
                if (v.size() != 1 && v.size() != 3) fail(p, "srgb '{}' needs 1 or 3 values", name);
                c = v.size() == 1 ? RGB(v[0]) : RGB(v[0], v[1], v[2]);
            }
            for (int k = 0; k < 3; ++k) c[k] = srgbToLinear(c[k]);
            return c;
        }
        if (tag == "float") return RGB(number(p, "value"));
        if (tag == "spectrum") return spectrum(p, emission);
        if (tag == "texture") return textureMean(p, name, notes);
        fail(p, "property '{}' must be rgb, srgb, spectrum, float or texture, not <{}>", name, tag);
    }

    RGB spectrum(const Node& p, bool emission) {
        Samples s;
        if (p.n.attribute("filename")) {
            std::string file = filePath(p, attr(p, "filename"));
            std::error_code ec;
            if (fs::exists(file, ec) && !fs::is_regular_file(file, ec))
                fail(p, "spectrum file '{}' is not a regular file (a FIFO, device or folder)", file);
            if (!fs::exists(file, ec)) {  // scene.missing: grey, or no emission
                scene_.stats.missingFiles.add(loc(p), "spectrum file", file);
                return emission ? RGB(0.0) : RGB(opt_.defaultRho);
            }
            std::ifstream in(file);
            if (!in) fail(p, "spectrum file '{}' cannot be read", file);
            std::string line;
            int ln = 0;
            while (std::getline(in, line)) {
                ++ln;
                size_t h = line.find('#');
                if (h != std::string::npos) line.resize(h);
                std::istringstream ls(line);
                double a, b;
                if (!(ls >> a)) continue;
                if (!(ls >> b) || !std::isfinite(a) || !std::isfinite(b))
                    throwInputError(SourceLocation{file, ln, 0}, "expected 'wavelength value'");
                s.push_back({a, b});
            }
        } else {
            std::string v = attr(p, "value");
            if (v.find(':') == std::string::npos) {
                std::vector<double> x = numbers(p, v, "spectrum value");
                if (x.size() != 1) fail(p, "spectrum '{}' needs one value or 'nm:value' pairs", v);
                return RGB(x[0]);  // uniform spectrum: the same value in every channel
            }
            std::string item;
            std::istringstream ss(v);
            while (std::getline(ss, item, ',')) {
                size_t c = item.find(':');
                if (c == std::string::npos) fail(p, "spectrum entry '{}' is not 'nm:value'", item);
                std::vector<double> a = numbers(p, item.substr(0, c), "wavelength");
                std::vector<double> b = numbers(p, item.substr(c + 1), "spectrum value");
                if (a.size() != 1 || b.size() != 1) fail(p, "spectrum entry '{}' is not 'nm:value'", item);
                s.push_back({a[0], b[0]});
            }
        }
        if (s.empty()) fail(p, "empty spectrum");
        for (size_t i = 1; i < s.size(); ++i)
            if (!(s[i].first > s[i - 1].first)) fail(p, "spectrum wavelengths must increase");
        return spectrumToRgb(s, emission);
    }

    RGB textureMean(const Node& t, const std::string& name, std::vector<std::string>& notes) {
        std::string type = attr(t, "type");
        RGB grey(opt_.textureRho);
        if (type == "checkerboard") {
            std::vector<std::string> sub;
            RGB c0 = colorProp(t, "color0", false, sub).value_or(RGB(0.4));
            RGB c1 = colorProp(t, "color1", false, sub).value_or(RGB(0.2));
            RGB m = 0.5 * (c0 + c1);
            notes.push_back(fmt::format("{} checkerboard texture -> its mean ({:.3g}, {:.3g}, {:.3g})", name, m.r, m.g, m.b));
            return m;
        }
        if (type != "bitmap") {
            notes.push_back(fmt::format("{} texture '{}' not evaluated -> grey {} (mitsuba.texture_rho)", name, type,
                                        opt_.textureRho));
            return grey;
        }
        std::string file = filePath(t, stringProp(t, "filename", ""));
        bool raw = boolProp(t, "raw", false);
        const std::string wrapName = stringProp(t, "wrap_mode", "repeat");
        const TextureWrap wrap = wrapName == "clamp"    ? TextureWrap::Clamp
                                 : wrapName == "mirror" ? TextureWrap::Mirror
                                                        : TextureWrap::Repeat;
        if (wrapName != "repeat" && wrapName != "clamp" && wrapName != "mirror")
            fail(t, "wrap_mode '{}' must be repeat, mirror or clamp", wrapName);
        std::error_code ec;
        if (!fs::is_regular_file(file, ec)) {
            if (!fs::exists(file, ec)) scene_.stats.missingFiles.add(loc(t), "texture", file);  // scene.missing
            notes.push_back(fmt::format("{} texture '{}' not found -> grey {} (mitsuba.texture_rho)", name, file,
                                        opt_.textureRho));
            return grey;
        }
        // One decode per file, encoding and wrap mode: materials often share a
        // texture (the bathroom's wood.jpg, 910 x 2048, serves two).
        auto [slot, fresh] = textureCache_.try_emplace(
            {fs::weakly_canonical(file, ec).string() + (raw ? "#raw" : ""), int(wrap)}, -1, std::string());
        auto& [index, why] = slot->second;
        if (fresh) {
            std::optional<Texture> tex = decodeTextureFile(
                file, raw ? TextureEncoding::Linear : TextureEncoding::Srgb, budget_,
                SourceLocation{t.f->path, t.f->lineOf(t.n.offset_debug()), 0}, why);
            if (tex) {
                tex->wrapU = tex->wrapV = wrap;
                index = addTexture(scene_, std::move(*tex));
            } else if (why.empty()) {
                why = "unreadable";
            }
        }
        if (index < 0) {
            notes.push_back(fmt::format("{} texture '{}': {} -> grey {} (mitsuba.texture_rho)", name,
                                        fs::path(file).filename().string(), why, opt_.textureRho));
            return grey;
        }
        lastBitmap_ = index;
        const RGB* mean = &scene_.textures[size_t(index)]->mean;
        lastBitmapNote_ = notes.size();
        notes.push_back(fmt::format("{} texture '{}' -> its mean ({:.3g}, {:.3g}, {:.3g})", name,
                                    fs::path(file).filename().string(), mean->r, mean->g, mean->b));
        return *mean;
    }

    // --- transforms --------------------------------------------------------

    glm::dmat4 transform(const Node& t) const {
        glm::dmat4 m(1.0);
        for (pugi::xml_node c = t.n.first_child(); c; c = c.next_sibling()) {
            if (c.type() != pugi::node_element) continue;
            Node n{c, t.f};
            std::string op = snakeCase(c.name());
            glm::dmat4 s(1.0);
            if (op == "matrix") {
                std::vector<double> v = numbers(n, attr(n, "value"), "matrix value");
                if (v.size() == 16) {
                    for (int r = 0; r < 4; ++r)
                        for (int k = 0; k < 4; ++k) s[k][r] = v[size_t(r * 4 + k)];
                } else if (v.size() == 9) {
                    for (int r = 0; r < 3; ++r)
                        for (int k = 0; k < 3; ++k) s[k][r] = v[size_t(r * 3 + k)];
                } else {
                    fail(n, "bad transform: <matrix> needs 16 (or 9) values, got {}", v.size());
                }
            } else if (op == "translate") {
                Vec3 d(0.0);
                if (c.attribute("value")) d = vec3Attr(n, "value");
                const char* axes[3] = {"x", "y", "z"};
                for (int k = 0; k < 3; ++k)
                    if (c.attribute(axes[k])) d[k] = number(n, axes[k]);
                s = glm::translate(glm::dmat4(1.0), d);
            } else if (op == "scale") {
                Vec3 d(1.0);
                if (c.attribute("value")) {
                    std::vector<double> v = numbers(n, attr(n, "value"), "scale value");
                    if (v.size() == 1) d = Vec3(v[0]);
                    else if (v.size() == 3) d = Vec3(v[0], v[1], v[2]);
                    else fail(n, "bad transform: <scale value> needs 1 or 3 numbers");
                }
                const char* axes[3] = {"x", "y", "z"};
                for (int k = 0; k < 3; ++k)
                    if (c.attribute(axes[k])) d[k] = number(n, axes[k]);
                s = glm::scale(glm::dmat4(1.0), d);
            } else if (op == "rotate") {
                Vec3 axis(0.0);
                if (c.attribute("axis")) axis = vec3Attr(n, "axis");
                const char* axes[3] = {"x", "y", "z"};
                for (int k = 0; k < 3; ++k)
                    if (c.attribute(axes[k])) axis[k] = number(n, axes[k]);
                if (!(glm::length(axis) > 0)) fail(n, "bad transform: <rotate> needs a non-zero axis");
                double angle = number(n, "angle");
                s = glm::rotate(glm::dmat4(1.0), glm::radians(angle), glm::normalize(axis));
            } else if (op == "lookat" || op == "look_at") {
                Vec3 o = vec3Attr(n, "origin"), tg = vec3Attr(n, "target");
                Vec3 up = c.attribute("up") ? vec3Attr(n, "up") : Vec3(0, 1, 0);
                Vec3 dir = tg - o;
                if (!(glm::length(dir) > 0)) fail(n, "bad transform: <lookat> origin equals target");
                dir = glm::normalize(dir);
                Vec3 left = glm::cross(up, dir);
                if (!(glm::length(left) > 1e-12 * glm::length(up)))
                    fail(n, "bad transform: <lookat> up is parallel to the view direction");
                left = glm::normalize(left);
                Vec3 newUp = glm::cross(dir, left);
                // Mitsuba's Transform::look_at: columns left, up, dir, origin.
                s = glm::dmat4(glm::dvec4(left, 0), glm::dvec4(newUp, 0), glm::dvec4(dir, 0), glm::dvec4(o, 1));
            } else {
                fail(n, "bad transform: unknown operation <{}> (expected matrix, translate, rotate, "
                     "scale, lookat)", c.name());
            }
            m = s * m;
        }
        double det = glm::determinant(glm::dmat3(m));
        bool finite = true;
        for (int a = 0; a < 4; ++a)
            for (int b = 0; b < 4; ++b) finite = finite && std::isfinite(m[a][b]);
        if (!finite) fail(t, "bad transform: non-finite matrix");
        if (!(std::abs(det) > 1e-300)) fail(t, "bad transform: the matrix is singular (determinant {})", det);
        if (std::abs(m[0][3]) + std::abs(m[1][3]) + std::abs(m[2][3]) > 1e-12 || std::abs(m[3][3] - 1) > 1e-12)
            fail(t, "bad transform: projective matrices are not supported (last row must be 0 0 0 1)");
        return m;
    }

    glm::dmat4 toWorld(const Node& plugin) const {
        Node t = prop(plugin, "to_world");
        if (!t) return glm::dmat4(1.0);
        if (std::string(t.n.name()) != "transform") fail(t, "'to_world' must be a <transform>");
        return transform(t);
    }

    // --- non-area emitters (scene/lights/light.h) ------------------------------

    /// Mitsuba 3's parameters of a point, spot, directional or constant
    /// emitter: position or to_world (point), to_world looking along +z
    /// (spot), direction or to_world's +z (directional); intensity,
    /// irradiance, radiance default 1 as in Mitsuba.
    LightSpec lightSpec(const Node& n, const std::string& kind) {
        LightSpec s;
        s.kind = kind;
        s.where = loc(n);
        const glm::dmat4 m = toWorld(n);
        const char* valueName = kind == "directional" ? "irradiance"
                                : kind == "constant"  ? "radiance"
                                                      : "intensity";
        std::vector<std::string> notes;
        s.value = colorProp(n, valueName, true, notes).value_or(RGB(1.0));
        if (!notes.empty()) warn(n, std::string(valueName) + ": " + notes.front());
        s.position = Vec3(m * glm::dvec4(0, 0, 0, 1));
        s.position = pointProp(n, "position", s.position);
        s.direction = Vec3(m * glm::dvec4(0, 0, 1, 0));
        if (kind == "directional") s.direction = pointProp(n, "direction", s.direction);
        s.cutoffDegrees = floatProp(n, "cutoff_angle", s.cutoffDegrees);
        s.beamDegrees = floatProp(n, "beam_width", s.beamDegrees);
        return s;
    }

    /// Mitsuba 3's envmap: filename (a missing file is recorded for
    /// scene.missing, which drops the emitter or names it in the error),
    /// scale, to_world's linear part (scene/lights/envmap.cpp); the decode
    /// books the scene's texture budget.
    void envmap(const Node& n) {
        Node fp = prop(n, "filename");
        if (!fp) fail(n, "envmap emitter needs a 'filename'");
        LightSpec s;
        s.kind = "envmap";
        s.where = loc(n);
        s.filename = filePath(fp, attr(fp, "value"));
        s.scale = floatProp(n, "scale", 1.0);
        s.toWorld = glm::dmat3(toWorld(n));
        s.budget = &budget_;
        std::error_code ec;
        if (!fs::exists(s.filename, ec)) {
            scene_.stats.missingFiles.add(loc(fp), "environment map", s.filename);
            scene_.stats.dropEmitter("envmap with a missing file", where(n));
            return;
        }
        scene_.lights.push_back(makeLight(s));
    }

    // --- top level -----------------------------------------------------------

    void topLevel(const Node& n) {
        std::string tag = n.n.name();
        if (tag == "shape") {
            std::string type = attr(n, "type");
            if (type != "shapegroup") shape(n, glm::dmat4(1.0), 0);
        } else if (tag == "emitter") {
            std::string type = attr(n, "type");
            if (!contains(kEmitterTypes, type))
                fail(n, "unknown emitter plugin '{}' (expected one of {})", type, joinNames(kEmitterTypes));
            if (type == "area") return;
            if (type == "envmap") {
                envmap(n);
                return;
            }
            if (const LightKind* kind = lightKindByMitsuba(type)) {
                scene_.lights.push_back(makeLight(lightSpec(n, kind->name)));
                return;
            }
            scene_.stats.dropEmitter(type, where(n));
            warn(n, fmt::format("'{}' emitter not supported by radiosity (area, point, spot, directional, "
                                "constant and envmap are): ignored", type));
        } else if (tag == "sensor") {
            sensor(n);
        } else if (tag == "medium" || tag == "volume" || tag == "phase") {
            warn(n, fmt::format("participating media are not supported: <{}> ignored", tag));
        } else if (tag == "bsdf") {
            std::string type = attr(n, "type");
            if (!contains(kBsdfTypes, type))
                fail(n, "unknown bsdf plugin '{}' (expected one of {})", type, joinNames(kBsdfTypes));
        }
        // integrator, sampler, film, rfilter, texture, spectrum, path: renderer
        // settings or referenced objects.
    }

    void sensor(const Node& s) {
        std::string type = attr(s, "type");
        if (haveCamera_) {
            warn(s, "more than one sensor: the first one is the scene camera");
            return;
        }
        if (type != "perspective" && type != "thinlens") {
            warn(s, fmt::format("'{}' sensor not supported (perspective or thinlens): the automatic camera is used",
                                type));
            return;
        }
        // Mitsuba's default film is 768 x 576 (hdrfilm); its size is the
        // default image size of hrad solve/render and fixes the aspect the
        // fov_axis conversion below uses.
        double w = 768, h = 576;
        SourceLocation filmWhere = loc(s);
        if (pugi::xml_node c = s.n.child("film")) {
            Node film{c, s.f};
            w = floatProp(film, "width", w);
            h = floatProp(film, "height", h);
            if (!(w >= 1 && h >= 1 && w <= 32768 && h <= 32768) || w != std::floor(w) || h != std::floor(h))
                fail(film, "film width and height must be integers in 1 .. 32768, not {} x {}", w, h);
            filmWhere = loc(film);
        }
        double tanHalf;  // tan of half the fov along the axis it is given for
        std::string axis = stringProp(s, "fov_axis", "x");
        if (Node f = prop(s, "fov")) {
            double fov = number(f, "value");
            if (!(fov > 0 && fov < 180)) fail(f, "fov must be in (0, 180) degrees, not {}", fov);
            tanHalf = std::tan(glm::radians(fov) / 2);
        } else {
            // focal_length "50mm": 36 x 24 mm film, along its diagonal.
            std::string fl = stringProp(s, "focal_length", "50mm");
            std::vector<double> v = numbers(s, fl.substr(0, fl.find("mm")), "focal_length");
            if (v.size() != 1 || !(v[0] > 0)) fail(s, "focal_length '{}' must be like '50mm'", fl);
            tanHalf = std::sqrt(36.0 * 36.0 + 24.0 * 24.0) / (2 * v[0]);
            axis = "diagonal";
        }
        const std::string axisGiven = axis;
        double tanY;
        if (axis == "smaller") axis = w < h ? "x" : "y";
        if (axis == "larger") axis = w < h ? "y" : "x";
        if (axis == "x") tanY = tanHalf * h / w;
        else if (axis == "y") tanY = tanHalf;
        else if (axis == "diagonal") tanY = tanHalf * h / std::sqrt(w * w + h * h);
        else fail(prop(s, "fov_axis"), "fov_axis must be x, y, diagonal, smaller or larger, not '{}'", axis);
        glm::dmat4 m = toWorld(s);
        Camera cam;
        cam.eye = Vec3(m * glm::dvec4(0, 0, 0, 1));
        Vec3 dir = glm::normalize(Vec3(m * glm::dvec4(0, 0, 1, 0)));
        Vec3 up = glm::normalize(Vec3(m * glm::dvec4(0, 1, 0, 0)));
        cam.target = cam.eye + dir;
        cam.up = up;
        cam.fovYDegrees = glm::degrees(2 * std::atan(tanY));
        cam.filmWidth = int(w);
        cam.filmHeight = int(h);
        cam.fovAxis = axisGiven == "x"          ? FovAxis::X
                      : axisGiven == "y"        ? FovAxis::Y
                      : axisGiven == "diagonal" ? FovAxis::Diagonal
                      : axisGiven == "smaller"  ? FovAxis::Smaller
                                                : FovAxis::Larger;
        cam.filmWhere = filmWhere;
        scene_.camera = cam;
        Vec3 a = glm::abs(up);
        scene_.upAxis = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
        haveCamera_ = true;
    }

    // --- materials -------------------------------------------------------------

    BsdfInfo bsdf(Node b, std::vector<std::string>& notes, int depth) {
        if (depth > 16) fail(b, "BSDFs nested deeper than 16 levels");
        if (std::string(b.n.name()) == "ref") b = resolve(b);
        if (std::string(b.n.name()) != "bsdf") fail(b, "expected a <bsdf>, found <{}>", b.n.name());
        std::string type = attr(b, "type");
        if (!contains(kBsdfTypes, type))
            fail(b, "unknown bsdf plugin '{}' (expected one of {})", type, joinNames(kBsdfTypes));
        auto nested = [&](size_t which) -> Node {
            size_t k = 0;
            for (pugi::xml_node c = b.n.first_child(); c; c = c.next_sibling()) {
                std::string t = c.name();
                if (c.type() == pugi::node_element && (t == "bsdf" || (t == "ref" && !c.attribute("name"))))
                    if (k++ == which) return Node{c, b.f};
            }
            return Node{};
        };
        BsdfInfo info;
        if (type == "diffuse" || type == "roughdiffuse" || type == "difftrans") {
            lastBitmap_ = -1;
            info.rho = colorProp(b, type == "difftrans" ? "transmittance" : "reflectance", false, notes).value_or(RGB(0.5));
            keepBitmap(info, notes);
            if (type != "diffuse") notes.push_back(type + " -> Lambertian with its reflectance");
        } else if (type == "plastic" || type == "roughplastic" || type == "pplastic" || type == "phong" ||
                   type == "ward") {
            lastBitmap_ = -1;
            info.rho = colorProp(b, "diffuse_reflectance", false, notes).value_or(RGB(0.5));
            keepBitmap(info, notes);
            notes.push_back(type + ": glossy part dropped, albedo = diffuse_reflectance");
        } else if (type == "conductor" || type == "roughconductor") {
            RGB spec = colorProp(b, "specular_reflectance", false, notes).value_or(RGB(1.0));
            std::vector<std::string> sub;
            std::optional<RGB> eta = colorProp(b, "eta", true, sub), k = colorProp(b, "k", true, sub);
            RGB f0(1.0);
            if (eta && k) {
                for (int c = 0; c < 3; ++c) {
                    double e = (*eta)[c], kk = (*k)[c];
                    f0[c] = ((e - 1) * (e - 1) + kk * kk) / ((e + 1) * (e + 1) + kk * kk);
                }
                notes.push_back(type + " -> albedo = specular_reflectance x normal-incidence Fresnel of eta, k");
            } else {
                std::string material = stringProp(b, "material", "none");
                notes.push_back(type + (material == "none" ? " (perfect mirror)"
                                                           : " material '" + material + "' (not tabulated)") +
                                " -> albedo = specular_reflectance");
            }
            info.rho = spec * f0;
        } else if (type == "principled" || type == "principledthin") {
            lastBitmap_ = -1;
            info.rho = colorProp(b, "base_color", false, notes).value_or(RGB(0.5));
            keepBitmap(info, notes);
            notes.push_back(type + " -> albedo = base_color");
        } else if (type == "twosided") {
            Node front = nested(0);
            if (!front) fail(b, "twosided needs a nested bsdf");
            info = bsdf(front, notes, depth + 1);
            if (nested(1)) notes.push_back("twosided with a different back BSDF: the front one is used on both sides");
            info.twoSided = true;
        } else if (type == "mask" || type == "bumpmap" || type == "normalmap" || type == "coating" ||
                   type == "roughcoating") {
            Node inner = nested(0);
            if (!inner) fail(b, "{} needs a nested bsdf", type);
            info = bsdf(inner, notes, depth + 1);
            notes.push_back(type + " ignored, its nested BSDF is used");
        } else if (type == "blendbsdf") {
            Node a = nested(0), c = nested(1);
            if (!a || !c) fail(b, "blendbsdf needs two nested bsdfs");
            std::vector<std::string> sub;
            double w = 0.5;
            if (Node wp = prop(b, "weight")) w = std::string(wp.n.name()) == "float" ? number(wp, "value")
                                                                                   : color(wp, "weight", false, notes).g;
            BsdfInfo ia = bsdf(a, notes, depth + 1), ic = bsdf(c, notes, depth + 1);
            info.rho = (1 - w) * ia.rho + w * ic.rho;
            info.twoSided = ia.twoSided || ic.twoSided;
            notes.push_back(fmt::format("blendbsdf -> (1 - {}) first + {} second", w, w));
        } else if (type == "dielectric" || type == "thindielectric" || type == "roughdielectric" || type == "null") {
            info.transparent = true;
            notes.push_back(type + " is transparent: shapes with it are not added");
        } else {
            info.rho = RGB(opt_.defaultRho);
            notes.push_back(fmt::format("{} has no diffuse albedo -> grey {} (mitsuba.default_rho)", type, opt_.defaultRho));
        }
        return info;
    }

    /// A diffuse albedo that was a bitmap keeps it (the "-> its mean" note
    /// no longer applies).
    void keepBitmap(BsdfInfo& info, std::vector<std::string>& notes) {
        info.texture = lastBitmap_;
        if (lastBitmap_ >= 0 && lastBitmapNote_ < notes.size())
            notes.erase(notes.begin() + std::ptrdiff_t(lastBitmapNote_));
    }

    /// The BSDF of a shape's element, resolved once per BSDF node, with one
    /// warning per material.
    const BsdfInfo& bsdfOf(const Node& b) {
        auto it = bsdfs_.find(b.key());
        if (it != bsdfs_.end()) return it->second;
        std::vector<std::string> notes;
        BsdfInfo info = bsdf(b, notes, 0);
        if (!info.transparent) {
            for (int c = 0; c < 3; ++c)
                if (!(info.rho[c] >= 0)) fail(b, "negative reflectance");
            const RGB given = info.rho;
            switch (clampReflectance(info.rho, opt_.clampRho)) {  // scene.h: one rule for every format
                case RhoCheck::Clamped: notes.push_back(clampedNote(opt_.clampRho)); break;
                case RhoCheck::TooLarge: {  // braced, as in every loader
                    fail(b, "reflectance ({:.6g}, {:.6g}, {:.6g}) >= 1 ({})", given.r, given.g, given.b,
                         kClampRhoHint);
                    break;
                }
                case RhoCheck::Fine: break;
            }
        }
        std::string id = b.n.attribute("id") ? b.n.attribute("id").value() : "";
        if (!notes.empty()) {
            std::string all;
            for (const auto& s : notes) all += (all.empty() ? "" : "; ") + s;
            warn(b, info.transparent
                        ? fmt::format("material '{}': {}", id.empty() ? "unnamed" : id, all)
                        : fmt::format("material '{}': {} (rho = {:.3g}, {:.3g}, {:.3g})", id.empty() ? "unnamed" : id,
                                      all, info.rho.r, info.rho.g, info.rho.b));
        }
        return bsdfs_.emplace(b.key(), info).first->second;
    }

    // --- shapes ----------------------------------------------------------------

    void shape(const Node& s, const glm::dmat4& parent, int depth) {
        // Bounded before anything is made: shapes that yield no face (skipped
        // types, transparent ones) add nothing to the face budget.
        if (++shapesVisited_ > opt_.maxFaces)
            fail(s, "the scene instantiates more than {} shapes (setting mitsuba.max_faces; shapes "
                    "that yield no face count too)", opt_.maxFaces);
        std::string type = attr(s, "type");
        if (contains(kUnsupportedShapes, type)) {
            warn(s, fmt::format("'{}' shapes cannot be made into polygons: ignored", type));
            return;
        }
        if (!contains(kShapeTypes, type))
            fail(s, "unknown shape plugin '{}' (expected one of {})", type, joinNames(kShapeTypes));
        if (type == "shapegroup") fail(s, "a shapegroup cannot be nested in another shape");
        glm::dmat4 m = parent * toWorld(s);
        if (type == "instance") {
            if (depth > 8) fail(s, "instances nested deeper than 8 levels");
            Node ref;
            for (pugi::xml_node c = s.n.child("ref"); c; c = c.next_sibling("ref")) ref = Node{c, s.f};
            if (!ref) fail(s, "an instance needs <ref id=...> to a shapegroup");
            Node group = resolve(ref);
            if (std::string(group.n.name()) != "shape" || attr(group, "type") != "shapegroup")
                fail(ref, "instance refers to '{}', which is not a shapegroup", attr(ref, "id"));
            for (pugi::xml_node c = group.n.child("shape"); c; c = c.next_sibling("shape"))
                shape(Node{c, group.f}, m, depth + 1);
            return;
        }
        // BSDF and emitter: nested elements or references.
        Node bsdfNode, emitterNode;
        for (pugi::xml_node c = s.n.first_child(); c; c = c.next_sibling()) {
            if (c.type() != pugi::node_element) continue;
            Node n{c, s.f};
            std::string tag = c.name();
            Node target = n;
            if (tag == "ref") {
                target = resolve(n);
                tag = target.n.name();
            }
            if (tag == "bsdf") {
                if (bsdfNode) fail(n, "a shape may have only one bsdf");
                bsdfNode = target;
            } else if (tag == "emitter") {
                if (emitterNode) fail(n, "a shape may have only one emitter");
                emitterNode = target;
            } else if (tag == "medium") {
                if (warnedOnce_.insert("medium").second) warn(n, "participating media are not supported: ignored");
            }
        }
        const BsdfInfo* info = nullptr;
        if (bsdfNode) info = &bsdfOf(bsdfNode);
        if (info && info->transparent && !emitterNode) return;
        uint32_t material = materialFor(bsdfNode, info, emitterNode);

        bool flip = boolProp(s, "flip_normals", false);
        std::vector<std::vector<Vec2>> polyUVs;  // per polygon; empty: none
        std::vector<std::vector<Vec3>> polys = geometry(s, type, polyUVs);
        const bool textured = scene_.materials[material].diffuseMap.texture >= 0;
        // Analytic shapes keep Mitsuba's normal (transformed by the inverse
        // transpose), so a mirroring transform must not turn them inside out;
        // meshes follow their transformed winding like Mitsuba's face normals.
        bool analytic = type != "obj" && type != "ply" && type != "serialized";
        if (analytic && glm::determinant(glm::dmat3(m)) < 0) flip = !flip;
        faces_ += polys.size();
        if (faces_ > opt_.maxFaces)
            fail(s, "the scene yields more than {} faces (setting mitsuba.max_faces)", opt_.maxFaces);
        std::vector<Vec3> w;
        std::vector<Vec2> uvw;
        for (size_t pi = 0; pi < polys.size(); ++pi) {
            const auto& p = polys[pi];
            const bool hasUV = textured && pi < polyUVs.size() && polyUVs[pi].size() == p.size();
            if (hasUV) uvw = polyUVs[pi];
            w.clear();
            for (const Vec3& v : p) {
                w.push_back(Vec3(m * glm::dvec4(v, 1.0)));
                // Areas are products of coordinates: past 1e150 they overflow
                // and the face was dropped as degenerate, without a word
                // (a sphere of radius 1e200, an instance scale that overflows).
                const Vec3 a = glm::abs(w.back());
                if (!(std::max({a.x, a.y, a.z}) <= 1e150))
                    fail(s, "the shape's coordinates reach {:.3g} after its transform: beyond 1e150 "
                            "face areas overflow", std::max({a.x, a.y, a.z}));
            }
            if (flip) std::reverse(w.begin(), w.end());
            if (flip && hasUV) std::reverse(uvw.begin(), uvw.end());
            addPolygon(scene_, w, material, hasUV ? &uvw : nullptr);
        }
    }

    uint32_t materialFor(const Node& bsdfNode, const BsdfInfo* info, const Node& emitter) {
        auto key = std::make_pair(bsdfNode ? bsdfNode.key() : nullptr, emitter ? emitter.key() : nullptr);
        // A nested (anonymous) emitter is per shape; named BSDFs are shared.
        auto it = materials_.find(key);
        if (it != materials_.end()) return it->second;
        Material mat;
        const Node& named = bsdfNode;
        mat.name = named && named.n.attribute("id") ? named.n.attribute("id").value()
                   : bsdfNode ? fmt::format("bsdf@{}", named.f->lineOf(named.n.offset_debug()))
                              : "default";
        if (info && !info->transparent) {
            mat.rho = info->rho;
            mat.twoSided = info->twoSided;
            // rho(x) = the bitmap (scale 1); rho, its clamped mean over all
            // texels, stays the fallback of shapes without UVs.
            mat.diffuseMap.texture = info->texture;
            mat.diffuseMap.clampRho = opt_.clampRho;
            mat.diffuseMap.clampKey = "scene.clamp_rho";
        } else if (!info) {
            mat.rho = RGB(std::min(0.5, opt_.clampRho > 0 ? opt_.clampRho : 0.5));
        }
        if (emitter) {
            std::string type = attr(emitter, "type");
            if (type != "area") fail(emitter, "a '{}' emitter cannot be attached to a shape (only area)", type);
            usedEmitters_.insert(emitter.key());
            std::vector<std::string> notes;
            std::optional<RGB> L = colorProp(emitter, "radiance", true, notes);
            if (!L) fail(emitter, "area emitter needs a 'radiance'");
            for (int c = 0; c < 3; ++c)
                if (!((*L)[c] >= 0)) fail(emitter, "radiance must be >= 0");
            if (!notes.empty()) warn(emitter, "radiance: " + notes.front());
            mat.emission = kPi * *L;  // Lambertian emitter: E = pi L
            mat.name += emitter.n.attribute("id") ? std::string("+") + emitter.n.attribute("id").value()
                                                  : fmt::format("+emitter@{}", emitter.f->lineOf(emitter.n.offset_debug()));
            if (info && info->transparent) mat.twoSided = false;
        }
        mat.emitsBothSides = false;  // Mitsuba area lights emit from the front
        uint32_t id = scene_.addMaterial(mat);
        materials_.emplace(key, id);
        return id;
    }

    /// The face budget before an analytic shape's faces are made (a few
    /// spheres at mitsuba.resolution = 4096 made 25 M faces, then failed it).
    void checkAnalyticBudget(const Node& s, const std::string& type, int n) const {
        const uint64_t expected = type == "sphere" ? uint64_t(n) * uint64_t(std::max(2, n / 2))
                                  : type == "cube" ? 6
                                  : type == "rectangle" ? 1
                                                        : uint64_t(n);
        if (faces_ + expected > opt_.maxFaces)
            fail(s, "this {} at mitsuba.resolution = {} makes {} faces: the scene would pass "
                    "mitsuba.max_faces = {}", type, n, expected, opt_.maxFaces);
    }

    /// The shape's polygons in its object space; `uvs` gets their texture
    /// coordinates in hrad's sense (v up, scene/texture.h) where the shape has
    /// them. Mitsuba's uv has v pointing down the image (its bitmap's row 0 is
    /// uv.y = 0), so hrad's UV is (u, 1 - v) of Mitsuba's: meshes' stored
    /// coordinates after Mitsuba's flip_tex_coords (default true for obj, false
    /// for ply; serialized has none), the analytic shapes' parametrisations of
    /// Mitsuba 3 (src/shapes/{rectangle,cube,disk,sphere,cylinder}.cpp, 2026-08).
    std::vector<std::vector<Vec3>> geometry(const Node& s, const std::string& type,
                                            std::vector<std::vector<Vec2>>& uvs) {
        std::vector<std::vector<Vec3>> polys;
        if (type == "obj" || type == "ply" || type == "serialized") {
            meshGeometry(s, type, polys, uvs);
            return polys;
        }
        const int n = opt_.resolution;
        checkAnalyticBudget(s, type, n);
        if (type == "rectangle") {
            // Mitsuba: uv = ((x + 1) / 2, (y + 1) / 2).
            polys.push_back({{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}});
            uvs.push_back({{0, 1}, {1, 1}, {1, 0}, {0, 0}});
        } else if (type == "cube") {
            cubeGeometry(polys, uvs);
        } else if (type == "disk") {
            diskGeometry(n, polys, uvs);
        } else if (type == "cylinder") {
            cylinderGeometry(s, n, polys, uvs);
        } else if (type == "sphere") {
            sphereGeometry(s, n, polys, uvs);
        }
        return polys;
    }

    /// obj, ply and serialized shapes: the file's faces and, when it has them,
    /// its texture coordinates (see geometry()).
    void meshGeometry(const Node& s, const std::string& type, std::vector<std::vector<Vec3>>& polys,
                      std::vector<std::vector<Vec2>>& uvs) {
        Node fp = prop(s, "filename");
        if (!fp) fail(s, "{} shape needs a 'filename'", type);
        std::string file = filePath(fp, attr(fp, "value"));
        std::error_code ec;
        if (fs::exists(file, ec) && !fs::is_regular_file(file, ec))
            fail(fp, "mesh file '{}' is not a regular file", file);
        if (!fs::exists(file, ec)) {  // scene.missing: the shape adds nothing
            scene_.stats.missingFiles.add(loc(fp), "mesh file", file);
            return;
        }
        if (type == "serialized") {
            serializedGeometry(s, file, polys, uvs);
            return;
        }
        // Mitsuba flips the stored v of OBJ files by default, not of PLY files.
        const bool flipTex = boolProp(s, "flip_tex_coords", type == "obj");
        Scene sub;
        if (type == "obj") {
            ObjOptions o;
            o.clampRho = 0.99;  // the .mtl is not used: never fail on it (nor warn: not kept)
            o.keepUVs = true;   // the XML's bitmap needs them; the .mtl's maps are not read
            o.readTextures = false;
            sub = loadObj(file, o);
        } else {
            PlyOptions o;
            o.keepUVs = true;
            sub = loadPly(file, o);
        }
        for (const std::string& w : sub.stats.warnings)
            if (w.find("no material") == std::string::npos && w.find("default") == std::string::npos)
                scene_.stats.warnings.push_back(w);
        scene_.stats.droppedDegenerate += sub.stats.droppedDegenerate;
        scene_.stats.overflowFaces += sub.stats.overflowFaces;
        scene_.stats.triangulatedFaces += sub.stats.triangulatedFaces;  // e.g. a non-planar quad
        polys.reserve(sub.patches.size());
        // Both loaders keep the stored v. With flip_tex_coords Mitsuba's v is
        // 1 - stored, so hrad's (1 - Mitsuba's) is the stored one; without,
        // hrad's v is 1 - stored.
        const bool invert = !flipTex;
        for (const Patch& p : sub.patches) {
            polys.emplace_back(p.v.begin(), p.v.begin() + p.numVertices());
            if (sub.cornerUVs.empty()) continue;
            uvs.resize(polys.size());
            if (const auto* row = patchUVs(sub, p)) {
                uvs.back().assign(row->begin(), row->begin() + p.numVertices());
                if (invert)
                    for (Vec2& t : uvs.back()) t.y = 1 - t.y;
            }
        }
    }

    /// A serialized shape's triangles and texture coordinates (Mitsuba's uv
    /// as stored: hrad's v = 1 - stored).
    void serializedGeometry(const Node& s, const std::string& file, std::vector<std::vector<Vec3>>& polys,
                            std::vector<std::vector<Vec2>>& uvs) {
        // Checked as a number before it becomes an index: a value no
        // integer type holds must not be cast (fuzz finding).
        const double shapeIndex = floatProp(s, "shape_index", 0);
        if (!(shapeIndex >= 0) || shapeIndex > 4294967295.0 || shapeIndex != std::floor(shapeIndex))
            fail(s, "shape_index must be a whole number in [0, 2^32), not {}", shapeIndex);
        const uint64_t index = uint64_t(shapeIndex);
        SerializedMesh mesh = readSerialized(
            file, index, opt_.maxFaces - std::min(faces_, opt_.maxFaces), "shape at " + where(s),
            opt_.maxInflatedBytes - std::min(inflated_, opt_.maxInflatedBytes));
        inflated_ += mesh.inflatedBytes;
        polys.reserve(mesh.triangles.size());
        const bool withUV = mesh.texcoords.size() == mesh.positions.size();
        if (withUV) uvs.reserve(mesh.triangles.size());
        for (const auto& t : mesh.triangles) {
            polys.push_back({mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]});
            if (!withUV) continue;
            uvs.emplace_back();
            for (uint32_t k : t) uvs.back().push_back(Vec2(mesh.texcoords[k].x, 1 - mesh.texcoords[k].y));
        }
    }

    /// The cube [-1, 1]^3, one quad per face. Mitsuba maps every face onto
    /// [0, 1]^2 (its cube.cpp vertex and texcoord tables); per face, from
    /// those tables, Mitsuba's (u, v) at a corner (x, y, z):
    ///   -x: ((y+1)/2, (z+1)/2)   +x: ((y+1)/2, (1-z)/2)
    ///   -y: ((z+1)/2, (x+1)/2)   +y: ((1-x)/2, (1-z)/2)
    ///   -z: ((1-y)/2, (x+1)/2)   +z: ((y+1)/2, (x+1)/2)
    void cubeGeometry(std::vector<std::vector<Vec3>>& polys, std::vector<std::vector<Vec2>>& uvs) const {
        auto mitsubaUV = [](int axis, int sign, const Vec3& p) {
            const double x = p.x, y = p.y, z = p.z;
            if (axis == 0) return sign < 0 ? Vec2((y + 1) / 2, (z + 1) / 2) : Vec2((y + 1) / 2, (1 - z) / 2);
            if (axis == 1) return sign < 0 ? Vec2((z + 1) / 2, (x + 1) / 2) : Vec2((1 - x) / 2, (1 - z) / 2);
            return sign < 0 ? Vec2((1 - y) / 2, (x + 1) / 2) : Vec2((y + 1) / 2, (x + 1) / 2);
        };
        for (int axis = 0; axis < 3; ++axis)
            for (int sign = -1; sign <= 1; sign += 2) {
                int a = (axis + 1) % 3, b = (axis + 2) % 3;
                std::vector<Vec3> q(4, Vec3(0.0));
                double uv[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
                for (int k = 0; k < 4; ++k) {
                    q[k][axis] = sign;
                    q[k][a] = uv[k][0];
                    q[k][b] = uv[k][1];
                }
                // (a, b, axis) is right-handed: this order faces +axis.
                if (sign < 0) std::reverse(q.begin(), q.end());
                std::vector<Vec2> t;
                for (const Vec3& p : q) {
                    const Vec2 m = mitsubaUV(axis, sign, p);
                    t.push_back(Vec2(m.x, 1 - m.y));
                }
                polys.push_back(q);
                uvs.push_back(t);
            }
    }

    /// The unit disk as n triangles around its centre. Mitsuba's uv is
    /// (r, phi / 2 pi), phi in [0, 2 pi) (disk.cpp); hrad's v = 1 - phi / 2 pi,
    /// the rim's corners at u = 1 (the n-gon is scaled to the disk's area,
    /// its rim stands for the disk's), the centre at the wedge's mid-angle.
    void diskGeometry(int n, std::vector<std::vector<Vec3>>& polys,
                      std::vector<std::vector<Vec2>>& uvs) const {
        // Radius scaled so that the n-gon's area equals pi.
        double r = std::sqrt(2 * kPi / (n * std::sin(2 * kPi / n)));
        for (int k = 0; k < n; ++k) {
            double a0 = 2 * kPi * k / n, a1 = 2 * kPi * (k + 1) / n;
            polys.push_back({{0, 0, 0}, {r * std::cos(a0), r * std::sin(a0), 0}, {r * std::cos(a1), r * std::sin(a1), 0}});
            uvs.push_back({Vec2(0, 1 - (k + 0.5) / n), Vec2(1, 1 - double(k) / n), Vec2(1, 1 - double(k + 1) / n)});
        }
    }

    /// The cylinder's lateral surface as an n-sided prism. Mitsuba 3
    /// (cylinder.cpp) places its local unit cylinder (z in [0, 1]) with
    /// to_frame(Frame(d / |d|)), d = p1 - p0, whose (s, t) is the orthonormal
    /// basis of Duff et al., "Building an Orthonormal Basis, Revisited" (JCGT
    /// 6(1), 2017; Mitsuba's coordinate_system), and its uv is (phi / 2 pi, z),
    /// phi = atan2(local y, local x) in [0, 2 pi). hrad's UV is (phi / 2 pi,
    /// 1 - z) at each corner, the facet over the seam unwrapped past u = 1.
    void cylinderGeometry(const Node& s, int n, std::vector<std::vector<Vec3>>& polys,
                          std::vector<std::vector<Vec2>>& uvs) const {
        Vec3 p0 = pointProp(s, "p0", Vec3(0, 0, 0)), p1 = pointProp(s, "p1", Vec3(0, 0, 1));
        double radius = floatProp(s, "radius", 1.0);
        if (!(radius > 0) || !(glm::length(p1 - p0) > 0)) fail(s, "cylinder needs radius > 0 and p0 != p1");
        Vec3 w = glm::normalize(p1 - p0);
        Vec3 u = glm::normalize(std::abs(w.x) < 0.9 ? glm::cross(w, Vec3(1, 0, 0)) : glm::cross(w, Vec3(0, 1, 0)));
        Vec3 v = glm::cross(w, u);
        // Radius scaled so that the prism's lateral area equals 2 pi r h.
        double r = radius * kPi / (n * std::sin(kPi / n));
        auto at = [&](int k, const Vec3& base) {
            double a = 2 * kPi * k / n;
            return base + r * (std::cos(a) * u + std::sin(a) * v);
        };
        // Mitsuba's (s, t) around w (Duff et al. 2017, listing 3; sign(0) = 1).
        const double sg = w.z >= 0 ? 1.0 : -1.0, a = -1.0 / (sg + w.z), b = w.x * w.y * a;
        const Vec3 fs(1 + sg * w.x * w.x * a, sg * b, -sg * w.x), ft(b, sg + w.y * w.y * a, -w.y);
        // Both frames are right-handed around w: Mitsuba's phi is ours plus
        // the angle of our u in (s, t).
        double offset = std::atan2(glm::dot(u, ft), glm::dot(u, fs)) / (2 * kPi);
        offset -= std::floor(offset);
        for (int k = 0; k < n; ++k) {
            polys.push_back({at(k, p0), at(k + 1, p0), at(k + 1, p1), at(k, p1)});
            double u0 = offset + double(k) / n;
            u0 -= std::floor(u0);
            const double u1 = u0 + 1.0 / n;
            uvs.push_back({Vec2(u0, 1), Vec2(u1, 1), Vec2(u1, 0), Vec2(u0, 0)});
        }
    }

    /// A UV sphere of n segments and n / 2 rings. Mitsuba's uv is
    /// (phi / 2 pi, theta / pi), theta from +z, phi = atan2(y, x) in
    /// [0, 2 pi) (sphere.cpp); hrad's v = 1 - theta / pi, the seam's corners
    /// at u = 1, a pole's corner at its triangle's mid-angle.
    void sphereGeometry(const Node& s, int n, std::vector<std::vector<Vec3>>& polys,
                        std::vector<std::vector<Vec2>>& uvs) const {
        Vec3 c = pointProp(s, "center", Vec3(0.0));
        double radius = floatProp(s, "radius", 1.0);
        if (!(radius > 0)) fail(s, "sphere needs radius > 0");
        int rings = std::max(2, n / 2);
        auto at = [&](int i, int j) {
            double th = kPi * i / rings, ph = 2 * kPi * j / n;
            return Vec3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
        };
        double area = 0;
        for (int i = 0; i < rings; ++i)
            for (int j = 0; j < n; ++j) {
                std::vector<Vec3> q;
                std::vector<Vec2> t;
                // a, d, c, b: theta then phi increasing -> outward normal.
                const int ij[4][2] = {{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j + 1}};
                for (const auto& [ii, jj] : ij) {
                    const Vec3 p = at(ii, jj);
                    const bool pole = ii == 0 || ii == rings;
                    const Vec2 uv((pole ? j + 0.5 : double(jj)) / n, 1 - double(ii) / rings);
                    if (q.empty() || glm::length(p - q.back()) > 1e-12) {
                        q.push_back(p);
                        t.push_back(uv);
                    }
                }
                if (glm::length(q.front() - q.back()) < 1e-12) {
                    q.pop_back();
                    t.pop_back();
                }
                for (size_t k = 1; k + 1 < q.size(); ++k)
                    area += 0.5 * glm::length(glm::cross(q[k] - q[0], q[k + 1] - q[0]));
                polys.push_back(q);
                uvs.push_back(t);
            }
        // Scaled so that the polyhedron's area equals 4 pi r^2.
        double scale = radius * std::sqrt(4 * kPi / area);
        for (auto& q : polys)
            for (Vec3& p : q) p = c + scale * p;
    }
};

}  // namespace

Scene loadMitsuba(const std::string& path, const MitsubaOptions& options) {
    Loader loader(options);
    return loader.run(path);
}

}  // namespace hrad::scene
