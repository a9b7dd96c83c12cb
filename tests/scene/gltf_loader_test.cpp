// glTF 2.0 loader: small files written here by hand (JSON + a base64 data-URI
// buffer, or a GLB container) with known transforms, materials, emission,
// camera and doubleSided, and the bad-input cases of issue 12 item 7.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <numbers>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "scene/gltf_loader.h"
#include "scene/loader.h"
#include "scene/element.h"
#include "scene/texture.h"
#include "scene/element.h"
#include "scene/loader.h"
#include "tests/test_util.h"

using namespace hrad;
using namespace hrad::scene;
using nlohmann::json;

namespace {

std::string base64(const std::vector<unsigned char>& in) {
    static const char* tab = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    size_t i = 0;
    for (; i + 2 < in.size(); i += 3) {
        uint32_t v = uint32_t(in[i]) << 16 | uint32_t(in[i + 1]) << 8 | in[i + 2];
        for (int k = 3; k >= 0; --k) out += tab[(v >> (6 * k)) & 63];
    }
    if (i + 1 == in.size()) {
        uint32_t v = uint32_t(in[i]) << 16;
        out += tab[(v >> 18) & 63], out += tab[(v >> 12) & 63], out += "==";
    } else if (i + 2 == in.size()) {
        uint32_t v = uint32_t(in[i]) << 16 | uint32_t(in[i + 1]) << 8;
        out += tab[(v >> 18) & 63], out += tab[(v >> 12) & 63], out += tab[(v >> 6) & 63], out += '=';
    }
    return out;
}

// Little-endian appends (the test machines are little-endian x86/arm; glTF is LE).
template <typename T>
void put(std::vector<unsigned char>& b, T v) {
    unsigned char c[sizeof(T)];
    std::memcpy(c, &v, sizeof(T));
    b.insert(b.end(), c, c + sizeof(T));
}

/// One buffer with: a unit quad (4 float3 positions, bytes 0..47), its indices
/// (6 uint16, bytes 48..59), one triangle (3 float3, bytes 60..95).
std::vector<unsigned char> geometryBuffer() {
    std::vector<unsigned char> b;
    for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 1.f, 1.f, 0.f, 0.f, 1.f, 0.f}) put(b, v);
    for (uint16_t i : {0, 1, 2, 0, 2, 3}) put(b, i);
    for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(b, v);
    return b;
}

/// A 2x1 24-bit BMP: one white and one black pixel (sRGB mean in linear = 0.5).
std::vector<unsigned char> bmp2x1() {
    std::vector<unsigned char> b = {'B', 'M'};
    put(b, uint32_t(62));  // file size: 14 + 40 + 8 (two rows of 6 bytes padded to 8)
    put(b, uint32_t(0));
    put(b, uint32_t(54));  // pixel data offset
    put(b, uint32_t(40));
    put(b, int32_t(2));
    put(b, int32_t(1));
    put(b, uint16_t(1));
    put(b, uint16_t(24));
    for (int i = 0; i < 6; ++i) put(b, uint32_t(0));
    for (unsigned char c : {255, 255, 255, 0, 0, 0, 0, 0}) b.push_back(c);
    return b;
}

