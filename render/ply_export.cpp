#include "render/ply_export.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "core/safe_file.h"
#include "render/image.h"
#include "render/render.h"
#include "scene/element.h"

namespace hrad::render {

namespace {
template <typename T>
void putLE(std::vector<char>& out, T value) {
    char b[sizeof(T)];
    std::memcpy(b, &value, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
    out.insert(out.end(), b, b + sizeof(T));
}
}  // namespace

PlyCounts writePly(const scene::RadiosityField& field, const std::string& path, double exposure) {
    ToneSettings ts;
    ts.exposure = exposure > 0 ? exposure : 0.0;
    return writePly(field, path, leafToneMap(field, ts));
}

PlyCounts writePly(const scene::RadiosityField& field, const std::string& path, const ToneMap& tone,
                   bool interpolate, const SmoothSettings& smooth) {
    const scene::Scene& scene = field.scene();
    const std::vector<FieldLeaf> leaves = fieldLeaves(field);
    std::unique_ptr<VertexInterpolation> interp;
    if (interpolate) interp = std::make_unique<VertexInterpolation>(field, smooth);
    const double exposure = tone.exposure;

    PlyCounts counts;
    std::vector<char> vtx, faces;
    for (const FieldLeaf& l : leaves) {
        const scene::Patch& p = scene.patches[l.patch];
        Vec3 c[4];
        int n = scene::elementCorners(p, scene::keyDomain(p.kind, l.key), c);
        putLE(faces, uint8_t(n));
        for (int i = 0; i < n; ++i) {
            putLE(vtx, float(c[i].x));
            putLE(vtx, float(c[i].y));
            putLE(vtx, float(c[i].z));
            // The leaf's value at this corner (its polynomial, for hr.basis >
            // constant), or the smooth reconstruction's.
            Vec2 a = scene::cornerLocal(p.kind, i);
            RGB b = interp ? interp->cornerValue(l.patch, l.key, i)
                           : field.leafPoint(l.patch, l.key, l.b, a.x, a.y);
            auto rgb = tone.srgb8(b);
            for (uint8_t ch : rgb) putLE(vtx, ch);
            putLE(faces, int32_t(counts.vertices + uint64_t(i)));
        }
        putLE(faces, float(l.b.r));
        putLE(faces, float(l.b.g));
        putLE(faces, float(l.b.b));
        counts.vertices += uint64_t(n);
        ++counts.faces;
    }
    HRAD_CHECK_MSG(counts.vertices < uint64_t(INT32_MAX), "too many vertices for PLY int indices");

    std::ostringstream out;
    out << "ply\nformat binary_little_endian 1.0\n"
        << "comment hrad radiosity field of " << scene.name << ": one face per leaf element\n"
        << "comment vertex colours: sRGB of " << tone.curveName() << "(exposure * B), exposure "
        << fmt::format("{:.6g}", exposure)
        << (tone.curve == ToneCurve::Reinhard ? fmt::format(", white {:.6g}", tone.white) : "")
        << ", the PNG's tone map" << (interpolate ? "; smooth (vertex) reconstruction" : "")
        << "\ncomment face radiosity_r/g/b: linear radiosity B (W/m^2)\n"
        << "element vertex " << counts.vertices << "\n"
        << "property float x\nproperty float y\nproperty float z\n"
        << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
        << "element face " << counts.faces << "\n"
        << "property list uchar int vertex_indices\n"
        << "property float radiosity_r\nproperty float radiosity_g\nproperty float radiosity_b\n"
        << "end_header\n";
    writeThroughTemp(path, [&](const std::filesystem::path& tmp) {
        std::ofstream file(tmp, std::ios::binary | std::ios::trunc);
        file << out.str();
        file.write(vtx.data(), std::streamsize(vtx.size()));
        file.write(faces.data(), std::streamsize(faces.size()));
        file.close();
        if (!file) throw IoError(path, "cannot write the PLY file (disk full?)");
    });
    return counts;
}

}  // namespace hrad::render
