// OBJ/MTL loading (see obj_loader.h).
#include "scene/obj_loader.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include <tiny_obj_loader.h>

#include "core/error.h"
#include "scene/triangulate.h"

namespace hrad::scene {

namespace {

struct MtlLocation {
    std::string file;
    int line = 0;
};

bool parseDouble(const std::string& tok, double& out) {
    if (tok.empty()) return false;
    char* end = nullptr;
    out = std::strtod(tok.c_str(), &end);
    return end && *end == '\0';
}

// Checks the OBJ text for what tinyobjloader accepts silently and records
// where each material is defined.
void preScan(const std::string& path, std::map<std::string, MtlLocation>& mtlLines) {
    std::ifstream in(path);
    if (!in) throwInputError(SourceLocation{path, 0, 0}, "cannot open file");
    std::string line;
    int lineNo = 0;
    long numVertices = 0;
    std::vector<std::string> mtllibs;
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
                    throwInputError(SourceLocation{path, lineNo, 0}, "malformed vertex coordinate '{}'",
                                    tok);
                if (!std::isfinite(d))
                    throwInputError(SourceLocation{path, lineNo, 0}, "non-finite vertex coordinate '{}'",
                                    tok);
            }
            ++numVertices;
        } else if (key == "f") {
            std::string tok;
            int n = 0;
            while (ss >> tok) {
                std::string first = tok.substr(0, tok.find('/'));
                char* end = nullptr;
                long idx = std::strtol(first.c_str(), &end, 10);
                if (first.empty() || !end || *end != '\0')
                    throwInputError(SourceLocation{path, lineNo, 0}, "malformed face index '{}'", tok);
                long resolved = idx > 0 ? idx : numVertices + idx + 1;
                if (idx == 0 || resolved < 1 || resolved > numVertices)
                    throwInputError(SourceLocation{path, lineNo, 0},
                                    "face refers to vertex {} but only {} vertices are defined", idx,
                                    numVertices);
                ++n;
            }
            if (n < 3) throwInputError(SourceLocation{path, lineNo, 0}, "face with fewer than 3 vertices");
        } else if (key == "mtllib") {
            std::string rest;
            std::getline(ss, rest);
            size_t b = rest.find_first_not_of(" \t"), e = rest.find_last_not_of(" \t\r");
            if (b != std::string::npos) mtllibs.push_back(rest.substr(b, e - b + 1));
        }
    }
    std::filesystem::path dir = std::filesystem::path(path).parent_path();
    for (const auto& lib : mtllibs) {
        std::string mpath = (dir / lib).string();
        std::ifstream min(mpath);
        int ln = 0;
        while (std::getline(min, line)) {
            ++ln;
            std::istringstream ss(line);
            std::string key, name;
            ss >> key;
            if (key == "newmtl" && (ss >> name) && !mtlLines.count(name)) mtlLines[name] = {mpath, ln};
        }
    }
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

}  // namespace

Scene loadObj(const std::string& path, const ObjOptions& options) {
    std::map<std::string, MtlLocation> mtlLines;
    preScan(path, mtlLines);

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
    scene.name = path;
    scene.source = "obj";
    if (!reader.Warning().empty()) {
        std::istringstream ws(reader.Warning());
        std::string w;
        while (std::getline(ws, w))
            if (!trimmed(w).empty()) scene.stats.warnings.push_back(fmt::format("{}: {}", path, trimmed(w)));
    }

    const auto& mats = reader.GetMaterials();
    for (const auto& m : mats) {
        Material mat;
        mat.name = m.name;
        mat.rho = RGB(m.diffuse[0], m.diffuse[1], m.diffuse[2]);
        mat.emission = RGB(m.emission[0], m.emission[1], m.emission[2]);
        if (options.clampRho > 0) {
            bool clamped = false;
            for (int c = 0; c < 3; ++c)
                if (mat.rho[c] >= 1.0) {
                    mat.rho[c] = options.clampRho;
                    clamped = true;
                }
            if (clamped)
                scene.stats.warnings.push_back(fmt::format(
                    "{}: material '{}': reflectance >= 1 clamped to {} (obj.clamp_rho)", path,
                    m.name, options.clampRho));
        }
        for (int c = 0; c < 3; ++c) {
            bool rhoOk = mat.rho[c] >= 0.0 && mat.rho[c] < 1.0;
            bool eOk = mat.emission[c] >= 0.0 && std::isfinite(mat.emission[c]);
            if (!rhoOk || !eOk) {
                auto it = mtlLines.find(m.name);
                SourceLocation where = it != mtlLines.end() ? SourceLocation{it->second.file, it->second.line, 0}
                                                            : SourceLocation{path, 0, 0};
                if (!rhoOk)
                    throwInputError(where,
                                    "material '{}': reflectance Kd ({:.6g}, {:.6g}, {:.6g}) must be in "
                                    "[0, 1) per channel (set obj.clamp_rho, e.g. 0.99, to clamp)",
                                    m.name, mat.rho.r, mat.rho.g, mat.rho.b);
                throwInputError(where, "material '{}': emission Ke must be finite and >= 0", m.name);
            }
        }
        scene.addMaterial(mat);
    }

    const auto& attrib = reader.GetAttrib();
    const auto& verts = attrib.vertices;
    uint32_t defaultMaterial = UINT32_MAX;
    std::vector<Vec3> poly;
    for (const auto& shape : reader.GetShapes()) {
        const auto& mesh = shape.mesh;
        size_t offset = 0;
        for (size_t f = 0; f < mesh.num_face_vertices.size(); ++f) {
            size_t n = mesh.num_face_vertices[f];
            poly.clear();
            for (size_t k = 0; k < n; ++k) {
                int vi = mesh.indices[offset + k].vertex_index;
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
                    defaultMaterial = scene.addMaterial({"default", RGB(options.defaultRho), RGB(0.0)});
                material = defaultMaterial;
                ++scene.stats.defaultMaterialFaces;
            } else {
                material = uint32_t(mid);
            }
            addPolygon(scene, poly, material);
        }
    }
    if (scene.stats.defaultMaterialFaces > 0)
        scene.stats.warnings.push_back(fmt::format(
            "{}: {} faces have no material; they use grey 'default' (rho = obj.default_rho = {})", path,
            scene.stats.defaultMaterialFaces, options.defaultRho));
    return scene;
}

}  // namespace hrad::scene