/// The test scene as glTF JSON; `bufferUri` is the buffer's URI (a data URI
/// unless a test points it elsewhere).
json sceneJson(const std::string& bufferUri) {
    const double s = std::sqrt(0.5);
    json j;
    j["asset"] = {{"version", "2.0"}};
    j["extensionsUsed"] = {"KHR_materials_emissive_strength"};
    j["buffers"] = json::array({{{"byteLength", 96}, {"uri", bufferUri}}});
    j["bufferViews"] = json::array({{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
                                    {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 12}},
                                    {{"buffer", 0}, {"byteOffset", 60}, {"byteLength", 36}}});
    j["accessors"] = json::array(
        {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"},
          {"min", {0, 0, 0}}, {"max", {1, 1, 0}}},
         {{"bufferView", 1}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}},
         {{"bufferView", 2}, {"componentType", 5126}, {"count", 3}, {"type", "VEC3"},
          {"min", {0, 0, 0}}, {"max", {1, 1, 0}}}});
    j["materials"] = json::array(
        {{{"name", "red"}, {"pbrMetallicRoughness", {{"baseColorFactor", {0.8, 0.2, 0.1, 1.0}}}}},
         {{"name", "lamp"},
          {"pbrMetallicRoughness", {{"baseColorFactor", {0.0, 0.0, 0.0, 1.0}}}},
          {"emissiveFactor", {1.0, 0.5, 0.25}},
          {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 4.0}}}}}},
         {{"name", "white"}, {"doubleSided", true}}});  // default baseColorFactor = 1
    j["meshes"] = json::array(
        {{{"primitives", json::array({{{"attributes", {{"POSITION", 0}}}, {"indices", 1}, {"material", 0}}})}},
         {{"primitives", json::array({{{"attributes", {{"POSITION", 0}}}, {"indices", 1}, {"material", 1}}})}},
         {{"primitives", json::array({{{"attributes", {{"POSITION", 2}}}, {"material", 2}, {"mode", 4}}})}}});
    // Column-major matrix of translate(0,3,0) * rotX(+90 deg) * scale(0.5):
    // columns are the images of x, y, z and the translation.
    json lightMatrix = {0.5, 0, 0, 0, 0, 0, 0.5, 0, 0, -0.5, 0, 0, 0, 0, 0, 1};
    j["nodes"] = json::array({
        // 0: floor, TRS: rotX(-90 deg) maps the quad's +Z normal to +Y; scale 2 -> area 4
        {{"name", "floor"}, {"mesh", 0}, {"rotation", {-s, 0, 0, s}}, {"scale", {2, 2, 2}}},
        // 1: group lifting its child by 3 in y
        {{"name", "group"}, {"translation", {0, 3, 0}}, {"children", {2}}},
        // 2: light, matrix; world = translate(0,3,0) * rotX(90) * scale(0.5): normal -Y, area 0.25
        {{"name", "light"}, {"mesh", 1}, {"matrix", lightMatrix}},
        // 3: wall, mirrored in x (negative determinant: the winding is reversed)
        {{"name", "wall"}, {"mesh", 2}, {"scale", {-1, 1, 1}}, {"translation", {0, 0, -2}}},
        // 4: camera at (0, 1, 5) looking down -Z
        {{"name", "cam"}, {"camera", 0}, {"translation", {0, 1, 5}}},
    });
    j["cameras"] = json::array({{{"type", "perspective"},
                                 {"perspective", {{"yfov", 0.6}, {"znear", 0.1}, {"aspectRatio", 1.5}}}}});
    j["scenes"] = json::array({{{"nodes", {0, 1, 3, 4}}}});
    j["scene"] = 0;
    return j;
}

std::string dataUri(const std::vector<unsigned char>& b) {
    return "data:application/octet-stream;base64," + base64(b);
}

/// A GLB container (glTF 2.0 §4.4) of `j` with `bin` as its BIN chunk.
std::string glb(const json& j, const std::vector<unsigned char>& bin) {
    std::string text = j.dump();
    while (text.size() % 4) text += ' ';
    std::vector<unsigned char> binPadded = bin;
    while (binPadded.size() % 4) binPadded.push_back(0);
    std::vector<unsigned char> out = {'g', 'l', 'T', 'F'};
    put(out, uint32_t(2));
    put(out, uint32_t(12 + 8 + text.size() + 8 + binPadded.size()));
    put(out, uint32_t(text.size()));
    put(out, uint32_t(0x4E4F534A));
    out.insert(out.end(), text.begin(), text.end());
    put(out, uint32_t(binPadded.size()));
    put(out, uint32_t(0x004E4942));
    out.insert(out.end(), binPadded.begin(), binPadded.end());
    return std::string(out.begin(), out.end());
}

const Material* findMaterial(const Scene& s, const std::string& name) {
    for (const Material& m : s.materials)
        if (m.name == name) return &m;
    return nullptr;
}

double areaOf(const Scene& s, const std::string& material) {
    double a = 0;
    for (const Patch& p : s.patches)
        if (s.materials[p.material].name == material) a += p.area;
    return a;
}

