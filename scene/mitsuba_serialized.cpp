// Mitsuba `.serialized` mesh reader (see mitsuba_serialized.h for the format).
#include "scene/mitsuba_serialized.h"

#include <zlib.h>

#include <cmath>
#include <cstring>
#include <fstream>

#include "core/safe_file.h"
#include "core/error.h"

namespace hrad::scene {

namespace {

constexpr uint16_t kFormatId = 0x041C;
constexpr uint32_t kHasNormals = 0x0001, kHasTexcoords = 0x0002, kHasColors = 0x0008;
constexpr uint32_t kSingle = 0x1000, kDouble = 0x2000;
// deflate cannot expand data by more than 1032:1 (zlib FAQ, "maximum
// compression ratio"), so a declared size beyond that of the compressed bytes
// present is corrupt and must not be allocated.
constexpr uint64_t kMaxZlibRatio = 1032;

template <typename T>
T readLE(const unsigned char* p) {
    T v = 0;
    for (size_t i = 0; i < sizeof(T); ++i) v |= T(p[i]) << (8 * i);
    return v;
}

class Reader {
  public:
    Reader(const std::string& path, const std::string& context) : path_(path), context_(context) {}

    [[noreturn]] void fail(uint64_t offset, const std::string& msg) const {
        throw InputError(SourceLocation{path_, 0, 0},
                         fmt::format("{} (at byte offset {}){}", msg, offset,
                                     context_.empty() ? "" : " (" + context_ + ")"));
    }

    void load() {
        requireRegularFile(path_, "serialized mesh file");
        std::ifstream in(path_, std::ios::binary);
        if (!in) throw InputError(SourceLocation{path_, 0, 0}, "cannot open serialized mesh file" +
                                                              (context_.empty() ? "" : " (" + context_ + ")"));
        data_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        if (data_.size() < 4) fail(data_.size(), "truncated serialized mesh file: no header");
    }

    const std::vector<unsigned char>& data() const { return data_; }

  private:
    std::string path_, context_;
    std::vector<unsigned char> data_;
};

/// Pulls decompressed bytes from a zlib stream on demand.
class Inflater {
  public:
    Inflater(const Reader& r, const unsigned char* begin, size_t size, uint64_t fileOffset)
        : r_(r), fileOffset_(fileOffset) {
        std::memset(&zs_, 0, sizeof(zs_));
        zs_.next_in = const_cast<unsigned char*>(begin);
        zs_.avail_in = uInt(size);
        if (inflateInit(&zs_) != Z_OK) r_.fail(fileOffset_, "zlib initialisation failed");
    }
    ~Inflater() { inflateEnd(&zs_); }
    Inflater(const Inflater&) = delete;
    Inflater& operator=(const Inflater&) = delete;

    uint64_t compressedOffset() const { return fileOffset_ + zs_.total_in; }

    void read(void* dst, size_t n, const char* what) {
        zs_.next_out = static_cast<unsigned char*>(dst);
        zs_.avail_out = uInt(n);
        while (zs_.avail_out > 0) {
            int rc = inflate(&zs_, Z_NO_FLUSH);
            if (rc == Z_STREAM_END && zs_.avail_out > 0)
                r_.fail(compressedOffset(), fmt::format("serialized mesh data ends inside the {}", what));
            if (rc == Z_BUF_ERROR || (rc == Z_OK && zs_.avail_in == 0 && zs_.avail_out > 0))
                r_.fail(compressedOffset(), fmt::format("truncated serialized mesh: compressed data ends inside the {}", what));
            if (rc != Z_OK && rc != Z_STREAM_END)
                r_.fail(compressedOffset(), fmt::format("corrupt compressed data in the {} ({})", what,
                                                        zs_.msg ? zs_.msg : "zlib error"));
        }
    }
    template <typename T>
    T get(const char* what) {
        unsigned char b[sizeof(T)];
        read(b, sizeof(T), what);
        return readLE<T>(b);
    }
    /// Reads and drops n bytes (normals, texture coordinates, colours).
    void skip(uint64_t n, const char* what) {
        unsigned char buf[4096];
        while (n > 0) {
            size_t k = size_t(std::min<uint64_t>(n, sizeof(buf)));
            read(buf, k, what);
            n -= k;
        }
    }

