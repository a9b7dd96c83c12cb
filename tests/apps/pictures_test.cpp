// Issue 60, end to end through `hrad solve`: the PNG, the PLY vertex colours
// and the glTF COLOR_0 share one tone map (a flat render's pixels are exactly
// the exports' leaf colours), the automatic exposure clips few pixels, smooth
// is the default, and every .glb written is valid for the Khronos validator.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>
#include <png.h>
#include <sys/wait.h>
#include <tiny_gltf.h>

#include "render/image.h"
#include "tests/gltf_validate.h"
#include "tests/test_util.h"

namespace {

using Rgb8 = std::array<uint8_t, 3>;

int run(const std::string& args, std::string* out = nullptr) {
    std::string cmd = std::string(HRAD_BINARY) + " --log quiet " + args + " 2>&1";
    FILE* p = popen(cmd.c_str(), "r");
    std::string text;
    std::array<char, 4096> buf;
    while (size_t n = fread(buf.data(), 1, buf.size(), p)) text.append(buf.data(), n);
    int status = pclose(p);
    if (out) *out = text;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::vector<Rgb8> readPng(const std::string& path, int& w, int& h) {
    png_image img{};
    img.version = PNG_IMAGE_VERSION;
    EXPECT_TRUE(png_image_begin_read_from_file(&img, path.c_str())) << path;
    img.format = PNG_FORMAT_RGB;
    w = int(img.width);
    h = int(img.height);
    std::vector<Rgb8> px(size_t(w) * size_t(h));
    EXPECT_TRUE(png_image_finish_read(&img, nullptr, px.data(), 0, nullptr));
    return px;
}

/// COLOR_0 of the glb's only primitive, sRGB encoded as a viewer shows it.
std::set<Rgb8> glbColours(const std::string& path, nlohmann::json& extras) {
    tinygltf::TinyGLTF loader;
    tinygltf::Model m;
    std::string err, warn;
    EXPECT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, path)) << err;
    const auto& prim = m.meshes.at(0).primitives.at(0);
    const auto& a = m.accessors.at(size_t(prim.attributes.at("COLOR_0")));
    const auto& bv = m.bufferViews.at(size_t(a.bufferView));
    std::vector<float> c(3 * a.count);
    std::memcpy(c.data(), m.buffers.at(0).data.data() + bv.byteOffset + a.byteOffset, 4 * c.size());
    std::set<Rgb8> out;
    for (size_t i = 0; i < a.count; ++i)
        out.insert({hrad::render::encodeSrgb8(c[3 * i]), hrad::render::encodeSrgb8(c[3 * i + 1]),
                    hrad::render::encodeSrgb8(c[3 * i + 2])});
    extras = nlohmann::json::object();
    extras["exposure"] = m.asset.extras.Get("exposure").GetNumberAsDouble();
    extras["interpolated"] = m.asset.extras.Get("interpolated").Get<bool>();
    return out;
}

/// The uchar vertex colours of an hrad PLY (x, y, z float, then r, g, b).
std::set<Rgb8> plyColours(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::string line;
    size_t vertices = 0;
    while (std::getline(in, line) && line != "end_header")
        if (line.rfind("element vertex ", 0) == 0) vertices = std::stoul(line.substr(15));
    std::set<Rgb8> out;
    std::array<char, 15> rec;
    for (size_t i = 0; i < vertices && in.read(rec.data(), 15); ++i)
        out.insert({uint8_t(rec[12]), uint8_t(rec[13]), uint8_t(rec[14])});
    return out;
}

nlohmann::json readJson(const std::filesystem::path& p) {
    std::ifstream in(p);
    return nlohmann::json::parse(in);
}

TEST(Pictures, PngPlyAndGlbShareOneToneMap) {
    auto dir = hrad::test::tempDir("pictures_tone");
    std::string out;
    ASSERT_EQ(run("solve cornell --eps 1e-2 --flat --glb --no-progress --width 64 --height 64 -o " +
                      dir.string(), &out),
              0)
        << out;
    int w = 0, h = 0;
    std::vector<Rgb8> png = readPng((dir / "image.png").string(), w, h);
    ASSERT_EQ(w, 64);
    nlohmann::json extras;
    std::set<Rgb8> glb = glbColours((dir / "solution.glb").string(), extras);
    std::set<Rgb8> ply = plyColours((dir / "solution.ply").string());
    nlohmann::json summary = readJson(dir / "summary.json");
    ASSERT_TRUE(summary.contains("tone_map")) << summary.dump();
    EXPECT_EQ(summary["tone_map"]["exposure"].get<double>(), extras["exposure"].get<double>());
    EXPECT_FALSE(extras["interpolated"].get<bool>());
    // Flat, one sample at each pixel centre: every lit pixel is one leaf's
    // value, so its colour is one of the exports' colours, to the bit.
    size_t lit = 0, inGlb = 0, inPly = 0;
    for (const Rgb8& c : png) {
        if (c == Rgb8{0, 0, 0}) continue;
        ++lit;
        inGlb += glb.count(c);
        inPly += ply.count(c);
    }
    ASSERT_GT(lit, size_t(w * h / 2));
    EXPECT_EQ(inPly, lit);
    // COLOR_0 is float and is encoded here from the float: a value within
    // round-off of an 8-bit step may land on the next one.
    EXPECT_GE(double(inGlb), 0.99 * double(lit));
    EXPECT_LT(summary["tone_map"]["clipped_share"].get<double>(), 0.02);
    HRAD_EXPECT_VALID_GLTF((dir / "solution.glb").string());
}

TEST(Pictures, SmoothIsTheDefaultAndLightmapsAreWritten) {
    auto dir = hrad::test::tempDir("pictures_smooth");
    std::string out;
    ASSERT_EQ(run("solve cornell --eps 1e-2 --glb --lightmap 128 --no-images --no-solution --no-ply "
                  "--no-progress -o " + dir.string(), &out),
              0)
        << out;
    nlohmann::json extras;
    glbColours((dir / "solution.glb").string(), extras);
    EXPECT_TRUE(extras["interpolated"].get<bool>());
    HRAD_EXPECT_VALID_GLTF((dir / "solution.glb").string());
    nlohmann::json summary = readJson(dir / "summary.json");
    ASSERT_TRUE(summary.contains("lightmap")) << summary.dump();
    EXPECT_EQ(summary["lightmap"]["size"].get<int>(), 128);
    EXPECT_GT(summary["lightmap"]["texels_per_unit"].get<double>(), 0.0);
    for (const char* f : {"lightmap.exr", "lightmap.png", "lightmap.glb"})
        EXPECT_TRUE(std::filesystem::exists(dir / f)) << f;
    HRAD_EXPECT_VALID_GLTF((dir / "lightmap.glb").string());
}

}  // namespace