bool hasWarning(const Scene& s, const std::string& part) {
    for (const auto& w : s.stats.warnings)
        if (w.find(part) != std::string::npos) return true;
    return false;
}

/// Loads `text` written to dir/name and returns the InputError it throws.
InputError loadError(const std::filesystem::path& file) {
    try {
        loadGltf(file.string());
    } catch (const InputError& e) {
        return e;
    }
    ADD_FAILURE() << file << " loaded without an error";
    return InputError(SourceLocation{}, "none");
}

/// The scene's first material ("red") takes its base colour from a texture
/// of one image at `uri`.
void useBaseColorTexture(json& j, const std::string& uri) {
    j["images"] = json::array({{{"uri", uri}}});
    j["textures"] = json::array({{{"source", 0}}});
    j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
}

/// A scene whose "red" texture, at `uri` beside it in `dir`, cannot be
/// loaded: the texture is skipped with a warning and the factor kept.
void expectTextureSkipped(const std::filesystem::path& dir, const std::string& uri) {
    json j = sceneJson(dataUri(geometryBuffer()));
    useBaseColorTexture(j, uri);
    auto file = test::writeFile(dir / "scene.gltf", j.dump());
    Scene s = loadGltf(file.string());
    EXPECT_NEAR(findMaterial(s, "red")->rho.r, 0.8, 1e-12);
    EXPECT_TRUE(hasWarning(s, "could not be loaded"));
}

void checkTestScene(const Scene& s) {
    // floor 2 + light 2 + wall 1 triangles (addPolygon keeps triangles as triangles)
    EXPECT_EQ(s.patches.size(), 5u);
    EXPECT_EQ(s.upAxis, 1);
    EXPECT_NEAR(areaOf(s, "red"), 4.0, 1e-12);
    EXPECT_NEAR(areaOf(s, "lamp"), 0.25, 1e-12);
    EXPECT_NEAR(areaOf(s, "white"), 0.5, 1e-12);
    for (const Patch& p : s.patches) {
        const std::string& m = s.materials[p.material].name;
        if (m == "red") {  // TRS: the quad lies in y = 0 with normal +Y
            EXPECT_NEAR(p.normal.y, 1.0, 1e-12);
            for (int k = 0; k < 3; ++k) EXPECT_NEAR(p.v[size_t(k)].y, 0.0, 1e-12);
        } else if (m == "lamp") {  // nested matrix under a translated group: y = 3, normal -Y
            EXPECT_NEAR(p.normal.y, -1.0, 1e-12);
            for (int k = 0; k < 3; ++k) EXPECT_NEAR(p.v[size_t(k)].y, 3.0, 1e-12);
        } else if (m == "white") {  // mirrored: the front still faces +Z; z = -2
            EXPECT_NEAR(p.normal.z, 1.0, 1e-12);
            EXPECT_NEAR(p.v[0].z, -2.0, 1e-12);
            EXPECT_LE(p.centroid().x, 0.0);
        }
    }
    const Material* red = findMaterial(s, "red");
    ASSERT_TRUE(red);
    EXPECT_NEAR(red->rho.r, 0.8, 1e-12);
    EXPECT_NEAR(red->rho.g, 0.2, 1e-12);
    EXPECT_NEAR(red->rho.b, 0.1, 1e-12);
    EXPECT_FALSE(red->twoSided);
    EXPECT_FALSE(red->isEmitter());
    const Material* lamp = findMaterial(s, "lamp");
    ASSERT_TRUE(lamp);
    // E = pi * emissiveFactor * emissiveStrength
    EXPECT_NEAR(lamp->emission.r, std::numbers::pi * 4.0, 1e-12);
    EXPECT_NEAR(lamp->emission.g, std::numbers::pi * 2.0, 1e-12);
    EXPECT_NEAR(lamp->emission.b, std::numbers::pi * 1.0, 1e-12);
    EXPECT_EQ(lamp->rho, RGB(0.0));
    const Material* white = findMaterial(s, "white");
    ASSERT_TRUE(white);
    EXPECT_EQ(white->rho, RGB(0.99));  // default baseColorFactor 1 -> gltf.clamp_rho
    EXPECT_TRUE(white->twoSided);
    EXPECT_TRUE(white->emitsBothSides);
    EXPECT_TRUE(hasWarning(s, "'white': reflectance >= 1 clamped to 0.99"));
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_NEAR(s.camera->eye.x, 0.0, 1e-12);
    EXPECT_NEAR(s.camera->eye.y, 1.0, 1e-12);
    EXPECT_NEAR(s.camera->eye.z, 5.0, 1e-12);
    Vec3 dir = glm::normalize(s.camera->target - s.camera->eye);
    EXPECT_NEAR(dir.z, -1.0, 1e-12);
    EXPECT_NEAR(s.camera->up.y, 1.0, 1e-12);
    EXPECT_NEAR(s.camera->fovYDegrees, 0.6 * 180.0 / std::numbers::pi, 1e-9);
}

}  // namespace

