// glTF 2.0 loading (see gltf_loader.h).
#include "scene/gltf_loader.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <regex>
#include <set>
#include <sstream>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <stb/stb_image.h>
#include <tiny_gltf.h>

#include "core/error.h"
#include "scene/texture.h"
#include "scene/triangulate.h"

namespace hrad::scene {

namespace {

using Mat4 = glm::dmat4;

// ---- file intake -----------------------------------------------------------------

/// Reads a whole file, only a regular one, with the size the file system
/// states; false with the reason in *err otherwise. Also tinygltf's file
/// callback for buffer and image URIs: its own reads the size with
/// seekg/tellg, which for a folder on ext4 is 2^63 - 1, and then resizes a
/// vector to it (a URI naming a folder, "." or "", asked for 8 EiB).
bool readUriFile(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                 void*) {
    std::error_code ec;
    auto status = std::filesystem::status(path, ec);
    if (ec || !std::filesystem::is_regular_file(status)) {
        if (err) *err += "not a regular file (a folder or device)";
        return false;
    }
    uintmax_t size = std::filesystem::file_size(path, ec);
    if (ec) {
        if (err) *err += "cannot determine the file size";
        return false;
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        if (err) *err += "cannot open the file";
        return false;
    }
    out->resize(size_t(size));
    if (size > 0 && !in.read(reinterpret_cast<char*>(out->data()), std::streamsize(size))) {
        out->clear();
        if (err) *err += "error reading the file";
        return false;
    }
    return true;
}

std::vector<unsigned char> readWholeFile(const std::string& path) {
    std::vector<unsigned char> bytes;
    std::string err;
    if (!readUriFile(&bytes, &err, path, nullptr))
        throwInputError(SourceLocation{path, 0, 0}, "{}", err);
    return bytes;
}

/// Bytes in the file's (little-endian, glTF 2.0 §4.4) order -> native.
template <typename T>
T fromLE(T v) {
    if constexpr (sizeof(T) > 1 && std::endian::native == std::endian::big) {
        unsigned char b[sizeof(T)];
        std::memcpy(b, &v, sizeof(T));
        std::reverse(b, b + sizeof(T));
        std::memcpy(&v, b, sizeof(T));
    }
    return v;
}

uint32_t le32(const unsigned char* p) {
    uint32_t v;
    std::memcpy(&v, p, 4);
    return fromLE(v);
}

/// Checks the GLB container (glTF 2.0 §4.4) before tinygltf sees it, so that a
/// truncated or malformed file names the byte offset where it goes wrong.
/// Returns the offset of the JSON chunk's data.
size_t checkGlb(const std::string& path, const std::vector<unsigned char>& b) {
    auto fail = [&](size_t offset, const std::string& msg) {
        throwInputError(SourceLocation{path, 0, 0}, "{} (at byte offset {})", msg, offset);
    };
    if (b.size() < 12)
        fail(b.size(), fmt::format("truncated GLB: the file has {} bytes, the header alone needs 12", b.size()));
    if (std::memcmp(b.data(), "glTF", 4) != 0) fail(0, "not a binary glTF file (no 'glTF' magic)");
    uint32_t version = le32(&b[4]);
    if (version != 2) fail(4, fmt::format("GLB container version {} (hrad reads version 2)", version));
    uint32_t length = le32(&b[8]);
    if (length > b.size())
        fail(b.size(), fmt::format("truncated GLB: the header says {} bytes but the file ends after {}", length,
                                   b.size()));
    if (length < 20) fail(8, fmt::format("GLB length {} is too small for a JSON chunk", length));
    size_t offset = 12;
    size_t jsonData = 0;
    for (int chunk = 0; offset < length; ++chunk) {
        if (length - offset < 8) fail(offset, "truncated GLB chunk header");
        uint32_t chunkLength = le32(&b[offset]);
        uint32_t chunkType = le32(&b[offset + 4]);
        if (uint64_t(chunkLength) > uint64_t(length) - offset - 8)
            fail(offset, fmt::format("truncated GLB: chunk {} declares {} bytes but only {} remain", chunk,
                                     chunkLength, uint64_t(length) - offset - 8));
        if (chunk == 0) {
            if (chunkType != 0x4E4F534Au) fail(offset + 4, "the first GLB chunk is not JSON");
            if (chunkLength == 0) fail(offset, "empty GLB JSON chunk");
            jsonData = offset + 8;
        }
        offset += 8 + size_t(chunkLength);
    }
    return jsonData;
}

/// Throws when arrays and objects nest deeper than kMaxJsonDepth: tinygltf
/// converts "extras" and "extensions" values recursively, so 200,000 nested
/// arrays would overflow the stack (issue 64). A linear scan outside strings.
constexpr int kMaxJsonDepth = 256;
void checkJsonDepth(const std::string& path, const std::vector<unsigned char>& text, size_t begin,
                    size_t end, bool binary) {
    int depth = 0, line = 1;
    bool inString = false;
    for (size_t i = begin; i < end; ++i) {
        const unsigned char c = text[i];
        if (c == '\n') ++line;
        if (inString) {
            if (c == '\\') ++i;
            else if (c == '"') inString = false;
        } else if (c == '"') {
            inString = true;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxJsonDepth) {
                if (binary)
                    throwInputError(SourceLocation{path, 0, 0},
                                    "JSON arrays and objects nested deeper than {} levels (at byte "
                                    "offset {}, in the GLB JSON chunk)", kMaxJsonDepth, i);
                throwInputError(SourceLocation{path, line, 0},
                                "JSON arrays and objects nested deeper than {} levels", kMaxJsonDepth);
            }
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
}

/// nlohmann-json's parse errors read "... parse error at line L, column C: ...".
int jsonErrorLine(const std::string& err) {
    static const std::regex re("at line ([0-9]+)");
    std::smatch m;
    if (std::regex_search(err, m, re)) return std::stoi(m[1].str());
    return 0;
}

/// The line of the first occurrence of `needle"` in JSON text (0 if none):
/// gives a line to errors about a named URI, which tinygltf reports without one.
int lineOfString(const std::vector<unsigned char>& text, size_t begin, size_t end, const std::string& needle) {
    if (needle.empty()) return 0;
    std::string quoted = needle + "\"";  // the end of a JSON string value
    auto it = std::search(text.begin() + std::ptrdiff_t(begin), text.begin() + std::ptrdiff_t(end),
                          quoted.begin(), quoted.end());
    if (it == text.begin() + std::ptrdiff_t(end)) return 0;
    return 1 + int(std::count(text.begin() + std::ptrdiff_t(begin), it, '\n'));
}

/// tinygltf's multi-line messages as one line ("a; b").
std::string firstLine(const std::string& s) {
    std::istringstream in(s);
    std::string out;
    for (std::string l; std::getline(in, l);) {
        while (!l.empty() && (l.back() == '\r' || l.back() == ' ')) l.pop_back();
        if (!l.empty()) out += (out.empty() ? "" : "; ") + l;
    }
    return out;
}

/// Where the value at a JSON path (e.g. "meshes[0].primitives[1].indices")
/// starts in well-formed JSON text, or npos. tinygltf keeps no positions, so
/// errors found after parsing are located by scanning the text once more:
/// only along the path, skipping other values by bracket counting.
size_t locateJsonPath(const std::string& t, const std::string& path) {
    constexpr size_t npos = std::string::npos;
    static const std::regex stepRe(R"(^(?:\.?([A-Za-z_][A-Za-z_0-9]*)|\[([0-9]{1,9})\]))");
    const size_t end = t.size();
    size_t i = 0;
    auto ws = [&] {
        while (i < end && (t[i] == ' ' || t[i] == '\t' || t[i] == '\n' || t[i] == '\r')) ++i;
    };
    auto skipString = [&] {  // at the opening quote
        for (++i; i < end && t[i] != '"'; ++i)
            if (t[i] == '\\') ++i;
        ++i;
    };
    auto skipValue = [&] {
        ws();
        if (i >= end) return;
        if (t[i] == '"') return skipString();
        if (t[i] == '{' || t[i] == '[') {
            for (int depth = 0; i < end;) {
                char c = t[i];
                if (c == '"') {
                    skipString();
                    continue;
                }
                if (c == '{' || c == '[') ++depth;
                if ((c == '}' || c == ']') && --depth == 0) {
                    ++i;
                    return;
                }
                ++i;
            }
            return;
        }
        while (i < end && t[i] != ',' && t[i] != '}' && t[i] != ']') ++i;
    };
    std::smatch m;
    for (std::string rest = path; !rest.empty(); rest = m.suffix().str()) {
        if (!std::regex_search(rest, m, stepRe)) return npos;
        ws();
        if (i >= end) return npos;
        if (m[1].matched) {
            if (t[i] != '{') return npos;
            for (++i;;) {
                ws();
                if (i >= end || t[i] == '}') return npos;
                if (t[i] == ',') {
                    ++i;
                    continue;
                }
                if (t[i] != '"') return npos;
                size_t k0 = i + 1;
                skipString();
                std::string key = t.substr(k0, std::min(i, end) - 1 - k0);
                ws();
                if (i >= end || t[i] != ':') return npos;
                ++i;
                if (key == m[1].str()) break;
                skipValue();
            }
        } else {
            if (t[i] != '[') return npos;
            size_t want = std::stoul(m[2].str());
            ++i;
            for (size_t k = 0;; ++k) {
                ws();
                if (i >= end || t[i] == ']') return npos;
                if (k == want) break;
                skipValue();
                ws();
                if (i < end && t[i] == ',') ++i;
            }
        }
    }
    ws();
    return i < end ? i : npos;
}

// Image loading: tinygltf's stb loader, but an image it cannot decode is a
// warning (the material keeps its factor), not a failed load.
struct ImageLoadLog {
    std::vector<std::string> failures;
    /// texture.max_mb: checked from each image's header before it is decoded
    /// (a few hundred bytes of PNG header may claim 65535 x 65535 texels).
    TextureBudget* budget = nullptr;
    std::string overBudget;  ///< the error, raised after tinygltf returns
};

bool lenientImageLoader(tinygltf::Image* image, const int index, std::string* err, std::string* warn, int reqW,
                        int reqH, const unsigned char* bytes, int size, void* user) {
    auto* log = static_cast<ImageLoadLog*>(user);
    int iw = 0, ih = 0, ic = 0;
    if (stbi_info_from_memory(bytes, size, &iw, &ih, &ic) && log->budget) {
        try {
            log->budget->reserve(iw, ih, SourceLocation{});
        } catch (const InputError& e) {
            // Not thrown through tinygltf: recorded, raised after it returns.
            if (log->overBudget.empty()) log->overBudget = fmt::format("image {}: {}", index, e.what());
            image->image.clear();
            image->width = image->height = 0;
            return true;
        }
    }
    std::string e, w;
    if (tinygltf::LoadImageData(image, index, &e, &w, reqW, reqH, bytes, size, nullptr)) return true;
    log->failures.push_back(fmt::format("image {}: {}", index, firstLine(e.empty() ? w : e)));
    image->image.clear();
    image->width = image->height = 0;
    (void)err;
    (void)warn;
    return true;
}

// ---- accessors ---------------------------------------------------------------------

/// A validated accessor: every element's bytes lie inside its buffer.
struct View {
    const unsigned char* data = nullptr;
    size_t count = 0;
    size_t stride = 0;
    int componentType = 0;
    int components = 0;
    bool normalized = false;

    double component(size_t i, int c) const {
        const unsigned char* p = data + i * stride;
        switch (componentType) {
            case TINYGLTF_COMPONENT_TYPE_FLOAT: return read<float>(p, c, 0.0);
            case TINYGLTF_COMPONENT_TYPE_BYTE: return read<int8_t>(p, c, 127.0);
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return read<uint8_t>(p, c, 255.0);
            case TINYGLTF_COMPONENT_TYPE_SHORT: return read<int16_t>(p, c, 32767.0);
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return read<uint16_t>(p, c, 65535.0);
            default: return read<uint32_t>(p, c, 4294967295.0);
        }
    }

  private:
    template <typename T>
    double read(const unsigned char* p, int c, double normMax) const {
        T v;
        std::memcpy(&v, p + size_t(c) * sizeof(T), sizeof(T));
        v = fromLE(v);
        // Normalised integers (§3.11): signed ones map to max(c / (2^(n-1) - 1), -1).
        if (normalized && normMax > 0) return std::max(double(v) / normMax, -1.0);
        return double(v);
    }
};

int componentSize(int type) {
    switch (type) {
        case TINYGLTF_COMPONENT_TYPE_BYTE: case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
        case TINYGLTF_COMPONENT_TYPE_SHORT: case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
        default: return 0;  // INT and DOUBLE are not valid glTF 2.0 accessor types
    }
}

/// The number of elements of the JSON array starting at t[at] (-1 when the
/// value there is not an array). tinygltf replaces a number array of the
/// wrong length by its default, so the loader counts it in the text.
long jsonArrayLength(const std::string& t, size_t at) {
    if (at >= t.size() || t[at] != '[') return -1;
    long commas = 0;
    bool any = false, inString = false;
    int depth = 0;
    for (size_t i = at; i < t.size(); ++i) {
        const char c = t[i];
        if (inString) {
            if (c == '\\') ++i;
            else if (c == '"') inString = false;
            continue;
        }
        if (c == '"') inString = true;
        if (c == '[' || c == '{') ++depth;
        else if (c == ']' || c == '}') {
            if (--depth == 0) return any ? commas + 1 : 0;
        } else if (c == ',' && depth == 1) ++commas;
        if (depth >= 1 && !(c == ' ' || c == '\n' || c == '\t' || c == '\r' || (c == '[' && i == at))) any = true;
    }
    return -1;
}

class Loader {
  public:
    Loader(const std::string& path, const GltfOptions& options) : path_(path), opt_(options) {
        budget_.maxBytes = options.textureBudget;
    }

    Scene load();

  private:
    std::string path_;
    GltfOptions opt_;
    tinygltf::Model model_;
    Scene scene_;
    std::map<int, uint32_t> materialOf_;  // glTF material index -> hrad material
    std::map<int, RGB> imageMean_;        // image index -> mean of its linear texels
    std::map<int, int32_t> textureOf_;    // glTF texture index -> Scene::textures index
    std::map<uint32_t, int> texCoordOf_;  // hrad material -> its TEXCOORD_n set
    TextureBudget budget_;
    uint32_t defaultMaterial_ = UINT32_MAX;
    uint64_t skippedPrimitives_ = 0, noPositionPrimitives_ = 0, remainderIndices_ = 0;
    bool vertexColoursSeen_ = false;
    size_t faces_ = 0;
    std::string json_;       // the JSON text (a .gltf, or a .glb's JSON chunk), to locate errors
    size_t jsonOffset_ = 0;  // where json_ starts in the file
    bool binary_ = false;

    /// Throws InputError. A message that starts with a JSON path (e.g.
    /// "nodes[3].children: ...") is located: its line in a .gltf, its byte
    /// offset in a .glb.
    [[noreturn]] void fail(const std::string& msg) const {
        static const std::regex pathRe(R"(^[A-Za-z_]+(\[[0-9]+\]|\.[A-Za-z_0-9]+)*)");
        std::smatch m;
        size_t at = std::string::npos;
        if (std::regex_search(msg, m, pathRe)) at = locateJsonPath(json_, m[0].str());
        if (at == std::string::npos) throw InputError(SourceLocation{path_, 0, 0}, msg);
        if (binary_)
            throw InputError(SourceLocation{path_, 0, 0}, fmt::format("{} (at byte offset {})", msg, jsonOffset_ + at));
        int line = 1 + int(std::count(json_.begin(), json_.begin() + std::ptrdiff_t(at), '\n'));
        throw InputError(SourceLocation{path_, line, 0}, msg);
    }
    void warn(const std::string& msg) { scene_.stats.warnings.push_back(fmt::format("{}: {}", path_, msg)); }

    void parse();
    View accessor(int index, const std::string& what, std::initializer_list<int> types,
                  std::initializer_list<int> componentTypes) const;
    Mat4 localMatrix(int node) const;
    void addMesh(int meshIndex, const Mat4& world, int node);
    void addLight(int node, const Mat4& world);
    /// The line (.gltf) of a JSON path, for errors raised elsewhere.
    SourceLocation locate(const std::string& jsonPath) const {
        const size_t at = locateJsonPath(json_, jsonPath);
        if (at == std::string::npos || binary_) return SourceLocation{path_, 0, 0};
        return SourceLocation{path_, 1 + int(std::count(json_.begin(), json_.begin() + std::ptrdiff_t(at), '\n')), 0};
    }
    uint64_t meshTriangles(int meshIndex) const;
    void checkFaceBudget(const std::vector<int>& roots) const;
    uint32_t material(int index, const std::string& where);
    RGB textureMean(int textureIndex, int materialIndex, const std::string& materialName, const char* slot);
    int32_t baseColorTexture(int textureIndex, int source);
    bool readUVs(const tinygltf::Primitive& prim, int set, const std::string& where, std::vector<Vec2>& uv);
    void camera(const std::vector<std::pair<int, Mat4>>& placed);
};

void Loader::parse() {
    std::vector<unsigned char> bytes = readWholeFile(path_);
    std::string ext = std::filesystem::path(path_).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    // The container decides, not the extension: a .gltf that starts with the
    // GLB magic is read as GLB, and the reverse.
    bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    if (ext == ".glb" && !binary) checkGlb(path_, bytes);  // reports the missing magic
    std::string baseDir = std::filesystem::path(path_).parent_path().string();
    tinygltf::TinyGLTF gltf;
    gltf.SetFsCallbacks(tinygltf::FsCallbacks{&tinygltf::FileExists, &tinygltf::ExpandFilePath, &readUriFile,
                                              &tinygltf::WriteWholeFile, nullptr});
    ImageLoadLog images;
    images.budget = &budget_;
    gltf.SetImageLoader(&lenientImageLoader, &images);
    std::string err, warnText;
    bool ok;
    size_t jsonBegin = 0, jsonEnd = bytes.size();
    if (binary) {
        jsonBegin = checkGlb(path_, bytes);
        jsonEnd = jsonBegin + le32(&bytes[jsonBegin - 8]);
        if (bytes.size() > size_t(std::numeric_limits<unsigned int>::max()))
            fail("GLB files of 4 GiB or more are not supported");
        checkJsonDepth(path_, bytes, jsonBegin, std::min(jsonEnd, bytes.size()), true);
        ok = gltf.LoadBinaryFromMemory(&model_, &err, &warnText, bytes.data(), unsigned(bytes.size()), baseDir);
    } else {
        if (bytes.size() > size_t(std::numeric_limits<unsigned int>::max()))
            fail(".gltf files of 4 GiB or more are not supported");
        checkJsonDepth(path_, bytes, 0, bytes.size(), false);
        ok = gltf.LoadASCIIFromString(&model_, &err, &warnText, reinterpret_cast<const char*>(bytes.data()),
                                      unsigned(bytes.size()), baseDir);
    }
    if (!images.overBudget.empty()) throwInputError(SourceLocation{path_, 0, 0}, "{}", images.overBudget);
    if (!ok) {
        std::string msg = firstLine(err.empty() ? warnText : err);
        if (msg.empty()) msg = "tinygltf could not read the file";
        int line = jsonErrorLine(msg);
        // Errors about an external file name its URI: point at the line in the JSON.
        if (line == 0) {
            static const std::regex uriRe("(File not found : |File read error : )([^;:]+)");
            std::smatch m;
            if (std::regex_search(msg, m, uriRe)) {
                std::string name = m[2].str();
                while (!name.empty() && name.back() == ' ') name.pop_back();
                line = lineOfString(bytes, jsonBegin, jsonEnd, name);
                // tinygltf reports the path joined to the base folder; the JSON has the URI.
                if (line == 0) line = lineOfString(bytes, jsonBegin, jsonEnd, std::filesystem::path(name).filename().string());
            }
        }
        if (binary)
            throwInputError(SourceLocation{path_, 0, 0}, "{} (in the GLB JSON chunk at byte offset {}{})", msg,
                            jsonBegin, line > 0 ? fmt::format(", its line {}", line) : std::string());
        throwInputError(SourceLocation{path_, line, 0}, "{}", msg);
    }
    std::istringstream ws(warnText);
    for (std::string w; std::getline(ws, w);)
        if (!firstLine(w).empty()) warn(firstLine(w));
    json_.assign(bytes.begin() + std::ptrdiff_t(jsonBegin), bytes.begin() + std::ptrdiff_t(jsonEnd));
    jsonOffset_ = jsonBegin;
    binary_ = binary;
    for (const std::string& f : images.failures)
        warn(fmt::format("{}: could not be decoded (texture means that use it are not applied)", f));
}

View Loader::accessor(int index, const std::string& what, std::initializer_list<int> types,
                      std::initializer_list<int> componentTypes) const {
    const auto& m = model_;
    if (index < 0 || size_t(index) >= m.accessors.size())
        fail(fmt::format("{}: accessor {} does not exist (the file has {} accessors)", what, index,
                         m.accessors.size()));
    const tinygltf::Accessor& a = m.accessors[size_t(index)];
    // Problems of the accessor itself are located at it; the referencing path
    // stays in the message.
    std::string name = fmt::format("accessors[{}] (used as {})", index, what);
    if (a.sparse.isSparse) fail(name + ": sparse accessors are not supported");
    if (std::find(types.begin(), types.end(), a.type) == types.end())
        fail(fmt::format("{}: unexpected accessor type {}", name, a.type));
    if (std::find(componentTypes.begin(), componentTypes.end(), a.componentType) == componentTypes.end())
        fail(fmt::format("{}: unexpected component type {}", name, a.componentType));
    View v;
    v.count = a.count;
    v.componentType = a.componentType;
    v.components = tinygltf::GetNumComponentsInType(uint32_t(a.type));
    v.normalized = a.normalized;
    int csize = componentSize(a.componentType);
    if (v.components <= 0 || csize <= 0) fail(name + ": invalid type or component type");
    size_t elemSize = size_t(csize) * size_t(v.components);
    if (a.count == 0) return v;
    if (a.bufferView < 0)
        fail(name + ": accessor without bufferView (implicit zeros) is not supported for geometry");
    if (size_t(a.bufferView) >= m.bufferViews.size())
        fail(fmt::format("{}: bufferView {} does not exist (the file has {})", name, a.bufferView,
                         m.bufferViews.size()));
    const tinygltf::BufferView& bv = m.bufferViews[size_t(a.bufferView)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= m.buffers.size())
        fail(fmt::format("{}: bufferView {} names buffer {} which does not exist", name, a.bufferView, bv.buffer));
    const std::vector<unsigned char>& data = m.buffers[size_t(bv.buffer)].data;
    if (bv.byteOffset > data.size() || bv.byteLength > data.size() - bv.byteOffset)
        fail(fmt::format("{}: bufferView {} (bytes {}..+{}) lies outside buffer {} ({} bytes)", name,
                         a.bufferView, bv.byteOffset, bv.byteLength, bv.buffer, data.size()));
    size_t stride = bv.byteStride ? bv.byteStride : elemSize;
    if (stride < elemSize)
        fail(fmt::format("{}: byteStride {} is smaller than one element ({} bytes)", name, stride, elemSize));
    // last byte = byteOffset + stride * (count - 1) + elemSize <= byteLength, without overflow
    if (a.byteOffset > bv.byteLength || elemSize > bv.byteLength - a.byteOffset ||
        (a.count - 1) > (bv.byteLength - a.byteOffset - elemSize) / stride)
        fail(fmt::format("{}: {} elements of {} bytes (stride {}) from byte {} do not fit in bufferView {} "
                         "({} bytes)",
                         name, a.count, elemSize, stride, a.byteOffset, a.bufferView, bv.byteLength));
    v.data = data.data() + bv.byteOffset + a.byteOffset;
    v.stride = stride;
    return v;
}

Mat4 Loader::localMatrix(int index) const {
    const tinygltf::Node& n = model_.nodes[size_t(index)];
    auto bad = [&](const char* what, size_t size, size_t expected) {
        if (size != 0 && size != expected)
            fail(fmt::format("nodes[{}].{}: {} numbers (expected {})", index, what, size, expected));
    };
    bad("matrix", n.matrix.size(), 16);
    bad("translation", n.translation.size(), 3);
    bad("rotation", n.rotation.size(), 4);
    bad("scale", n.scale.size(), 3);
    for (const auto* vec : {&n.matrix, &n.translation, &n.rotation, &n.scale})
        for (double x : *vec)
            if (!std::isfinite(x)) fail(fmt::format("nodes[{}]: non-finite transform value", index));
    if (n.matrix.size() == 16) return glm::make_mat4(n.matrix.data());  // column-major, as glTF (§3.5.2)
    Mat4 t(1.0), r(1.0), s(1.0);
    if (!n.translation.empty()) t = glm::translate(Mat4(1.0), Vec3(n.translation[0], n.translation[1], n.translation[2]));
    if (!n.rotation.empty()) {
        // glTF quaternions are (x, y, z, w); glm's constructor takes (w, x, y, z).
        glm::dquat q(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);
        double len = glm::length(q);
        if (!(len > 1e-12)) fail(fmt::format("nodes[{}].rotation: zero quaternion", index));
        r = glm::mat4_cast(q / len);
    }
    if (!n.scale.empty()) s = glm::scale(Mat4(1.0), Vec3(n.scale[0], n.scale[1], n.scale[2]));
    return t * r * s;
}

RGB Loader::textureMean(int textureIndex, int materialIndex, const std::string& materialName, const char* slot) {
    if (textureIndex < 0) return RGB(1.0);
    if (size_t(textureIndex) >= model_.textures.size())
        fail(fmt::format("materials[{}]{}{}.index (material '{}'): texture {} does not exist (the file has {})",
                         materialIndex, std::strcmp(slot, "baseColorTexture") == 0 ? ".pbrMetallicRoughness." : ".",
                         slot, materialName, textureIndex, model_.textures.size()));
    int source = model_.textures[size_t(textureIndex)].source;
    if (source < 0 || size_t(source) >= model_.images.size()) {
        warn(fmt::format("material '{}': {} (texture {}) has no image; its mean is not applied", materialName, slot,
                         textureIndex));
        return RGB(1.0);
    }
    const tinygltf::Image& img = model_.images[size_t(source)];
    int bytesPer = img.bits == 16 ? 2 : img.bits == 8 ? 1 : 0;
    size_t texels = size_t(std::max(img.width, 0)) * size_t(std::max(img.height, 0));
    if (img.image.empty() || bytesPer == 0 || img.component < 1 || img.component > 4 || texels == 0 ||
        img.image.size() != texels * size_t(img.component) * size_t(bytesPer)) {
        warn(fmt::format("material '{}': {} image {} ('{}') could not be loaded; its mean is not applied",
                         materialName, slot, source, img.uri.empty() ? img.name : img.uri));
        return RGB(1.0);
    }
    const bool base = std::strcmp(slot, "baseColorTexture") == 0;
    auto cached = imageMean_.find(source);
    if (cached != imageMean_.end()) {
        if (!base)
            warn(fmt::format("material '{}': {} replaced by its mean ({:.4g}, {:.4g}, {:.4g}) (emission has "
                             "one value per material)",
                             materialName, slot, cached->second.r, cached->second.g, cached->second.b));
        return cached->second;
    }
    // Colour textures are sRGB-encoded (§3.9.2); the mean is taken in linear RGB.
    auto toLinear = [](double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); };
    double lut[256];
    for (int i = 0; i < 256; ++i) lut[i] = toLinear(i / 255.0);
    RGB sum(0.0);
    const unsigned char* p = img.image.data();
    for (size_t t = 0; t < texels; ++t) {
        double c[4];
        for (int k = 0; k < img.component; ++k) {
            if (bytesPer == 1) {
                c[k] = lut[p[k]];
            } else {
                uint16_t v;
                std::memcpy(&v, p + 2 * k, 2);
                c[k] = toLinear(v / 65535.0);
            }
        }
        // 1 or 2 components: grey (+ alpha); 3 or 4: RGB (+ alpha).
        sum += img.component < 3 ? RGB(c[0]) : RGB(c[0], c[1], c[2]);
        p += size_t(img.component) * size_t(bytesPer);
    }
    RGB mean = sum / double(texels);
    imageMean_[source] = mean;
    if (!base)
        warn(fmt::format("material '{}': {} replaced by its mean ({:.4g}, {:.4g}, {:.4g}) (emission has one "
                         "value per material)",
                         materialName, slot, mean.r, mean.g, mean.b));
    return mean;
}

/// The scene texture of glTF texture `textureIndex` (image `source`, already
/// checked by textureMean): sRGB-decoded (§3.9.2), wrap modes of its sampler
/// (§3.8.4, REPEAT when it has none). Filters are bilinear whatever the
/// sampler says; KHR_texture_transform is not applied.
int32_t Loader::baseColorTexture(int textureIndex, int source) {
    auto it = textureOf_.find(textureIndex);
    if (it != textureOf_.end()) return it->second;
    const tinygltf::Texture& gt = model_.textures[size_t(textureIndex)];
    const tinygltf::Image& img = model_.images[size_t(source)];
    Texture t = textureFromPixels(fmt::format("{}#images[{}]", path_, source), img.width, img.height,
                                  img.component, img.bits, img.image.data(), TextureEncoding::Srgb);
    auto wrap = [](int mode) {
        return mode == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE     ? TextureWrap::Clamp
               : mode == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT ? TextureWrap::Mirror
                                                               : TextureWrap::Repeat;
    };
    if (gt.sampler >= 0 && size_t(gt.sampler) < model_.samplers.size()) {
        t.wrapU = wrap(model_.samplers[size_t(gt.sampler)].wrapS);
        t.wrapV = wrap(model_.samplers[size_t(gt.sampler)].wrapT);
    }
    const int32_t id = addTexture(scene_, std::move(t));
    textureOf_[textureIndex] = id;
    return id;
}

/// TEXCOORD_<set> of a primitive as hrad UVs (v up: 1 - t, §3.7.2.1 puts the
/// image's origin at the top left). False when the primitive has none.
bool Loader::readUVs(const tinygltf::Primitive& prim, int set, const std::string& where, std::vector<Vec2>& uv) {
    const std::string name = fmt::format("TEXCOORD_{}", set);
    auto it = prim.attributes.find(name);
    if (it == prim.attributes.end()) return false;
    View tv = accessor(it->second, where + ".attributes." + name, {TINYGLTF_TYPE_VEC2},
                       {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                        TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
    uv.resize(tv.count);
    for (size_t i = 0; i < tv.count; ++i) {
        uv[i] = Vec2(tv.component(i, 0), 1.0 - tv.component(i, 1));
        if (!std::isfinite(uv[i].x) || !std::isfinite(uv[i].y))
            fail(fmt::format("{}.attributes.{}: texture coordinate {} is not finite", where, name, i));
    }
    return true;
}

uint32_t Loader::material(int index, const std::string& where) {
    if (index < 0) {
        if (defaultMaterial_ == UINT32_MAX)
            defaultMaterial_ = scene_.addMaterial({"default", RGB(opt_.defaultRho), RGB(0.0), false, false});
        return defaultMaterial_;
    }
    if (size_t(index) >= model_.materials.size())
        fail(fmt::format("{}: material {} does not exist (the file has {})", where, index,
                         model_.materials.size()));
    auto it = materialOf_.find(index);
    if (it != materialOf_.end()) return it->second;
    const tinygltf::Material& gm = model_.materials[size_t(index)];
    Material m;
    m.name = gm.name.empty() ? fmt::format("material_{}", index) : gm.name;
    // Errors of this material start with its JSON path, so fail() locates them.
    auto mfail = [&](const std::string& what, const std::string& msg) {
        fail(fmt::format("materials[{}]{} (material '{}'): {}", index, what, m.name, msg));
    };
    // A factor of the wrong length or type: an error, not tinygltf's default.
    for (auto [what, want] : {std::pair<const char*, long>{".pbrMetallicRoughness.baseColorFactor", 4},
                              std::pair<const char*, long>{".emissiveFactor", 3}}) {
        const size_t at = locateJsonPath(json_, fmt::format("materials[{}]{}", index, what));
        if (at == std::string::npos) continue;
        const long n = jsonArrayLength(json_, at);
        if (n != want) mfail(what, n < 0 ? fmt::format("is not an array (expected {} numbers)", want)
                                         : fmt::format("{} numbers (expected {})", n, want));
    }
    const auto& bc = gm.pbrMetallicRoughness.baseColorFactor;
    if (bc.size() != 4) mfail(".pbrMetallicRoughness.baseColorFactor", fmt::format("{} numbers (expected 4)", bc.size()));
    const auto& ef = gm.emissiveFactor;
    if (ef.size() != 3) mfail(".emissiveFactor", fmt::format("{} numbers (expected 3)", ef.size()));
    double strength = 1.0;
    auto ext = gm.extensions.find("KHR_materials_emissive_strength");
    if (ext != gm.extensions.end() && ext->second.Has("emissiveStrength")) {
        const tinygltf::Value& s = ext->second.Get("emissiveStrength");
        if (!s.IsNumber()) mfail(".extensions.KHR_materials_emissive_strength", "emissiveStrength is not a number");
        strength = s.GetNumberAsDouble();
    }
    if (!(std::isfinite(strength) && strength >= 0))
        mfail(".extensions.KHR_materials_emissive_strength", "emissiveStrength must be finite and >= 0");
    RGB base(bc[0], bc[1], bc[2]);
    RGB emissive(ef[0], ef[1], ef[2]);
    for (int c = 0; c < 3; ++c) {
        if (!(std::isfinite(base[c]) && base[c] >= 0))
            mfail(".pbrMetallicRoughness.baseColorFactor", "must be finite and >= 0");
        if (!(std::isfinite(emissive[c]) && emissive[c] >= 0))
            mfail(".emissiveFactor", "must be finite and >= 0");
    }
    const tinygltf::TextureInfo& bct = gm.pbrMetallicRoughness.baseColorTexture;
    const RGB baseMean = textureMean(bct.index, index, m.name, "baseColorTexture");
    m.rho = base * baseMean;
    if (bct.index >= 0 && imageMean_.count(model_.textures[size_t(bct.index)].source)) {
        // rho(x) = baseColorFactor * texel (§3.9.2); m.rho, the mean over all
        // texels, stays the reflectance of primitives without TEXCOORD_n.
        m.diffuseMap.texture = baseColorTexture(bct.index, model_.textures[size_t(bct.index)].source);
        m.diffuseMap.scale = base;
        m.diffuseMap.clampRho = opt_.clampRho;
        m.diffuseMap.clampKey = "scene.clamp_rho";
    }
    bool emits = emissive.r > 0 || emissive.g > 0 || emissive.b > 0;
    RGB emissiveTex = emits && strength > 0 ? textureMean(gm.emissiveTexture.index, index, m.name, "emissiveTexture") : RGB(1.0);
    // E = pi L: radiance of a Lambertian emitter -> radiosity (see the header).
    m.emission = std::numbers::pi * emissive * strength * emissiveTex * opt_.emissionScale;
    for (int c = 0; c < 3; ++c)
        if (!std::isfinite(m.emission[c])) mfail("", "emission overflows");
    const RGB given = m.rho;
    switch (clampReflectance(m.rho, opt_.clampRho)) {  // scene.h: one rule for every format
        case RhoCheck::Clamped:
            warn(fmt::format("material '{}': {}", m.name, clampedNote(opt_.clampRho)));
            break;
        case RhoCheck::TooLarge: {  // braced: the message's lifetime ends in this case
            mfail(".pbrMetallicRoughness",
                  fmt::format("reflectance ({:.6g}, {:.6g}, {:.6g}) must be < 1 per channel ({})",
                              given.r, given.g, given.b, kClampRhoHint));
            break;
        }
        case RhoCheck::Fine: break;
    }
    m.twoSided = gm.doubleSided;
    m.emitsBothSides = gm.doubleSided;
    uint32_t id = scene_.addMaterial(m);
    materialOf_[index] = id;
    if (m.diffuseMap.texture >= 0) texCoordOf_[id] = bct.texCoord;
    return id;
}

void Loader::addMesh(int meshIndex, const Mat4& world, int node) {
    if (meshIndex < 0 || size_t(meshIndex) >= model_.meshes.size())
        fail(fmt::format("nodes[{}].mesh: mesh {} does not exist (the file has {})", node, meshIndex,
                         model_.meshes.size()));
    const tinygltf::Mesh& mesh = model_.meshes[size_t(meshIndex)];
    // A mirroring transform reverses the winding (§3.7.2.1).
    bool flip = glm::determinant(glm::dmat3(world)) < 0;
    std::vector<Vec3> tri(3);
    std::vector<Vec2> triUV(3), uvs;
    std::vector<Vec3> pos;
    std::vector<uint32_t> idx;
    for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
        const tinygltf::Primitive& prim = mesh.primitives[pi];
        std::string where = fmt::format("meshes[{}].primitives[{}]", meshIndex, pi);
        int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
        if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
            mode != TINYGLTF_MODE_TRIANGLE_FAN) {
            if (mode < 0 || mode > 6) fail(fmt::format("{}.mode: {} is not a glTF primitive mode", where, mode));
            ++skippedPrimitives_;
            continue;
        }
        auto posIt = prim.attributes.find("POSITION");
        if (posIt == prim.attributes.end()) {
            ++noPositionPrimitives_;
            continue;
        }
        if (prim.attributes.count("COLOR_0")) vertexColoursSeen_ = true;
        View pv = accessor(posIt->second, where + ".attributes.POSITION", {TINYGLTF_TYPE_VEC3},
                           {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                            TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                            TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
        pos.resize(pv.count);
        for (size_t i = 0; i < pv.count; ++i) {
            glm::dvec4 p(pv.component(i, 0), pv.component(i, 1), pv.component(i, 2), 1.0);
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                fail(fmt::format("{}.attributes.POSITION: vertex {} is not finite", where, i));
            pos[i] = Vec3(world * p);
            if (!std::isfinite(pos[i].x) || !std::isfinite(pos[i].y) || !std::isfinite(pos[i].z))
                fail(fmt::format("{}.attributes.POSITION: vertex {} is not finite after node {}'s transform", where,
                                 i, node));
        }
        idx.clear();
        if (prim.indices >= 0) {
            View iv = accessor(prim.indices, where + ".indices", {TINYGLTF_TYPE_SCALAR},
                               {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
            iv.normalized = false;
            idx.resize(iv.count);
            for (size_t i = 0; i < iv.count; ++i) {
                double v = iv.component(i, 0);
                if (!(v < double(pos.size())))
                    fail(fmt::format("{}.indices (accessor {}): index {} at position {} is out of range (POSITION "
                                     "has {} vertices)",
                                     where, prim.indices, v, i, pos.size()));
                idx[i] = uint32_t(v);
            }
        } else {
            idx.resize(pos.size());
            for (size_t i = 0; i < idx.size(); ++i) idx[i] = uint32_t(i);
        }
        uint32_t mat = material(prim.material, where + ".material");
        auto set = texCoordOf_.find(mat);
        const bool textured = set != texCoordOf_.end() && readUVs(prim, set->second, where, uvs);
        if (textured && uvs.size() != pos.size())
            fail(fmt::format("{}.attributes.TEXCOORD_{}: {} coordinates for {} vertices", where, set->second,
                             uvs.size(), pos.size()));
        size_t n = idx.size();
        size_t triangles = mode == TINYGLTF_MODE_TRIANGLES ? n / 3 : n >= 3 ? n - 2 : 0;
        if (mode == TINYGLTF_MODE_TRIANGLES) remainderIndices_ += n % 3;
        faces_ += triangles;
        if (faces_ > opt_.maxFaces)
            fail(fmt::format("the scene yields more than gltf.max_faces = {} triangles (meshes instanced by many "
                             "nodes?); raise the setting if this is intended",
                             opt_.maxFaces));
        if (prim.material < 0) scene_.stats.defaultMaterialFaces += triangles;
        for (size_t t = 0; t < triangles; ++t) {
            uint32_t a, b, c;
            if (mode == TINYGLTF_MODE_TRIANGLES) {
                a = idx[3 * t], b = idx[3 * t + 1], c = idx[3 * t + 2];
            } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
                // §3.7.2.1: p_i = {v_i, v_(i+1+i%2), v_(i+2-i%2)}
                a = idx[t], b = idx[t + 1 + t % 2], c = idx[t + 2 - t % 2];
            } else {
                // §3.7.2.1: p_i = {v_(i+1), v_(i+2), v_0}
                a = idx[t + 1], b = idx[t + 2], c = idx[0];
            }
            if (flip) std::swap(b, c);
            tri[0] = pos[a], tri[1] = pos[b], tri[2] = pos[c];
            if (textured) triUV[0] = uvs[a], triUV[1] = uvs[b], triUV[2] = uvs[c];
            addPolygon(scene_, tri, mat, textured ? &triUV : nullptr);
        }
    }
}

/// The triangles a mesh makes, from its accessors' counts: each accessor is
/// checked as addMesh checks it (so a count beyond its buffer is reported as
/// such), but no element is read.
uint64_t Loader::meshTriangles(int meshIndex) const {
    uint64_t total = 0;
    const tinygltf::Mesh& mesh = model_.meshes[size_t(meshIndex)];
    for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
        const tinygltf::Primitive& prim = mesh.primitives[pi];
        const std::string where = fmt::format("meshes[{}].primitives[{}]", meshIndex, pi);
        int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
        auto pos = prim.attributes.find("POSITION");
        if (pos == prim.attributes.end()) continue;
        if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
            mode != TINYGLTF_MODE_TRIANGLE_FAN)
            continue;
        uint64_t n = prim.indices >= 0
                         ? accessor(prim.indices, where + ".indices", {TINYGLTF_TYPE_SCALAR},
                                    {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                     TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT})
                               .count
                         : accessor(pos->second, where + ".attributes.POSITION", {TINYGLTF_TYPE_VEC3},
                                    {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                                     TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                                     TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT})
                               .count;
        // Counts fit their buffers (checked above), so the sum cannot overflow.
        total += mode == TINYGLTF_MODE_TRIANGLES ? n / 3 : (n >= 3 ? n - 2 : 0);
    }
    return total;
}

/// gltf.max_faces over the whole node forest, before any triangle is made:
/// 10^4 nodes each instancing one 10^4-triangle mesh (a 61 KB file) built
/// 2 * 10^7 triangles before addMesh's running count stopped it (issue 64).
void Loader::checkFaceBudget(const std::vector<int>& roots) const {
    std::vector<uint64_t> perMesh(model_.meshes.size(), UINT64_MAX);
    uint64_t total = 0, instances = 0;
    std::vector<int> stack(roots.rbegin(), roots.rend());
    while (!stack.empty()) {
        const tinygltf::Node& node = model_.nodes[size_t(stack.back())];
        stack.pop_back();
        if (node.mesh >= 0 && size_t(node.mesh) < perMesh.size()) {
            uint64_t& t = perMesh[size_t(node.mesh)];
            if (t == UINT64_MAX) t = meshTriangles(node.mesh);
            total += t;
            ++instances;
            if (total > opt_.maxFaces)
                fail(fmt::format("the scene yields more than gltf.max_faces = {} triangles ({} mesh instances "
                                 "counted so far make {}); raise the setting if this is intended",
                                 opt_.maxFaces, instances, total));
        }
        for (auto c = node.children.rbegin(); c != node.children.rend(); ++c) stack.push_back(*c);
    }
}

void Loader::camera(const std::vector<std::pair<int, Mat4>>& placed) {
    if (model_.cameras.empty()) return;
    if (placed.empty()) {
        warn(fmt::format("{} camera(s) defined but no node of the scene places one; using the automatic view",
                         model_.cameras.size()));
        return;
    }
    const std::pair<int, Mat4>* chosen = &placed.front();
    for (const auto& p : placed)
        if (p.first == 0) {
            chosen = &p;
            break;
        }
    int index = chosen->first;  // checked during the traversal
    const tinygltf::Camera& gc = model_.cameras[size_t(index)];
    if (model_.cameras.size() > 1)
        warn(fmt::format("{} cameras; using camera {} ('{}')", model_.cameras.size(), index, gc.name));
    if (gc.type != "perspective") {
        warn(fmt::format("camera {} is '{}'; only perspective cameras are used (automatic view instead)", index,
                         gc.type));
        return;
    }
    double yfov = gc.perspective.yfov;
    if (!(yfov > 0 && yfov < std::numbers::pi))
        fail(fmt::format("cameras[{}].perspective.yfov = {} must be in (0, pi) radians", index, yfov));
    const Mat4& m = chosen->second;
    // glTF cameras look down their local -Z with +Y up (§3.10.1).
    Vec3 eye(m * glm::dvec4(0, 0, 0, 1));
    Vec3 forward(m * glm::dvec4(0, 0, -1, 0));
    Vec3 up(m * glm::dvec4(0, 1, 0, 0));
    if (!(glm::length(forward) > 1e-12) || !(glm::length(up) > 1e-12) ||
        !(glm::length(glm::cross(forward, up)) > 1e-12 * glm::length(forward) * glm::length(up)))
        fail(fmt::format("camera {}: its node transform is degenerate (no view direction)", index));
    if (!std::isfinite(eye.x + eye.y + eye.z + forward.x + forward.y + forward.z + up.x + up.y + up.z))
        fail(fmt::format("camera {}: its node transform is not finite", index));
    Camera cam;
    cam.eye = eye;
    cam.target = eye + glm::normalize(forward);
    cam.up = glm::normalize(up);
    cam.fovYDegrees = yfov * 180.0 / std::numbers::pi;
    scene_.camera = cam;
}

/// KHR_lights_punctual on a node (scene/lights/): the light at the node's
/// origin, shining along its -Z; color times intensity, taken as W/sr
/// (point, spot) and W/m^2 (directional) with no photometric conversion
/// (the extension's candela and lux over 683 lm/W would only scale every
/// light alike). A spot's cone: cutoff = outerConeAngle, beam =
/// innerConeAngle, with Mitsuba's linear falloff in angle between them
/// (the extension suggests a smooth one in cosine). `range` is ignored
/// (physical inverse-square falloff, as the extension recommends).
void Loader::addLight(int n, const Mat4& world) {
    const tinygltf::Node& node = model_.nodes[size_t(n)];
    auto ext = node.extensions.find("KHR_lights_punctual");
    if (ext == node.extensions.end()) return;
    const std::string at = fmt::format("nodes[{}].extensions.KHR_lights_punctual", n);
    if (!ext->second.Has("light") || !ext->second.Get("light").IsInt())
        fail(at + ": 'light' must be an integer index");
    const int li = ext->second.Get("light").Get<int>();
    if (li < 0 || size_t(li) >= model_.lights.size())
        fail(fmt::format("{}: light {} does not exist (the file has {})", at, li, model_.lights.size()));
    const tinygltf::Light& l = model_.lights[size_t(li)];
    const LightKind* kind = lightKindByGltf(l.type);
    const std::string where = fmt::format("extensions.KHR_lights_punctual.lights[{}]", li);
    if (!kind) {
        warn(fmt::format("{}: light type '{}' is not supported; ignored", where, l.type));
        scene_.stats.dropEmitter(l.type, fmt::format("{} light {}", path_, li));
        return;
    }
    LightSpec s;
    s.kind = kind->name;
    s.where = locate(where);
    RGB color(1.0);
    if (l.color.size() == 3) color = RGB(l.color[0], l.color[1], l.color[2]);
    else if (!l.color.empty()) fail(where + ".color: needs 3 components");
    s.value = color * l.intensity;
    s.position = Vec3(world * glm::dvec4(0, 0, 0, 1));
    s.direction = Vec3(world * glm::dvec4(0, 0, -1, 0));
    s.cutoffDegrees = l.spot.outerConeAngle * 180.0 / std::numbers::pi;
    s.beamDegrees = l.spot.innerConeAngle * 180.0 / std::numbers::pi;
    scene_.lights.push_back(makeLight(s));
}

Scene Loader::load() {
    parse();
    scene_.name = path_;
    scene_.source = "gltf";
    scene_.upAxis = 1;  // glTF is +Y up (§3.4)

    static const std::set<std::string> readable = {"KHR_materials_emissive_strength", "KHR_mesh_quantization",
                                                   "KHR_texture_transform", "KHR_materials_unlit"};
    for (const std::string& e : model_.extensionsRequired)
        if (!readable.count(e))
            fail(fmt::format("extensionsRequired: the file requires extension '{}', which hrad cannot read", e));

    const size_t numNodes = model_.nodes.size();
    std::vector<int> parent(numNodes, -1);
    for (size_t i = 0; i < numNodes; ++i)
        for (int c : model_.nodes[i].children) {
            if (c < 0 || size_t(c) >= numNodes)
                fail(fmt::format("nodes[{}].children: node {} does not exist (the file has {} nodes)", i, c, numNodes));
            if (parent[size_t(c)] >= 0)
                fail(fmt::format("nodes[{}].children: node {} is also a child of node {} (glTF nodes form trees)", i, c,
                                 parent[size_t(c)]));
            parent[size_t(c)] = int(i);
        }
    std::vector<int> roots;
    if (!model_.scenes.empty()) {
        int s = model_.defaultScene;
        if (s >= int(model_.scenes.size())) fail(fmt::format("scene: scene {} does not exist", s));
        if (s < 0) s = 0;
        roots = model_.scenes[size_t(s)].nodes;
        for (int r : roots) {
            if (r < 0 || size_t(r) >= numNodes)
                fail(fmt::format("scenes[{}].nodes: node {} does not exist (the file has {} nodes)", s, r, numNodes));
            if (parent[size_t(r)] >= 0)
                fail(fmt::format("scenes[{}].nodes: node {} is a root but also a child of node {}", s, r, parent[size_t(r)]));
        }
        if (std::set<int>(roots.begin(), roots.end()).size() != roots.size())
            fail(fmt::format("scenes[{}].nodes lists a node twice", s));
    } else {
        for (size_t i = 0; i < numNodes; ++i)
            if (parent[i] < 0) roots.push_back(int(i));
        if (!roots.empty()) warn("the file has no scene; every node without a parent is loaded");
    }

    // Depth-first over the node trees with an explicit stack. Every node has at
    // most one parent and roots have none, so each node is visited at most once
    // and a cycle (which could only involve non-root nodes) is never entered.
    checkFaceBudget(roots);
    std::vector<std::pair<int, Mat4>> stack, cameras;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.emplace_back(*it, Mat4(1.0));
    while (!stack.empty()) {
        auto [n, parentWorld] = stack.back();
        stack.pop_back();
        Mat4 world = parentWorld * localMatrix(n);
        const tinygltf::Node& node = model_.nodes[size_t(n)];
        if (node.mesh >= 0) addMesh(node.mesh, world, n);
        addLight(n, world);
        if (node.camera >= 0) {
            if (size_t(node.camera) >= model_.cameras.size())
                fail(fmt::format("nodes[{}].camera: camera {} does not exist (the file has {})", n, node.camera,
                                 model_.cameras.size()));
            cameras.emplace_back(node.camera, world);
        }
        for (auto c = node.children.rbegin(); c != node.children.rend(); ++c) stack.emplace_back(*c, world);
    }
    camera(cameras);

    if (skippedPrimitives_ > 0)
        warn(fmt::format("{} primitives are points or lines and were skipped (radiosity needs surfaces)",
                         skippedPrimitives_));
    if (noPositionPrimitives_ > 0)
        warn(fmt::format("{} primitives have no POSITION attribute and were skipped", noPositionPrimitives_));
    if (remainderIndices_ > 0)
        warn(fmt::format("{} trailing indices of TRIANGLES primitives do not make a whole triangle and were ignored",
                         remainderIndices_));
    if (vertexColoursSeen_)
        warn("COLOR_0 vertex colours are ignored (reflectance comes from the materials)");
    if (!model_.skins.empty() || !model_.animations.empty())
        warn("skins and animations are ignored; the rest pose is loaded");
    if (scene_.stats.defaultMaterialFaces > 0)
        warn(fmt::format("{} triangles have no material; they use grey 'default' (rho = gltf.default_rho = {})",
                         scene_.stats.defaultMaterialFaces, opt_.defaultRho));
    return std::move(scene_);
}

}  // namespace

Scene loadGltf(const std::string& path, const GltfOptions& options) {
    Loader loader(path, options);
    return loader.load();
}

}  // namespace hrad::scene
