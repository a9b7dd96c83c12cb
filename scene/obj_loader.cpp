// OBJ/MTL loading (see obj_loader.h).
#include "scene/obj_loader.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <regex>
#include <sstream>

#include <tiny_obj_loader.h>

#include "core/error.h"
#include "core/parse.h"
#include "scene/texture.h"
#include "scene/triangulate.h"

namespace hrad::scene {

namespace {

struct MtlLocation {
    std::string file;
    int line = 0;
};

/// What hrad reads of one MTL material, parsed by hrad itself: tinyobjloader
/// reads `Kd abc 0.5 0.5` as (0, 0.5, 0.5), `Kd 0.7` as (0.7, 0, 0) and
/// `Ke 10x 10 10` as (10, 10, 10) without a word.
struct MtlMaterial {
    MtlLocation where;  ///< the newmtl line
    std::optional<RGB> kd, ke;
    MtlLocation kdWhere, keWhere;
};

bool parseDouble(const std::string& tok, double& out) {
    auto v = parseFiniteDouble(tok);
    if (v) out = *v;
    return v.has_value();
}

std::vector<std::string> tokens(const std::string& line) {
    std::istringstream ss(line);
    std::vector<std::string> t;
    std::string w;
    while (ss >> w) t.push_back(w);
    return t;
}

// MTL colour statements (Wavefront MTL spec): `Kd r [g b]`, where a lone r
// stands for grey (g = b = r); `Kd spectral file` and `Kd xyz x y z` are
// refused (hrad works in RGB). Numbers strictly parsed (core/parse.h).
RGB mtlColour(const std::vector<std::string>& t, const SourceLocation& where) {
    if (t.size() > 1 && (t[1] == "spectral" || t[1] == "xyz"))
        throwInputError(where, "'{} {}' is not supported (hrad reads RGB: '{} r g b')", t[0], t[1], t[0]);
    if (t.size() != 2 && t.size() != 4)
        throwInputError(where, "'{}' needs 1 or 3 numbers ('{} r g b', or '{} v' for grey), got {}", t[0],
                        t[0], t[0], t.size() - 1);
    RGB c(0.0);
    for (size_t k = 1; k < t.size(); ++k) {
        auto v = parseFiniteDouble(t[k]);
        if (!v) throwInputError(where, "'{}': malformed or non-finite number '{}'", t[0], t[k]);
        c[int(k - 1)] = *v;
    }
    if (t.size() == 2) c = RGB(c.r);
    return c;
}

// Checks every numeric MTL statement strictly; records Kd and Ke per material.
void scanMtl(const std::string& mpath, std::map<std::string, MtlMaterial>& mtl) {
    std::ifstream in(mpath, std::ios::binary);
    if (!in) throwInputError(SourceLocation{mpath, 0, 0}, "cannot open material library");
    static const std::set<std::string> colourKeys = {"Ka", "Kd", "Ks", "Ke", "Kt", "Tf"};
    static const std::set<std::string> scalarKeys = {"Ns", "Ni", "d", "Tr", "illum", "sharpness",
                                                     "Pr", "Pm", "Ps", "Pc", "Pcr", "aniso", "anisor"};
    std::string line;
    int ln = 0;
    MtlMaterial* cur = nullptr;
    std::set<std::string> seenHere;
    while (std::getline(in, line)) {
        ++ln;
        if (size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);  // `Ka 1 1 1 # red`
        std::vector<std::string> t = tokens(line);
        if (t.empty() || t[0][0] == '#') continue;
        SourceLocation where{mpath, ln, 0};
        if (t[0] == "newmtl") {
            if (t.size() < 2) throwInputError(where, "'newmtl' needs a name");
            // Later definitions of a name in other libraries are ignored, as
            // tinyobjloader keeps the first one.
            if (mtl.count(t[1])) {
                cur = seenHere.count(t[1]) ? &mtl[t[1]] : nullptr;
                if (seenHere.count(t[1]))
                    throwInputError(where, "material '{}' defined twice in this file (first at line {})",
                                    t[1], mtl[t[1]].where.line);
                continue;
            }
            seenHere.insert(t[1]);
            cur = &mtl[t[1]];
            cur->where = {mpath, ln};
        } else if (colourKeys.count(t[0]) || scalarKeys.count(t[0])) {
            if (colourKeys.count(t[0])) {
                RGB c = mtlColour(t, where);
                if (cur && t[0] == "Kd") {
                    cur->kd = c;
                    cur->kdWhere = {mpath, ln};
                } else if (cur && t[0] == "Ke") {
                    cur->ke = c;
                    cur->keWhere = {mpath, ln};
                }
            } else {
                size_t first = (t[0] == "d" && t.size() > 1 && t[1] == "-halo") ? 2 : 1;
                if (t.size() != first + 1)
                    throwInputError(where, "'{}' needs one number, got {}", t[0], t.size() - first);
                if (!parseFiniteDouble(t[first]))
                    throwInputError(where, "'{}': malformed or non-finite number '{}'", t[0], t[first]);
            }
            if (!cur && seenHere.empty())
                throwInputError(where, "'{}' before any 'newmtl'", t[0]);
        }
    }
}

// Checks the OBJ text for what tinyobjloader accepts silently, and the
// material libraries it names (which must exist).
void preScan(const std::string& path, std::map<std::string, MtlMaterial>& mtl, MissingFiles& missing) {
    std::ifstream in(path);
    if (!in) throwInputError(SourceLocation{path, 0, 0}, "cannot open file");
    std::string line;
    int lineNo = 0;
    long numVertices = 0;
    std::vector<std::pair<std::string, int>> mtllibs;  // resolved path, OBJ line
    std::filesystem::path dir = std::filesystem::path(path).parent_path();
    while (std::getline(in, line)) {
        ++lineNo;
        if (line.size() < 2) continue;
        std::istringstream ss(line);
        std::string key;
        ss >> key;
        if (key == "v") {
            for (int k = 0; k < 3; ++k) {
                std::string tok;
                double d;
                if (!(ss >> tok))
                    throwInputError(SourceLocation{path, lineNo, 0}, "vertex needs 3 coordinates");
                if (!parseDouble(tok, d))
                    throwInputError(SourceLocation{path, lineNo, 0},
                                    "malformed or non-finite vertex coordinate '{}'", tok);
            }
            ++numVertices;
        } else if (key == "f") {
            std::string tok;
            int n = 0;
            while (ss >> tok) {
                std::string first = tok.substr(0, tok.find('/'));
                auto idx = parseInt64(first);
                if (!idx)
                    throwInputError(SourceLocation{path, lineNo, 0}, "malformed face index '{}'", tok);
                int64_t resolved = *idx > 0 ? *idx : numVertices + *idx + 1;
                if (*idx == 0 || resolved < 1 || resolved > numVertices)
                    throwInputError(SourceLocation{path, lineNo, 0},
                                    "face refers to vertex {} but only {} vertices are defined", *idx,
                                    numVertices);
                ++n;
            }
            if (n < 3) throwInputError(SourceLocation{path, lineNo, 0}, "face with fewer than 3 vertices");
        } else if (key == "mtllib") {
            std::string rest;
            std::getline(ss, rest);
            size_t b = rest.find_first_not_of(" \t"), e = rest.find_last_not_of(" \t\r");
            if (b == std::string::npos)
                throwInputError(SourceLocation{path, lineNo, 0}, "'mtllib' needs a file name");
            rest = rest.substr(b, e - b + 1);
            // One name with spaces, or several names separated by spaces (as
            // tinyobjloader splits them).
            std::vector<std::string> names{rest};
            std::error_code ec;
            if (!std::filesystem::is_regular_file(dir / rest, ec)) names = tokens(rest);
            for (const auto& n : names) {
                std::filesystem::path mp = dir / n;
                if (std::filesystem::is_directory(mp, ec))
                    throwInputError(SourceLocation{path, lineNo, 0}, "material library '{}' is a folder", n);
                if (!std::filesystem::exists(mp, ec)) {  // scene.missing: default materials
                    missing.add(SourceLocation{path, lineNo, 0}, "material library", mp.string());
                    continue;
                }
                if (!std::filesystem::is_regular_file(mp, ec))
                    throwInputError(SourceLocation{path, lineNo, 0},
                                    "material library '{}' is not a regular file", n);
                mtllibs.emplace_back(mp.string(), lineNo);
            }
        }
    }
    for (const auto& lib : mtllibs) scanMtl(lib.first, mtl);
}

// tinyobjloader reports "... line 12 ..." in some messages: recover it.
SourceLocation locationFromMessage(const std::string& path, const std::string& msg) {
    std::smatch m;
    static const std::regex re("line ([0-9]+)");
    if (std::regex_search(msg, m, re)) return SourceLocation{path, std::atoi(m[1].str().c_str()), 0};
    return SourceLocation{path, 0, 0};
}

std::string trimmed(std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
    return s;
}

/// map_Kd of material m: decoded once per file (sRGB, the convention of
/// OBJ textures), repeat or (-clamp on) clamp; rho(x) = Kd * texel (MTL spec:
/// map_Kd multiplies Kd), or the texel alone with obj.texture_kd = replace.
/// A file that is missing or cannot be decoded is a warning naming it; the
/// material keeps Kd.
void bindDiffuseMap(Scene& scene, Material& mat, const tinyobj::material_t& m,
                    const MtlMaterial* mm, const std::string& path, const ObjOptions& options,
                    TextureBudget& budget, std::map<std::string, int32_t>& decoded) {
    if (m.diffuse_texname.empty()) return;
    const std::string file =
        (std::filesystem::path(path).parent_path() / m.diffuse_texname).lexically_normal().string();
    auto it = decoded.find(file);
    if (it == decoded.end()) {
        std::string why;
        const SourceLocation where = mm ? SourceLocation{mm->where.file, mm->where.line, 0}
                                        : SourceLocation{path, 0, 0};
        std::optional<Texture> t = decodeTextureFile(file, TextureEncoding::Srgb, budget, where, why);
        if (!t) {
            scene.stats.warnings.push_back(fmt::format(
                "{}: material '{}': map_Kd '{}' {}; the material's reflectance Kd is used", path,
                m.name, file, why));
            it = decoded.emplace(file, -2).first;
        } else {
            const TextureWrap wrap = m.diffuse_texopt.clamp ? TextureWrap::Clamp : TextureWrap::Repeat;
            t->wrapU = t->wrapV = wrap;
            it = decoded.emplace(file, addTexture(scene, std::move(*t))).first;
        }
    }
    if (it->second < 0) return;
    mat.diffuseMap.texture = it->second;
    mat.diffuseMap.scale = options.textureReplacesKd ? RGB(1.0) : mat.rho;
    mat.diffuseMap.clampRho = options.clampRho > 0 ? options.clampRho : 0.0;
    mat.diffuseMap.clampKey = "scene.clamp_rho";
    // The fallback for faces without UVs: the texture's mean times the scale.
    const RGB mean = mat.diffuseMap.scale * scene.textures[size_t(it->second)]->mean;
    for (int c = 0; c < 3; ++c)
        mat.rho[c] = mean[c] < 1.0 ? mean[c] : (options.clampRho > 0 ? options.clampRho : mat.rho[c]);
}

/// The MTL materials tinyobjloader read, with Kd and Ke as hrad parsed them
/// (`mtl`), range-checked and clamped (scene.clamp_rho), and their map_Kd.
void addMaterials(Scene& scene, const std::vector<tinyobj::material_t>& mats,
                  const std::map<std::string, MtlMaterial>& mtl, const std::string& path,
                  const ObjOptions& options) {
    TextureBudget budget{options.textureBudget};
    std::map<std::string, int32_t> decoded;  // texture file -> index (-2: failed)
    for (const auto& m : mats) {
        Material mat;
        mat.name = m.name;
        // Kd and Ke as hrad parsed them; absent, tinyobjloader's defaults
        // (black, or grey 0.6 for a map_Kd without Kd).
        auto own = mtl.find(m.name);
        const MtlMaterial* mm = own != mtl.end() ? &own->second : nullptr;
        mat.rho = mm && mm->kd ? *mm->kd : RGB(m.diffuse[0], m.diffuse[1], m.diffuse[2]);
        mat.emission = mm && mm->ke ? *mm->ke : RGB(m.emission[0], m.emission[1], m.emission[2]);
        if (clampReflectance(mat.rho, options.clampRho) == RhoCheck::Clamped)  // scene.h
            scene.stats.warnings.push_back(fmt::format("{}: material '{}': {}", path, m.name,
                                                       clampedNote(options.clampRho)));
        for (int c = 0; c < 3; ++c) {
            bool rhoOk = mat.rho[c] >= 0.0 && mat.rho[c] < 1.0;
            bool eOk = mat.emission[c] >= 0.0 && std::isfinite(mat.emission[c]);
            if (!rhoOk || !eOk) {
                MtlLocation at = !mm ? MtlLocation{path, 0}
                                 : !rhoOk && mm->kd ? mm->kdWhere
                                 : !eOk && mm->ke   ? mm->keWhere
                                                    : mm->where;
                SourceLocation where{at.file, at.line, 0};
                if (!rhoOk)
                    throwInputError(where,
                                    "material '{}': reflectance Kd ({:.6g}, {:.6g}, {:.6g}) must be in "
                                    "[0, 1) per channel ({})",
                                    m.name, mat.rho.r, mat.rho.g, mat.rho.b, kClampRhoHint);
                throwInputError(where, "material '{}': emission Ke must be finite and >= 0", m.name);
            }
        }
        mat.twoSided = options.twoSided;
        if (options.readTextures) bindDiffuseMap(scene, mat, m, mm, path, options, budget, decoded);
        scene.addMaterial(mat);
    }

}

}  // namespace

Scene loadObj(const std::string& path, const ObjOptions& options) {
    std::map<std::string, MtlMaterial> mtl;
    MissingFiles missing;
    preScan(path, mtl, missing);

    tinyobj::ObjReaderConfig config;
    config.triangulate = false;
    config.vertex_color = false;
    config.mtl_search_path = std::filesystem::path(path).parent_path().string();
    tinyobj::ObjReader reader;
    if (!reader.ParseFromFile(path, config)) {
        std::string msg = trimmed(reader.Error());
        throwInputError(locationFromMessage(path, msg), "OBJ: {}", msg.empty() ? "parse failed" : msg);
    }

    Scene scene;
    scene.stats.missingFiles = std::move(missing);
    scene.name = path;
    scene.source = "obj";
    if (!reader.Warning().empty()) {
        std::istringstream ws(reader.Warning());
        std::string w;
        while (std::getline(ws, w))
            if (!trimmed(w).empty()) scene.stats.warnings.push_back(fmt::format("{}: {}", path, trimmed(w)));
    }

    const auto& mats = reader.GetMaterials();
    addMaterials(scene, mats, mtl, path, options);

    const auto& attrib = reader.GetAttrib();
    const auto& verts = attrib.vertices;
    uint32_t defaultMaterial = UINT32_MAX;
    const auto& texcoords = attrib.texcoords;
    std::vector<Vec3> poly;
    std::vector<Vec2> uv;
    for (const auto& shape : reader.GetShapes()) {
        const auto& mesh = shape.mesh;
        size_t offset = 0;
        for (size_t f = 0; f < mesh.num_face_vertices.size(); ++f) {
            size_t n = mesh.num_face_vertices[f];
            poly.clear();
            uv.clear();
            bool hasUV = true;
            for (size_t k = 0; k < n; ++k) {
                int vi = mesh.indices[offset + k].vertex_index;
                const int ti = mesh.indices[offset + k].texcoord_index;
                if (ti >= 0 && size_t(2 * ti + 1) < texcoords.size())
                    uv.emplace_back(texcoords[2 * size_t(ti)], texcoords[2 * size_t(ti) + 1]);
                else
                    hasUV = false;
                if (vi < 0 || size_t(3 * vi + 2) >= verts.size())
                    throwInputError(SourceLocation{path, 0, 0}, "face in shape '{}' refers to a missing vertex",
                                    shape.name);
                poly.emplace_back(verts[3 * size_t(vi)], verts[3 * size_t(vi) + 1], verts[3 * size_t(vi) + 2]);
            }
            offset += n;
            int mid = f < mesh.material_ids.size() ? mesh.material_ids[f] : -1;
            uint32_t material;
            if (mid < 0 || size_t(mid) >= mats.size()) {
                if (defaultMaterial == UINT32_MAX)
                    defaultMaterial = scene.addMaterial(
                        {"default", RGB(options.defaultRho), RGB(0.0), options.twoSided, false});
                material = defaultMaterial;
                ++scene.stats.defaultMaterialFaces;
            } else {
                material = uint32_t(mid);
            }
            // UVs only where the material has a texture to look up.
            const bool wantsUV =
                hasUV && (options.keepUVs || scene.materials[material].diffuseMap.texture >= 0);
            addPolygon(scene, poly, material, wantsUV ? &uv : nullptr);
        }
    }
    if (scene.stats.defaultMaterialFaces > 0)
        scene.stats.warnings.push_back(fmt::format(
            "{}: {} faces have no material; they use grey 'default' (rho = obj.default_rho = {})", path,
            scene.stats.defaultMaterialFaces, options.defaultRho));
    return scene;
}

}  // namespace hrad::scene