TEST(GltfLoader, ReadsTransformsMaterialsEmissionCameraFromJson) {
    auto dir = test::tempDir("gltf_json");
    auto file = test::writeFile(dir / "scene.gltf", sceneJson(dataUri(geometryBuffer())).dump(2));
    checkTestScene(loadGltf(file.string()));
}

TEST(GltfLoader, ReadsTheSameSceneFromGlb) {
    auto dir = test::tempDir("gltf_glb");
    json j = sceneJson("");
    j["buffers"][0].erase("uri");  // the GLB's BIN chunk
    auto file = test::writeFile(dir / "scene.glb", glb(j, geometryBuffer()));
    checkTestScene(loadGltf(file.string()));
}

TEST(GltfLoader, ExternalBufferFileAndRegistry) {
    auto dir = test::tempDir("gltf_ext");
    auto bin = geometryBuffer();
    test::writeFile(dir / "geo.bin", std::string(bin.begin(), bin.end()));
    auto file = test::writeFile(dir / "scene.gltf", sceneJson("geo.bin").dump(2));
    // Through loadScene: the registry picks the loader by extension and makes
    // the doubleSided wall a front/back pair.
    Scene s = loadScene(file.string());
    EXPECT_EQ(s.source, "gltf");
    EXPECT_EQ(s.patches.size(), 6u);
    EXPECT_EQ(s.numBackSides(), 1u);
    EXPECT_NEAR(s.emittedPower().r, std::numbers::pi * 4.0 * 0.25, 1e-12);
}

TEST(GltfLoader, BaseColorTextureMeanMultipliesTheFactor) {
    auto dir = test::tempDir("gltf_tex");
    json j = sceneJson(dataUri(geometryBuffer()));
    useBaseColorTexture(j, "data:image/bmp;base64," + base64(bmp2x1()));
    auto file = test::writeFile(dir / "scene.gltf", j.dump());
    Scene s = loadGltf(file.string());
    const Material* red = findMaterial(s, "red");
    ASSERT_TRUE(red);
    // texels white and black: sRGB-decoded mean 0.5 in every channel
    EXPECT_NEAR(red->rho.r, 0.8 * 0.5, 1e-12);
    EXPECT_NEAR(red->rho.g, 0.2 * 0.5, 1e-12);
    // Kept as the material's texture (each textured patch gets its own mean);
    // these primitives have no TEXCOORD_0, so they keep the mean above.
    EXPECT_FALSE(hasWarning(s, "'red': baseColorTexture replaced by its mean"));
    EXPECT_GE(red->diffuseMap.texture, 0);
    EXPECT_EQ(s.cornerUVs.size(), 0u);
}

TEST(GltfLoader, UnloadableTextureKeepsTheFactorWithAWarning) {
    auto dir = test::tempDir("gltf_badtex");
    expectTextureSkipped(dir, "missing.png");
}

