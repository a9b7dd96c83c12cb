// PLY loading (see ply_loader.h).
#include "scene/ply_loader.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "core/error.h"
#include "core/parse.h"
#include "scene/triangulate.h"

namespace hrad::scene {

namespace {

enum class Type { I8, U8, I16, U16, I32, U32, F32, F64 };

bool parseType(const std::string& s, Type& t) {
    static const std::map<std::string, Type> types = {
        {"char", Type::I8},   {"int8", Type::I8},     {"uchar", Type::U8},   {"uint8", Type::U8},
        {"short", Type::I16}, {"int16", Type::I16},   {"ushort", Type::U16}, {"uint16", Type::U16},
        {"int", Type::I32},   {"int32", Type::I32},   {"uint", Type::U32},   {"uint32", Type::U32},
        {"float", Type::F32}, {"float32", Type::F32}, {"double", Type::F64}, {"float64", Type::F64}};
    auto it = types.find(s);
    if (it == types.end()) return false;
    t = it->second;
    return true;
}

int typeSize(Type t) {
    switch (t) {
        case Type::I8: case Type::U8: return 1;
        case Type::I16: case Type::U16: return 2;
        case Type::I32: case Type::U32: case Type::F32: return 4;
        default: return 8;
    }
}

bool isFloat(Type t) { return t == Type::F32 || t == Type::F64; }

struct Property {
    std::string name;
    Type type = Type::F32;
    bool list = false;
    Type countType = Type::U8;
};

struct Element {
    std::string name;
    size_t count = 0;
    std::vector<Property> props;
    int find(const std::string& n) const {
        for (size_t i = 0; i < props.size(); ++i)
            if (props[i].name == n) return int(i);
        return -1;
    }
    /// Indices of the first texture-coordinate pair present (ply_loader.h), or {-1, -1}.
    std::array<int, 2> findUV() const {
        static const char* const kPairs[4][2] = {
            {"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};
        for (const auto& pair : kPairs) {
            const int a = find(pair[0]), b = find(pair[1]);
            if (a >= 0 && b >= 0 && !props[size_t(a)].list && !props[size_t(b)].list) return {a, b};
        }
        return {-1, -1};
    }
};

class Reader {
  public:
    Reader(std::istream& in, const std::string& path, int format, uint64_t fileSize)
        : in_(in), path_(path), format_(format), fileSize_(fileSize) {}
    int line = 0;  // ASCII: current data line

    // Reads one element instance: scalars in vals, lists in lists (by property).
    void read(const Element& e, std::vector<double>& vals, std::vector<std::vector<double>>& lists) {
        vals.assign(e.props.size(), 0.0);
        lists.resize(e.props.size());
        if (format_ == 0) {
            std::string text;
            do {
                if (!std::getline(in_, text)) fail("unexpected end of file in element '" + e.name + "'");
                ++line;
            } while (text.find_first_not_of(" \t\r") == std::string::npos);
            std::istringstream ss(text);
            for (size_t i = 0; i < e.props.size(); ++i) {
                const Property& p = e.props[i];
                if (p.list) {
                    double n = asciiNum(ss, p.countType);
                    // Each value takes two bytes of the line at least.
                    if (!(n >= 0 && n < 1e7 && 2 * n <= double(text.size()))) fail("bad list count");
                    lists[i].resize(size_t(n));
                    for (auto& v : lists[i]) v = asciiNum(ss, p.type);
                } else {
                    vals[i] = asciiNum(ss, p.type);
                }
            }
        } else {
            for (size_t i = 0; i < e.props.size(); ++i) {
                const Property& p = e.props[i];
                if (p.list) {
                    double n = binNum(p.countType);
                    // The values must be in the file before they are allocated.
                    if (!(n >= 0 && n < 1e7 && n * typeSize(p.type) <= double(fileSize_ - uint64_t(in_.tellg()))))
                        fail(fmt::format("bad list count {} (the file ends sooner)", n));
                    lists[i].resize(size_t(n));
                    for (auto& v : lists[i]) v = binNum(p.type);
                } else {
                    vals[i] = binNum(p.type);
                }
            }
        }
    }

    [[noreturn]] void fail(const std::string& msg) const {
        if (format_ == 0) throw InputError(SourceLocation{path_, line, 0}, msg);
        throw InputError(SourceLocation{path_, 0, 0},
                         fmt::format("{} (at byte offset {})", msg, long(in_.tellg())));
    }
    std::string where() const {
        return format_ == 0 ? fmt::format("line {}", line) : fmt::format("byte offset {}", long(in_.tellg()));
    }
    SourceLocation location() const { return SourceLocation{path_, format_ == 0 ? line : 0, 0}; }

  private:
    std::istream& in_;
    std::string path_;
    int format_;  // 0 ascii, 1 little endian, 2 big endian
    uint64_t fileSize_;

    double asciiNum(std::istringstream& ss, Type t) {
        std::string tok;
        if (!(ss >> tok)) fail("too few values on the line");
        // Strict (core/parse.h): the whole token, finite; integer types take
        // integers within the type's range.
        if (isFloat(t)) {
            auto v = parseFiniteDouble(tok);
            if (!v) fail(fmt::format("malformed or non-finite number '{}'", tok));
            return *v;
        }
        auto v = parseInt64(tok);
        if (!v) fail(fmt::format("'{}' is not an integer", tok));
        double lo = 0, hi = 0;
        switch (t) {
            case Type::I8: lo = -128; hi = 127; break;
            case Type::U8: lo = 0; hi = 255; break;
            case Type::I16: lo = -32768; hi = 32767; break;
            case Type::U16: lo = 0; hi = 65535; break;
            case Type::I32: lo = -2147483648.0; hi = 2147483647.0; break;
            default: lo = 0; hi = 4294967295.0; break;
        }
        if (double(*v) < lo || double(*v) > hi) fail(fmt::format("'{}' is out of the property type's range", tok));
        return double(*v);
    }

    double binNum(Type t) {
        unsigned char b[8];
        int n = typeSize(t);
        if (!in_.read(reinterpret_cast<char*>(b), n)) fail("unexpected end of file");
        bool little = std::endian::native == std::endian::little;
        if ((format_ == 1) != little) std::reverse(b, b + n);
        switch (t) {
            case Type::I8: { int8_t v; std::memcpy(&v, b, 1); return v; }
            case Type::U8: return b[0];
            case Type::I16: { int16_t v; std::memcpy(&v, b, 2); return v; }
            case Type::U16: { uint16_t v; std::memcpy(&v, b, 2); return v; }
            case Type::I32: { int32_t v; std::memcpy(&v, b, 4); return v; }
            case Type::U32: { uint32_t v; std::memcpy(&v, b, 4); return v; }
            case Type::F32: {
                float v;
                std::memcpy(&v, b, 4);
                if (!std::isfinite(v)) fail("non-finite float value");
                return v;
            }
            default: {
                double v;
                std::memcpy(&v, b, 8);
                if (!std::isfinite(v)) fail("non-finite double value");
                return v;
            }
        }
    }
};

}  // namespace

Scene loadPly(const std::string& path, const PlyOptions& options) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throwInputError(SourceLocation{path, 0, 0}, "cannot open file");
    std::string text;
    int lineNo = 0;
    auto headerFail = [&](const std::string& msg) { throw InputError(SourceLocation{path, lineNo, 0}, msg); };
    if (!std::getline(in, text) || (++lineNo, text.rfind("ply", 0) != 0)) headerFail("not a PLY file (no 'ply' magic)");
    int format = -1;
    std::vector<Element> elements;
    bool ended = false;
    while (std::getline(in, text)) {
        ++lineNo;
        if (!text.empty() && text.back() == '\r') text.pop_back();
        std::istringstream ss(text);
        std::string key;
        ss >> key;
        if (key == "format") {
            std::string f;
            ss >> f;
            if (f == "ascii") format = 0;
            else if (f == "binary_little_endian") format = 1;
            else if (f == "binary_big_endian") format = 2;
            else headerFail("unknown PLY format '" + f + "'");
        } else if (key == "element") {
            Element e;
            std::string countText, extra;
            ss >> e.name >> countText >> extra;
            // The count is parsed strictly: the whole token is decimal digits ("4e3" is not 4).
            if (e.name.empty() || countText.empty() || !extra.empty() || countText.size() > 18 ||
                countText.find_first_not_of("0123456789") != std::string::npos)
                headerFail("malformed element line (expected 'element NAME COUNT' with a decimal count)");
            e.count = size_t(std::stoull(countText));
            for (const Element& old : elements)
                if (old.name == e.name) headerFail("element '" + e.name + "' declared twice");
            elements.push_back(e);
        } else if (key == "property") {
            if (elements.empty()) headerFail("property before any element");
            Property p;
            std::string t;
            ss >> t;
            if (t == "list") {
                std::string ct, it;
                ss >> ct >> it >> p.name;
                p.list = true;
                if (!parseType(ct, p.countType) || !parseType(it, p.type)) headerFail("unknown property type");
            } else {
                ss >> p.name;
                if (!parseType(t, p.type)) headerFail("unknown property type '" + t + "'");
            }
            if (p.name.empty()) headerFail("property without a name");
            elements.back().props.push_back(p);
        } else if (key == "end_header") {
            ended = true;
            break;
        } else if (key == "comment" || key == "obj_info" || key.empty()) {
        } else {
            headerFail("unknown header keyword '" + key + "'");
        }
    }
    if (!ended) headerFail("missing end_header");
    if (format < 0) headerFail("missing format line");
    // Element counts are checked against the bytes left in the file before anything is allocated:
    // an ASCII instance takes at least one line (2 bytes), a binary one at least the sum of its
    // fixed-size properties (1 byte per list count). An element without properties cannot hold data.
    uint64_t fileSize = 0;
    {
        std::streampos here = in.tellg();
        in.seekg(0, std::ios::end);
        fileSize = uint64_t(in.tellg());
        double remaining = double(in.tellg() - here);
        in.seekg(here);
        double needed = 0;
        for (const Element& e : elements) {
            if (e.count > 0 && e.props.empty())
                headerFail(fmt::format("element '{}' has {} instances but no properties", e.name, e.count));
            double per = 0;
            for (const Property& p : e.props) per += p.list ? typeSize(p.countType) : typeSize(p.type);
            needed += double(e.count) * (format == 0 ? 2.0 : per);
        }
        if (needed > remaining)
            headerFail(fmt::format("element counts need at least {:.0f} bytes of data but the file has {:.0f} after the header",
                                   needed, remaining));
    }

