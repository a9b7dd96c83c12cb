// Mitsuba .serialized meshes (scene/mitsuba_serialized.h), files written by
// the test with zlib in the documented layout.
#include "scene/mitsuba_serialized.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>

#include "core/error.h"
#include "scene/loader.h"
#include "tests/scene/little_endian.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

using test::put;
using test::putFloat;

/// One mesh record (version 4): header + zlib stream. `normals` adds a
/// normals block that the reader must skip.
std::string meshRecord(const std::vector<float>& pos, const std::vector<uint32_t>& idx,
                       bool normals, uint64_t declaredVertices = UINT64_MAX) {
    std::string raw;
    put(raw, uint32_t(0x1000 | (normals ? 0x0001 : 0)));
    raw += "mesh";
    raw += '\0';
    put(raw, declaredVertices != UINT64_MAX ? declaredVertices : uint64_t(pos.size() / 3));
    put(raw, uint64_t(idx.size() / 3));
    for (float f : pos) putFloat(raw, f);
    if (normals)
        for (size_t i = 0; i < pos.size(); ++i) putFloat(raw, i % 3 == 2 ? 1.0f : 0.0f);
    for (uint32_t i : idx) put(raw, i);
    uLongf n = compressBound(uLong(raw.size()));
    std::string z(n, '\0');
    EXPECT_EQ(compress2(reinterpret_cast<Bytef*>(z.data()), &n,
                        reinterpret_cast<const Bytef*>(raw.data()), uLong(raw.size()), 9),
              Z_OK);
    z.resize(n);
    std::string rec;
    put(rec, uint16_t(0x041C));
    put(rec, uint16_t(4));
    return rec + z;
}

/// A file of several records with the trailing offset table.
std::string serializedFile(const std::vector<std::string>& records) {
    std::string f;
    std::vector<uint64_t> offsets;
    for (const auto& r : records) {
        offsets.push_back(f.size());
        f += r;
    }
    for (uint64_t o : offsets) put(f, o);
    put(f, uint32_t(records.size()));
    return f;
}

const std::vector<float> kQuadPos = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
const std::vector<uint32_t> kQuadIdx = {0, 1, 2, 0, 2, 3};
const std::vector<float> kTriPos = {0, 0, 5, 2, 0, 5, 0, 2, 5};
const std::vector<uint32_t> kTriIdx = {0, 1, 2};

TEST(MitsubaSerialized, ReadsTheIndexedMeshAndSkipsNormals) {
    auto dir = test::tempDir("mts_ser");
    auto path =
        test::writeFile(dir / "m.serialized", serializedFile({meshRecord(kQuadPos, kQuadIdx, false),
                                                              meshRecord(kTriPos, kTriIdx, true)}));
    SerializedMesh a = readSerialized(path.string(), 0, 1000);
    EXPECT_EQ(a.name, "mesh");
    EXPECT_EQ(a.positions.size(), 4u);
    EXPECT_EQ(a.triangles.size(), 2u);
    SerializedMesh b = readSerialized(path.string(), 1, 1000);
    ASSERT_EQ(b.positions.size(), 3u);
    EXPECT_EQ(b.positions[1], Vec3(2, 0, 5));
    EXPECT_THROW(readSerialized(path.string(), 2, 1000), InputError);
}

// Issue 64: the bytes the data inflate to are a budget of their own
// (mitsuba.max_inflated_mb), checked from the declared counts first.
TEST(MitsubaSerialized, InflatedBytesAreBudgeted) {
    auto dir = test::tempDir("mts_ser_inflate");
    auto path =
        test::writeFile(dir / "m.serialized", serializedFile({meshRecord(kTriPos, kTriIdx, true)}));
    SerializedMesh m = readSerialized(path.string(), 0, 1000);
    EXPECT_EQ(m.inflatedBytes, 3u * 3 * 4 + 3 * 4 + 3u * 3 * 4);  // positions, indices, normals
    try {
        readSerialized(path.string(), 0, 1000, "shape at s.xml:3", m.inflatedBytes - 1);
        ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("setting mitsuba.max_inflated_mb"), std::string::npos)
            << e.what();
    }
}

TEST(MitsubaSerialized, LoadsThroughTheXmlShape) {
    auto dir = test::tempDir("mts_ser_xml");
    test::writeFile(dir / "m.serialized", serializedFile({meshRecord(kQuadPos, kQuadIdx, false),
                                                          meshRecord(kTriPos, kTriIdx, true)}));
    auto xml = test::writeFile(dir / "s.xml", R"(<scene version="3.0.0">
  <shape type="serialized"><string name="filename" value="m.serialized"/><integer name="shape_index" value="1"/>
    <transform name="to_world"><translate z="1"/></transform>
    <emitter type="area"><rgb name="radiance" value="1"/></emitter>
  </shape>
  <shape type="serialized"><string name="filename" value="m.serialized"/></shape>
</scene>
)");
    Scene s = loadScene(xml.string());
    ASSERT_EQ(s.patches.size(), 3u);
    EXPECT_NEAR(s.patches[0].area, 2.0, 1e-6);
    EXPECT_NEAR(s.patches[0].centroid().z, 6.0, 1e-6);
    EXPECT_NEAR(s.patches[1].area + s.patches[2].area, 1.0, 1e-6);
}