TEST(GltfLoader, HugeTextureIsNotDecoded) {
    // A PNG header (no pixel data) claiming 16000 x 16000 RGB texels of 16
    // bits: 1.5 GB decoded, from 33 bytes of input. stb_image's own bound
    // (2^30 counted in 8-bit channels) lets it through; hrad's does not.
    std::vector<unsigned char> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R'};
    for (unsigned char c : {0, 0, 0x3e, 0x80, 0, 0, 0x3e, 0x80, 16, 2, 0, 0, 0}) png.push_back(c);
    for (int i = 0; i < 4; ++i) png.push_back(0);  // CRC (stb does not check it)
    auto dir = test::tempDir("gltf_hugetex");
    json j = sceneJson(dataUri(geometryBuffer()));
    useBaseColorTexture(j, "data:image/png;base64," + base64(png));
    auto file = test::writeFile(dir / "scene.gltf", j.dump());
    // Refused from the header before decoding (texture.max_mb, 2048 MiB by
    // default; 16000^2 float RGB texels are 2.9 GiB): an error naming it.
    InputError e = loadError(file);
    EXPECT_NE(std::string(e.what()).find("texture.max_mb"), std::string::npos) << e.what();
}

TEST(GltfLoader, TexCoordsAndBaseColorTextureAreKept) {
    // The quad of geometryBuffer() with TEXCOORD_0 (bytes 96..127): corners
    // (0,0) (1,0) (1,1) (0,1) in glTF's t-down sense.
    std::vector<unsigned char> b = geometryBuffer();
    for (float v : {0.f, 0.f, 1.f, 0.f, 1.f, 1.f, 0.f, 1.f}) put(b, v);
    json j = sceneJson(dataUri(b));
    j["buffers"][0]["byteLength"] = 128;
    j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 96}, {"byteLength", 32}});
    j["accessors"].push_back({{"bufferView", 3}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}});
    j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = 3;
    useBaseColorTexture(j, "data:image/bmp;base64," + base64(bmp2x1()));
    j["samplers"] = json::array({{{"wrapS", 33071}, {"wrapT", 10497}}});  // CLAMP_TO_EDGE, REPEAT
    j["textures"][0]["sampler"] = 0;
    auto dir = test::tempDir("gltf_uv");
    auto file = test::writeFile(dir / "scene.gltf", j.dump());
    Scene s = loadScene(file.string());
    ASSERT_EQ(s.textures.size(), 1u);
    EXPECT_EQ(s.textures[0]->wrapU, TextureWrap::Clamp);
    EXPECT_EQ(s.textures[0]->wrapV, TextureWrap::Repeat);
    size_t textured = 0;
    for (const Patch& p : s.patches) {
        if (s.materials[p.material].name != "red") continue;
        const auto* uv = patchUVs(s, p);
        ASSERT_TRUE(uv);
        ++textured;
        // hrad keeps v up: every stored v is 1 - t of the file.
        for (int c = 0; c < 3; ++c) EXPECT_TRUE((*uv)[size_t(c)].y == 0.f || (*uv)[size_t(c)].y == 1.f);
        // The white texel is the left one (u < 1/2), whatever v (one row):
        // rho there is baseColorFactor.
        const Vec2 at = patchInverse(p, p.centroid());
        const Vec2 st = uvAt(p, *uv, at.x, at.y);
        const RGB rho = textureRho(s, p, at.x, at.y);
        const double white = std::clamp(1.5 - 2 * st.x, 0.0, 1.0);  // bilinear, clamp, centres 1/4, 3/4
        EXPECT_NEAR(rho.r, 0.8 * white, 1e-6) << st.x;
        // Each triangle of the quad gets its own mean (one is more white
        // than black, the other the reverse); both stay below the factor.
        EXPECT_LT(p.rho.r, 0.8);
    }
    EXPECT_EQ(textured, 2u);
    EXPECT_GT(std::fabs(s.patches[0].rho.r - s.patches[1].rho.r), 0.05);
}