  private:
    const Reader& r_;
    uint64_t fileOffset_;
    z_stream zs_;
};

/// A real (float or double, as the flags say) from the stream.
double getReal(Inflater& z, uint64_t real, const char* what) {
    if (real == 8) {
        const uint64_t bits = z.get<uint64_t>(what);
        double v;
        std::memcpy(&v, &bits, 8);
        return v;
    }
    const uint32_t bits = z.get<uint32_t>(what);
    float v;
    std::memcpy(&v, &bits, 4);
    return v;
}

/// nv texture coordinates (u, v), finite, as stored.
void readTexcoords(Inflater& z, const Reader& r, uint64_t real, uint64_t nv, std::vector<Vec2>& out) {
    out.resize(size_t(nv));
    for (uint64_t i = 0; i < nv; ++i) {
        Vec2 t;
        t.x = getReal(z, real, "texture coordinates");
        t.y = getReal(z, real, "texture coordinates");
        if (!std::isfinite(t.x) || !std::isfinite(t.y))
            r.fail(z.compressedOffset(), fmt::format("vertex {} has a non-finite texture coordinate", i));
        out[size_t(i)] = t;
    }
}

}  // namespace

SerializedMesh readSerialized(const std::string& path, uint64_t shapeIndex, uint64_t maxFaces,
                              const std::string& context, uint64_t maxInflatedBytes) {
    Reader r(path, context);
    r.load();
    const std::vector<unsigned char>& d = r.data();
    const uint64_t size = d.size();

    uint16_t id = readLE<uint16_t>(d.data());
    uint16_t version = readLE<uint16_t>(d.data() + 2);
    if (id != kFormatId)
        r.fail(0, fmt::format("not a Mitsuba serialized mesh (format id 0x{:04X}, expected 0x041C)", id));
    if (version != 3 && version != 4)
        r.fail(2, fmt::format("unsupported serialized mesh version {} (3 and 4 are known)", version));

    // Start of the requested mesh: the offset table at the end of the file.
    uint64_t start = 0;
    if (size < 8) r.fail(size, "truncated serialized mesh file: no mesh count at the end");
    uint32_t count = readLE<uint32_t>(d.data() + size - 4);
    const uint64_t entry = version == 4 ? 8 : 4;
    if (count == 0 || uint64_t(count) * entry + 4 > size)
        r.fail(size - 4, fmt::format("serialized mesh file has an invalid mesh count {} at its end "
                                     "(truncated file?)", count));
    if (shapeIndex >= count)
        r.fail(size - 4, fmt::format("shape_index {} out of range: the file holds {} mesh{}", shapeIndex,
                                     count, count == 1 ? "" : "es"));
    const uint64_t table = size - 4 - uint64_t(count) * entry;
    const uint64_t at = table + shapeIndex * entry;
    start = version == 4 ? readLE<uint64_t>(d.data() + at) : readLE<uint32_t>(d.data() + at);
    uint64_t end = table;
    if (shapeIndex + 1 < count) {
        uint64_t next = version == 4 ? readLE<uint64_t>(d.data() + at + entry)
                                     : readLE<uint32_t>(d.data() + at + entry);
        if (next > start && next <= table) end = next;
    }
    if (end > size || start > end || end - start < 4)  // no start + 4: it may wrap
        r.fail(at, fmt::format("mesh offset {} of shape_index {} lies outside the file", start, shapeIndex));
    if (readLE<uint16_t>(d.data() + start) != kFormatId)
        r.fail(start, fmt::format("no serialized mesh header at the offset of shape_index {}", shapeIndex));
    version = readLE<uint16_t>(d.data() + start + 2);
    if (version != 3 && version != 4)
        r.fail(start + 2, fmt::format("unsupported serialized mesh version {}", version));

    const uint64_t zBegin = start + 4, zSize = end - zBegin;
    if (zSize > UINT32_MAX) r.fail(zBegin, "compressed mesh larger than 4 GiB is not supported");
    Inflater z(r, d.data() + zBegin, size_t(zSize), zBegin);

    SerializedMesh mesh;
    uint32_t flags = z.get<uint32_t>("flags");
    if ((flags & kSingle) && (flags & kDouble))
        r.fail(z.compressedOffset(), "flags say both single and double precision");
    const uint64_t real = (flags & kDouble) ? 8 : 4;
    if (version == 4) {
        for (;;) {
            char c = char(z.get<uint8_t>("mesh name"));
            if (c == 0) break;
            if (mesh.name.size() >= 4096) r.fail(z.compressedOffset(), "mesh name longer than 4096 bytes");
            mesh.name += c;
        }
    }
    const uint64_t nv = z.get<uint64_t>("vertex count");
    const uint64_t nt = z.get<uint64_t>("triangle count");
    if (nt > maxFaces)
        r.fail(z.compressedOffset(), fmt::format("mesh declares {} triangles, more than the limit {} "
                                                 "(setting mitsuba.max_faces)", nt, maxFaces));
    if (nv > 3 * maxFaces + 3 || nv > UINT32_MAX)
        r.fail(z.compressedOffset(), fmt::format("mesh declares {} vertices, more than the face "
                                                 "budget allows", nv));
    const uint64_t idx = 4;  // nv <= UINT32_MAX was checked: indices are uint32
    const uint64_t declared = nv * 3 * real + nt * 3 * idx;
    if (declared > (zSize + 1) * kMaxZlibRatio)
        r.fail(z.compressedOffset(), fmt::format("mesh declares {} vertices and {} triangles, more than "
                                                 "{} compressed bytes can hold (corrupt or truncated)",
                                                 nv, nt, zSize));

    // All the data the mesh inflates to, read or skipped: a 911 KiB file
    // declared 3.6 GiB within the face budget (issue 64).
    mesh.inflatedBytes = declared + ((flags & kHasNormals) ? nv * 3 * real : 0) +
                         ((flags & kHasTexcoords) ? nv * 2 * real : 0) +
                         ((flags & kHasColors) ? nv * 3 * real : 0);
    if (mesh.inflatedBytes > maxInflatedBytes)
        r.fail(z.compressedOffset(),
               fmt::format("mesh data inflate to {} MiB, more than the scene's remaining budget of "
                           "{} MiB (setting mitsuba.max_inflated_mb)",
                           mesh.inflatedBytes >> 20, maxInflatedBytes >> 20));
    mesh.positions.resize(size_t(nv));
    for (uint64_t i = 0; i < nv; ++i) {
        Vec3 p;
        for (int k = 0; k < 3; ++k) p[k] = getReal(z, real, "vertex positions");
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            r.fail(z.compressedOffset(), fmt::format("vertex {} has a non-finite coordinate", i));
        mesh.positions[size_t(i)] = p;
    }
    if (flags & kHasNormals) z.skip(nv * 3 * real, "vertex normals");
    if (flags & kHasTexcoords) readTexcoords(z, r, real, nv, mesh.texcoords);
    if (flags & kHasColors) z.skip(nv * 3 * real, "vertex colours");

    mesh.triangles.resize(size_t(nt));
    for (uint64_t t = 0; t < nt; ++t) {
        std::array<uint32_t, 3> tri;
        for (int k = 0; k < 3; ++k) {
            tri[k] = z.get<uint32_t>("triangle indices");
            if (tri[k] >= nv)
                r.fail(z.compressedOffset(), fmt::format("triangle {} names vertex {} of {}", t, tri[k], nv));
        }
        mesh.triangles[size_t(t)] = tri;
    }
    return mesh;
}

}  // namespace hrad::scene