// A shape_index no integer holds (7.8e91: a fuzz finding, UBSan's
// float-cast-overflow), a negative or a fractional one is refused with the
// shape's line, not cast.
TEST(MitsubaSerialized, ShapeIndexOutsideTheWholeNumbersIsAnInputError) {
    auto dir = test::tempDir("mts_ser_index");
    test::writeFile(dir / "m.serialized", serializedFile({meshRecord(kQuadPos, kQuadIdx, false)}));
    for (const std::string v : {"7.77778e+91", "-1", "1.5", "4294967296"}) {
        auto xml = test::writeFile(dir / "s.xml",
                                   "<scene version=\"3.0.0\">\n"
                                   "  <shape type=\"serialized\"><string name=\"filename\" "
                                   "value=\"m.serialized\"/><float name=\"shape_index\" value=\"" +
                                       v + "\"/></shape>\n</scene>\n");
        try {
            loadScene(xml.string());
            ADD_FAILURE() << "no error for shape_index " << v;
        } catch (const InputError& e) {
            std::string w = e.what();
            EXPECT_NE(w.find("s.xml:2: error: "), std::string::npos) << w;
            EXPECT_NE(w.find("shape_index"), std::string::npos) << w;
        }
    }
}

TEST(MitsubaSerialized, TruncatedOrCorruptFilesNameTheByteOffset) {
    auto dir = test::tempDir("mts_ser_bad");
    std::string good = serializedFile({meshRecord(kQuadPos, kQuadIdx, false)});
    auto expectError = [&](const std::string& bytes, const std::string& needle) {
        auto path = test::writeFile(dir / "bad.serialized", bytes);
        try {
            readSerialized(path.string(), 0, 1000, "shape at s.xml:3");
            ADD_FAILURE() << "no error for " << needle;
        } catch (const InputError& e) {
            std::string w = e.what();
            EXPECT_NE(w.find("bad.serialized: error: "), std::string::npos) << w;
            EXPECT_NE(w.find(needle), std::string::npos) << w;
            EXPECT_NE(w.find("byte offset"), std::string::npos) << w;
            EXPECT_NE(w.find("s.xml:3"), std::string::npos) << w;
        }
    };
    // Cut inside the compressed stream, the offset table rebuilt so that the
    // table itself is valid.
    std::string rec = meshRecord(kQuadPos, kQuadIdx, false);
    expectError(serializedFile({rec.substr(0, rec.size() / 2)}), "truncated");
    // Cut anywhere: never a crash, always an InputError.
    for (size_t n = 0; n < good.size(); n += 3) {
        auto path = test::writeFile(dir / "cut.serialized", good.substr(0, n));
        EXPECT_THROW(readSerialized(path.string(), 0, 1000), InputError) << n;
    }
    // A vertex count no compressed size can hold is refused before allocating.
    expectError(serializedFile({meshRecord(kQuadPos, kQuadIdx, false, uint64_t(1) << 31)}),
                "vertices");
    // Wrong magic.
    std::string wrong = good;
    wrong[0] = 'X';
    expectError(wrong, "not a Mitsuba serialized mesh");
    // An offset near 2^64 must not wrap around the bounds check (fuzz finding).
    std::string wrap = rec;
    put(wrap, uint64_t(0xFFFFFFFFFFFFFFFEull));
    put(wrap, uint32_t(1));
    expectError(wrap, "lies outside the file");
    // Index out of range.
    expectError(serializedFile({meshRecord(kQuadPos, {0, 1, 9}, false)}), "names vertex 9");

    // Through the XML loader, the error still names the .serialized file.
    test::writeFile(dir / "t.serialized", serializedFile({rec.substr(0, rec.size() / 2)}));
    auto xml = test::writeFile(
        dir / "s.xml",
        "<scene version=\"3.0.0\">\n  <shape type=\"serialized\">\n"
        "    <string name=\"filename\" value=\"t.serialized\"/>\n  </shape>\n</scene>\n");
    try {
        loadScene(xml.string());
        ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
        std::string w = e.what();
        EXPECT_NE(w.find("t.serialized: error: truncated"), std::string::npos) << w;
        EXPECT_NE(w.find("s.xml:2"), std::string::npos) << w;
    }
}

}  // namespace
}  // namespace hrad::scene