TEST(GltfLoader, FansLinesAndDefaultMaterial) {
    auto dir = test::tempDir("gltf_modes");
    json j = sceneJson(dataUri(geometryBuffer()));
    // The quad's 4 vertices, not indexed: as a fan (0,1,2,3) -> 2 triangles;
    // as lines -> skipped with a warning. Neither has a material.
    j["meshes"][0]["primitives"] = json::array({{{"attributes", {{"POSITION", 0}}}, {"mode", 6}},
                                                {{"attributes", {{"POSITION", 0}}}, {"mode", 1}}});
    j["scenes"][0]["nodes"] = {0};
    auto file = test::writeFile(dir / "scene.gltf", j.dump());
    GltfOptions opt;
    opt.defaultRho = 0.3;
    Scene s = loadGltf(file.string(), opt);
    EXPECT_EQ(s.patches.size(), 2u);
    EXPECT_NEAR(s.totalArea(), 4.0, 1e-12);
    for (const Patch& p : s.patches) EXPECT_NEAR(p.normal.y, 1.0, 1e-12);  // fan keeps the winding
    EXPECT_EQ(findMaterial(s, "default")->rho, RGB(0.3));
    EXPECT_TRUE(hasWarning(s, "points or lines"));
    EXPECT_TRUE(hasWarning(s, "no material"));
    EXPECT_FALSE(s.camera.has_value());
}

TEST(GltfLoader, ClampRhoZeroMakesWhiteAnError) {
    auto dir = test::tempDir("gltf_clamp");
    auto file = test::writeFile(dir / "scene.gltf", sceneJson(dataUri(geometryBuffer())).dump());
    GltfOptions opt;
    opt.clampRho = 0;
    try {
        loadGltf(file.string(), opt);
        FAIL() << "expected an error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("'white'"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("scene.clamp_rho"), std::string::npos) << e.what();
    }
}

// ---- bad input (issue 12 item 7) ---------------------------------------------------

TEST(GltfLoaderErrors, MalformedJsonNamesTheLine) {
    auto dir = test::tempDir("gltf_badjson");
    auto file = test::writeFile(dir / "bad.gltf", "{\n  \"asset\": {\"version\": \"2.0\"},\n  \"nodes\": [ {,\n]}\n");
    InputError e = loadError(file);
    EXPECT_EQ(e.where().line, 3) << e.what();
    EXPECT_EQ(std::string(e.what()).rfind(file.string() + ":3: error: ", 0), 0u) << e.what();
}

TEST(GltfLoaderErrors, MissingBufferFileNamesItsLine) {
    auto dir = test::tempDir("gltf_nobuf");
    auto file = test::writeFile(dir / "scene.gltf", sceneJson("nowhere.bin").dump(2));
    InputError e = loadError(file);
    EXPECT_GT(e.where().line, 1) << e.what();
    EXPECT_NE(std::string(e.what()).find("nowhere.bin"), std::string::npos) << e.what();
}

TEST(GltfLoaderErrors, BufferUriNamingAFolderIsAnError) {
    // tinygltf's own file read sized a folder by tellg (2^63 - 1 on ext4) and
    // allocated that; the loader reads URIs itself and refuses non-files.
    auto dir = test::tempDir("gltf_dirbuf");
    std::filesystem::create_directories(dir / "sub");
    for (const char* uri : {"sub", "."}) {
        auto file = test::writeFile(dir / "scene.gltf", sceneJson(uri).dump(2));
        InputError e = loadError(file);
        EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
        if (std::string(uri) == "sub") {
            EXPECT_GT(e.where().line, 1) << e.what();
        }
    }
    // An image URI naming a folder: the texture is skipped with a warning.
    expectTextureSkipped(dir, "sub");
}

TEST(GltfLoaderErrors, TruncatedGlbNamesTheByteOffset) {
    auto dir = test::tempDir("gltf_trunc");
    json j = sceneJson("");
    j["buffers"][0].erase("uri");
    std::string whole = glb(j, geometryBuffer());
    for (size_t keep : {size_t(0), size_t(7), size_t(16), whole.size() / 2, whole.size() - 4}) {
        auto file = test::writeFile(dir / "cut.glb", whole.substr(0, keep));
        InputError e = loadError(file);
        EXPECT_NE(std::string(e.what()).find("byte offset"), std::string::npos) << keep << ": " << e.what();
        EXPECT_EQ(std::string(e.what()).rfind(file.string() + ": error: ", 0), 0u) << e.what();
    }
    // Not a GLB at all.
    auto file = test::writeFile(dir / "text.glb", "hello, this is not binary glTF");
    EXPECT_NE(std::string(loadError(file).what()).find("magic"), std::string::npos);
}