    Scene scene;
    scene.name = path;
    scene.source = "ply";
    Reader reader(in, path, format, fileSize);
    reader.line = lineNo;

    std::vector<Vec3> pos;
    std::vector<RGB> vcol;
    std::vector<Vec2> vuv;  // per vertex when kept (PlyOptions::keepUVs) and present
    bool vertexColours = false;
    std::map<std::array<long, 3>, uint32_t> byColour;
    uint32_t defaultMat = UINT32_MAX;
    auto materialFor = [&](const RGB& c) -> uint32_t {
        std::array<long, 3> key = {std::lround(c.r * 65535), std::lround(c.g * 65535), std::lround(c.b * 65535)};
        auto it = byColour.find(key);
        if (it != byColour.end()) return it->second;
        Material m;
        if (key[0] == 65535 && key[1] == 65535 && key[2] == 65535) {
            m = {"ply_emitter", RGB(0.0), RGB(options.emission)};
        } else {
            m.name = fmt::format("ply_{:02x}{:02x}{:02x}", int(std::lround(c.r * 255)), int(std::lround(c.g * 255)),
                                 int(std::lround(c.b * 255)));
            m.rho = glm::max(c, RGB(0.0));
            const RGB given = m.rho;
            if (clampReflectance(m.rho, options.clampRho) == RhoCheck::TooLarge)  // scene.h
                throwInputError(SourceLocation{path, 0, 0},
                                "face colour ({:.6g}, {:.6g}, {:.6g}): reflectance must be < 1 ({})",
                                given.r, given.g, given.b, kClampRhoHint);
        }
        uint32_t id = scene.addMaterial(m);
        byColour[key] = id;
        return id;
    };

