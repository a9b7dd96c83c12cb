// Issue 63 item 2, forgiving and honest loading: scene.missing = error | skip
// (scene/missing_files.h), one reflectance rule for every format
// (scene.clamp_rho, scene.h clampReflectance), and a "no emitter" error that
// names the emitters the loader dropped.
#include <gtest/gtest.h>

#include "core/error.h"
#include "scene/loader.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

const char* kLight = R"(  <shape type="rectangle">
    <transform name="to_world"><translate value="0, 0, 10"/></transform>
    <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
  </shape>
)";

std::string errorOf(const std::string& spec, const Params& p = {}) {
    try {
        loadScene(spec, p);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

size_t countOf(const std::string& text, const std::string& what) {
    size_t n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

/// A Mitsuba scene naming three missing meshes (one of them twice), a
/// missing include and a missing spectrum, beside a light and a floor.
std::filesystem::path scatteredScene(const test::TempDir& dir) {
    return test::writeFile(
        dir / "scene.xml",
        std::string("<scene version=\"3.0.0\">\n") + kLight +                        // lines 2-5
            "  <shape type=\"rectangle\"/>\n"                                         // 6
            "  <shape type=\"obj\"><string name=\"filename\" value=\"a.obj\"/></shape>\n"   // 7
            "  <shape type=\"ply\"><string name=\"filename\" value=\"b.ply\"/></shape>\n"   // 8
            "  <shape type=\"obj\"><string name=\"filename\" value=\"a.obj\"/></shape>\n"   // 9
            "  <include filename=\"parts.xml\"/>\n"                                   // 10
            "  <shape type=\"rectangle\"><bsdf type=\"diffuse\"><spectrum name=\"reflectance\" "
            "filename=\"paint.spd\"/></bsdf></shape>\n"                               // 11
            "  <shape type=\"serialized\"><string name=\"filename\" value=\"c.serialized\"/></shape>\n"
            "</scene>\n");
}

TEST(ForgivingLoading, MissingFilesAreAllNamedInOneError) {
    auto dir = test::tempDir("missing_error");
    const std::string e = errorOf(scatteredScene(dir).string());
    // The first one's FILE:LINE, then every one of them, each once.
    EXPECT_NE(e.find("scene.xml:7: error: mesh file"), std::string::npos) << e;
    EXPECT_NE(e.find("4 more files"), std::string::npos) << e;
    for (const char* f : {"b.ply", "parts.xml", "paint.spd", "c.serialized"})
        EXPECT_EQ(countOf(e, f), 1u) << f << ": " << e;
    EXPECT_EQ(countOf(e, "a.obj"), 1u) << e;  // named twice in the scene, listed once
    EXPECT_NE(e.find("scene.xml:11: spectrum file"), std::string::npos) << e;
    EXPECT_NE(e.find("scene.missing = skip"), std::string::npos) << e;
}

TEST(ForgivingLoading, SkipWarnsOncePerFileAndLoadsTheRest) {
    auto dir = test::tempDir("missing_skip");
    Params p;
    p.set("scene.missing", std::string("skip"));
    Scene s = loadScene(scatteredScene(dir).string(), p);
    EXPECT_EQ(s.patches.size(), 3u);  // the light, the floor and the painted rectangle
    size_t missing = 0;
    for (const std::string& w : s.stats.warnings)
        if (w.find("not found: skipped") != std::string::npos) {
            ++missing;
            EXPECT_EQ(w.find("times in all"), std::string::npos) << w;
        }
    EXPECT_EQ(missing, 5u);
    // The painted rectangle kept the format's grey.
    bool grey = false;
    for (const Material& m : s.materials) grey |= m.rho == RGB(0.5);
    EXPECT_TRUE(grey);
    p.set("scene.missing", std::string("sometimes"));
    EXPECT_NE(errorOf(scatteredScene(dir).string(), p).find("scene.missing"), std::string::npos);
}

TEST(ForgivingLoading, MissingMaterialLibraryAndMgfInclude) {
    auto dir = test::tempDir("missing_obj_mgf");
    auto obj = test::writeFile(dir / "room.obj",
                               "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    EXPECT_NE(errorOf(obj.string()).find("room.obj:1: error: material library"), std::string::npos)
        << errorOf(obj.string());
    auto mgf = test::writeFile(dir / "room.mgf",
                               "m light =\n  ed 10\nv a =\n  p 0 0 0\nv b =\n  p 1 0 0\nv c =\n"
                               "  p 0 1 0\nf a b c\ni chair.mgf\ni desk.mgf\n");
    const std::string e = errorOf(mgf.string());
    EXPECT_NE(e.find("room.mgf:10: error: included file"), std::string::npos) << e;
    EXPECT_NE(e.find("room.mgf:11: included file"), std::string::npos) << e;
    Params skip;
    skip.set("scene.missing", std::string("skip"));
    EXPECT_EQ(loadScene(mgf.string(), skip).patches.size(), 1u);
}

// One rule: a channel >= 1 becomes scene.clamp_rho (0.99) in every format, or
// with 0 is an error at the line that sets it.
TEST(ForgivingLoading, OneClampRuleForEveryFormat) {
    auto dir = test::tempDir("clamp_rule");
    test::writeFile(dir / "white.mtl", "newmtl white\nKd 1 1 1\nnewmtl light\nKe 5 5 5\n");
    auto obj = test::writeFile(dir / "white.obj",
                               "mtllib white.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                               "usemtl white\nf 1 2 3\nusemtl light\nf 1 3 4\n");
    auto xml = test::writeFile(dir / "white.xml",
                               std::string("<scene version=\"3.0.0\">\n") + kLight +
                                   "  <shape type=\"rectangle\"><bsdf type=\"diffuse\"><rgb "
                                   "name=\"reflectance\" value=\"1\"/></bsdf></shape>\n</scene>\n");
    for (const auto& path : {obj, xml}) {
        Scene s = loadScene(path.string());
        bool clamped = false;
        for (const Material& m : s.materials) clamped |= m.rho == RGB(0.99);
        EXPECT_TRUE(clamped) << path;
        bool warned = false;
        for (const std::string& w : s.stats.warnings)
            warned |= w.find("clamped to 0.99 (scene.clamp_rho)") != std::string::npos;
        EXPECT_TRUE(warned) << path;
        Params strict;
        strict.set("scene.clamp_rho", 0.0);
        const std::string e = errorOf(path.string(), strict);
        EXPECT_NE(e.find("scene.clamp_rho"), std::string::npos) << e;
        EXPECT_NE(e.find(path.extension() == ".obj" ? "white.mtl:2: error" : "white.xml:6: error"),
                  std::string::npos)
            << e;
    }
    Params old;
    old.set("obj.clamp_rho", 0.99, {"study.toml", 4, 0});
    const std::string e = errorOf(obj.string(), old);
    EXPECT_NE(e.find("study.toml:4"), std::string::npos) << e;
    EXPECT_NE(e.find("is now 'scene.clamp_rho'"), std::string::npos) << e;
}

TEST(ForgivingLoading, NoEmitterNamesWhatWasDropped) {
    auto dir = test::tempDir("dropped_emitters");
    auto xml = test::writeFile(
        dir / "outdoor.xml",
        "<scene version=\"3.0.0\">\n"
        "  <shape type=\"rectangle\"/>\n"
        "  <emitter type=\"sunsky\"/>\n"
        "  <emitter type=\"projector\"/>\n"
        "  <emitter type=\"area\" id=\"lamp\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n"
        "</scene>\n");
    const std::string e = errorOf(xml.string());
    EXPECT_NE(e.find("no emitter"), std::string::npos) << e;
    EXPECT_NE(e.find("3 emitters of unsupported types were dropped: sunsky ("), std::string::npos) << e;
    EXPECT_NE(e.find("outdoor.xml:3)"), std::string::npos) << e;
    // point, spot, directional, constant and envmap emitters are lights now (scene/lights/).
    EXPECT_NE(e.find("outdoor.xml:4)"), std::string::npos) << e;
    EXPECT_NE(e.find("area emitter on no shape ("), std::string::npos) << e;
}

}  // namespace
}  // namespace hrad::scene