TEST(GltfLoaderErrors, AccessorProblemsAreErrorsNotCrashes) {
    auto dir = test::tempDir("gltf_acc");
    struct Case {
        const char* name;
        void (*edit)(json&);
        const char* expect;
    };
    const Case cases[] = {
        {"index accessor missing", [](json& j) { j["meshes"][0]["primitives"][0]["indices"] = 99; },
         "accessor 99 does not exist|indices accessor out of bounds"},  // tinygltf checks this one itself
        {"position accessor missing", [](json& j) { j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = -5; },
         "accessor -5 does not exist"},
        {"index value out of range", [](json& j) { j["accessors"][0]["count"] = 2; },
         "out of range (POSITION has 2 vertices)"},
        {"count beyond the view", [](json& j) { j["accessors"][1]["count"] = 1000000000; }, "do not fit in bufferView"},
        {"view beyond the buffer", [](json& j) { j["bufferViews"][2]["byteOffset"] = 90; }, "lies outside buffer"},
        {"missing buffer view", [](json& j) { j["accessors"][2]["bufferView"] = 17; }, "bufferView 17 does not exist"},
        {"wrong type", [](json& j) { j["accessors"][0]["type"] = "VEC2"; }, "unexpected accessor type"},
        {"missing material", [](json& j) { j["meshes"][0]["primitives"][0]["material"] = 9; },
         "material 9 does not exist"},
        {"missing mesh", [](json& j) { j["nodes"][0]["mesh"] = 42; }, "mesh 42 does not exist"},
        {"missing child", [](json& j) { j["nodes"][1]["children"] = {7}; }, "node 7 does not exist"},
        {"two parents", [](json& j) { j["nodes"][3]["children"] = {2}; }, "glTF nodes form trees"},
        {"bad yfov", [](json& j) { j["cameras"][0]["perspective"]["yfov"] = 4.0; }, "yfov"},
        {"draco required", [](json& j) { j["extensionsRequired"] = {"KHR_draco_mesh_compression"}; },
         "requires extension 'KHR_draco_mesh_compression'"},
    };
    for (const Case& c : cases) {
        json j = sceneJson(dataUri(geometryBuffer()));
        c.edit(j);
        auto file = test::writeFile(dir / "bad.gltf", j.dump(1));
        InputError e = loadError(file);
        // `expect` may list alternatives separated by '|' (hrad's or tinygltf's wording).
        bool found = false;
        std::string alternatives = c.expect;
        for (size_t b = 0, e2; b <= alternatives.size(); b = e2 + 1) {
            e2 = std::min(alternatives.find('|', b), alternatives.size());
            found |= std::string(e.what()).find(alternatives.substr(b, e2 - b)) != std::string::npos;
        }
        EXPECT_TRUE(found) << c.name << ": " << e.what();
        EXPECT_EQ(std::string(e.what()).rfind(file.string(), 0), 0u) << c.name << ": " << e.what();
        // hrad's own checks name the JSON line (tinygltf's do not).
        if (std::string(c.name) != "index accessor missing") {
            EXPECT_GT(e.where().line, 1) << c.name << ": " << e.what();
        }
    }
}