    std::vector<double> vals;
    std::vector<std::vector<double>> lists;
    bool haveVertices = false;
    for (const Element& e : elements) {
        if (e.name == "vertex") {
            int ix = e.find("x"), iy = e.find("y"), iz = e.find("z");
            if (ix < 0 || iy < 0 || iz < 0) reader.fail("element vertex needs properties x, y, z");
            int ir = e.find("red"), ig = e.find("green"), ib = e.find("blue");
            vertexColours = ir >= 0 && ig >= 0 && ib >= 0;
            double scale = vertexColours && !isFloat(e.props[size_t(ir)].type) ? 1.0 / 255.0 : 1.0;
            const std::array<int, 2> iuv = options.keepUVs ? e.findUV() : std::array<int, 2>{-1, -1};
            pos.reserve(e.count);
            for (size_t k = 0; k < e.count; ++k) {
                reader.read(e, vals, lists);
                Vec3 p(vals[size_t(ix)], vals[size_t(iy)], vals[size_t(iz)]);
                if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                    reader.fail(fmt::format("non-finite coordinate in vertex {}", k));
                pos.push_back(p);
                if (vertexColours) vcol.push_back(RGB(vals[size_t(ir)], vals[size_t(ig)], vals[size_t(ib)]) * scale);
                if (iuv[0] >= 0) vuv.push_back(Vec2(vals[size_t(iuv[0])], vals[size_t(iuv[1])]));
            }
            haveVertices = true;
        } else if (e.name == "face") {
            if (!haveVertices) reader.fail("element face before element vertex");
            int il = e.find("vertex_indices");
            if (il < 0) il = e.find("vertex_index");
            if (il < 0 || !e.props[size_t(il)].list) reader.fail("element face needs a list property vertex_indices");
            int ir = e.find("red"), ig = e.find("green"), ib = e.find("blue");
            bool faceColours = ir >= 0 && ig >= 0 && ib >= 0;
            double scale = faceColours && !isFloat(e.props[size_t(ir)].type) ? 1.0 / 255.0 : 1.0;
            std::vector<Vec3> poly;
            std::vector<Vec2> polyUV;
            const bool withUV = !vuv.empty() && vuv.size() == pos.size();
            for (size_t k = 0; k < e.count; ++k) {
                reader.read(e, vals, lists);
                const auto& idx = lists[size_t(il)];
                if (idx.size() < 3) reader.fail(fmt::format("face {} has fewer than 3 vertices", k));
                poly.clear();
                polyUV.clear();
                RGB mean(0.0);
                for (double d : idx) {
                    if (!(d >= 0 && d < double(pos.size())))
                        reader.fail(fmt::format("face {} refers to vertex {} but there are {} vertices", k, d, pos.size()));
                    poly.push_back(pos[size_t(d)]);
                    if (vertexColours) mean += vcol[size_t(d)];
                    if (withUV) polyUV.push_back(vuv[size_t(d)]);
                }
                uint32_t mat;
                if (faceColours) {
                    mat = materialFor(RGB(vals[size_t(ir)], vals[size_t(ig)], vals[size_t(ib)]) * scale);
                } else if (vertexColours) {
                    mat = materialFor(mean / double(idx.size()));
                } else {
                    if (defaultMat == UINT32_MAX)
                        defaultMat = scene.addMaterial({"default", RGB(options.defaultRho), RGB(0.0)});
                    mat = defaultMat;
                    ++scene.stats.defaultMaterialFaces;
                }
                addPolygon(scene, poly, mat, withUV ? &polyUV : nullptr);
            }
        } else {
            for (size_t k = 0; k < e.count; ++k) reader.read(e, vals, lists);
        }
    }
    return scene;
}

}  // namespace hrad::scene