TEST(GltfLoaderErrors, SemanticErrorsPointAtTheValue) {
    auto dir = test::tempDir("gltf_where");
    json j = sceneJson(dataUri(geometryBuffer()));
    j["nodes"][3]["mesh"] = 42;
    std::string text = j.dump(2);
    auto file = test::writeFile(dir / "bad.gltf", text);
    InputError e = loadError(file);
    // nlohmann dumps keys sorted: the first "mesh": 42 is the wall's.
    size_t at = text.find("\"mesh\": 42");
    ASSERT_NE(at, std::string::npos);
    EXPECT_EQ(e.where().line, 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'))) << e.what();
    // In a .glb the same problem names the byte offset of the value.
    json g = j;
    g["buffers"][0].erase("uri");
    std::string bin = glb(g, geometryBuffer());
    auto gfile = test::writeFile(dir / "bad.glb", bin);
    std::string msg = loadError(gfile).what();
    size_t pos = msg.find("at byte offset ");
    ASSERT_NE(pos, std::string::npos) << msg;
    size_t offset = std::stoul(msg.substr(pos + 15));
    ASSERT_LT(offset + 2, bin.size());
    EXPECT_EQ(bin.substr(offset, 2), "42") << msg;
}

TEST(GltfLoaderErrors, MaxFacesBoundsInstancing) {
    auto dir = test::tempDir("gltf_maxfaces");
    auto file = test::writeFile(dir / "scene.gltf", sceneJson(dataUri(geometryBuffer())).dump());
    GltfOptions opt;
    opt.maxFaces = 4;
    try {
        loadGltf(file.string(), opt);
        FAIL() << "expected an error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("gltf.max_faces"), std::string::npos) << e.what();
    }
}

// KHR_lights_punctual (scene/lights/): a point light on a node at (0, 2, 0),
// a spot on node 'group''s child, a directional; color times intensity.
TEST(GltfLoader, PunctualLightsBecomeLights) {
    auto dir = test::tempDir("gltf_lights");
    json j = sceneJson(dataUri(geometryBuffer()));
    j["extensionsUsed"] = json::array({"KHR_lights_punctual"});
    j["extensions"]["KHR_lights_punctual"]["lights"] = json::array({
        {{"type", "point"}, {"color", {1, 0.5, 0.25}}, {"intensity", 4}},
        {{"type", "spot"}, {"intensity", 2}, {"spot", {{"innerConeAngle", 0.2}, {"outerConeAngle", 0.5}}}},
        {{"type", "directional"}, {"intensity", 3}},
    });
    j["nodes"].push_back({{"translation", {0, 2, 0}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
    j["nodes"].push_back({{"translation", {0, 3, 0}}, {"extensions", {{"KHR_lights_punctual", {{"light", 1}}}}}});
    j["nodes"].push_back({{"extensions", {{"KHR_lights_punctual", {{"light", 2}}}}}});
    j["scenes"][0]["nodes"].push_back(5);
    j["scenes"][0]["nodes"].push_back(6);
    j["scenes"][0]["nodes"].push_back(7);
    auto file = test::writeFile(dir / "scene.gltf", j.dump(2));
    Scene s = loadGltf(file.string());
    ASSERT_EQ(s.lights.size(), 3u);
    EXPECT_STREQ(s.lights[0]->name(), "point");
    LightSample a = s.lights[0]->sample(Vec3(0.0), 0.5, 0.5);  // 2 m below: I / 4
    EXPECT_NEAR(a.value.r, 1.0, 1e-12);
    EXPECT_NEAR(a.value.g, 0.5, 1e-12);
    EXPECT_NEAR(a.dir.y, 1.0, 1e-12);
    // The spot shines along the node's -Z: a point 3 m below it is outside its 0.5 rad cone.
    EXPECT_EQ(s.lights[1]->sample(Vec3(0.0), 0.5, 0.5).value.r, 0.0);
    EXPECT_NEAR(s.lights[1]->sample(Vec3(0, 3, -1), 0.5, 0.5).value.r, 2.0, 1e-12);
    LightSample d = s.lights[2]->sample(Vec3(0.0), 0.5, 0.5);  // light travels along -Z
    EXPECT_NEAR(d.dir.z, 1.0, 1e-12);
    EXPECT_NEAR(d.value.r, 3.0, 1e-12);
}

TEST(GltfLoader, MissingPunctualLightIsAnError) {
    auto dir = test::tempDir("gltf_lights_bad");
    json j = sceneJson(dataUri(geometryBuffer()));
    j["nodes"].push_back({{"extensions", {{"KHR_lights_punctual", {{"light", 3}}}}}});
    j["scenes"][0]["nodes"].push_back(5);
    auto file = test::writeFile(dir / "scene.gltf", j.dump(2));
    InputError e = loadError(file);
    EXPECT_NE(std::string(e.what()).find("light 3 does not exist"), std::string::npos) << e.what();
}

