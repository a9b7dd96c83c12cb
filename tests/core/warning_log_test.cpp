// core/warning_log.h: warnings counted, not repeated, in bounded memory.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "core/warning_log.h"

using namespace hrad;

TEST(WarningLog, RepeatsAreCountedOnOneLine) {
    WarningLog log;
    log.push_back("a.mtl:12: material 'chair': both d and Tr");
    log.push_back("a.mtl:40: material 'desk': both d and Tr");
    log.push_back("a.obj:3: unknown statement 'vp'");
    ASSERT_EQ(log.size(), 2u);
    EXPECT_EQ(log.total(), 3u);
    EXPECT_EQ(log[0], "a.mtl:12: material 'chair': both d and Tr (2 times in all; also "
                      "a.mtl:40: material 'desk': both d and Tr)");
    EXPECT_EQ(log[1], "a.obj:3: unknown statement 'vp'");
    ASSERT_EQ(log.entries()[0].examples.size(), 2u);
    EXPECT_EQ(log.entries()[0].examples[1], "a.mtl:40: material 'desk': both d and Tr");
    // An explicit key groups what the text would not.
    log.add("cct", "x.mgf:1: cct converted");
    log.add("cct", "x.mgf:9: cct converted with another fit");
    log.add("cct", "x.mgf:1: cct converted");  // the same text: counted, not kept again
    EXPECT_EQ(log.size(), 3u);
    EXPECT_EQ(log[2], "x.mgf:1: cct converted (3 times in all; also x.mgf:9: cct converted with "
                      "another fit)");
}

// One warning string per skipped instance once held 7.6 GiB (issue 64):
// 10^6 identical or same-kind warnings cost what a handful cost.
TEST(WarningLog, AMillionWarningsCostConstantMemory) {
    WarningLog few, many;
    for (int i = 0; i < 10; ++i)
        few.push_back(fmt::format("scene.xml:{}: warning: 'hair' shapes cannot be made into polygons", i));
    for (int i = 0; i < 1000000; ++i)
        many.push_back(fmt::format("scene.xml:{}: warning: 'hair' shapes cannot be made into polygons", i));
    EXPECT_EQ(many.size(), 1u);
    EXPECT_EQ(many.total(), 1000000u);
    EXPECT_NE(many[0].find("(1000000 times in all; also "), std::string::npos) << many[0];
    EXPECT_EQ(many.entries()[0].examples.size(), WarningLog::kExamples);
    // Same number of strings; only the count's digits differ.
    EXPECT_LE(many.memoryBytes(), few.memoryBytes() + 64);
}

TEST(WarningLog, DistinctKindsAreBoundedToo) {
    WarningLog log;
    for (size_t i = 0; i < WarningLog::kDistinct + 500; ++i) log.add(fmt::format("kind {}", i), "w");
    EXPECT_EQ(log.entries().size(), WarningLog::kDistinct);
    EXPECT_EQ(log.size(), WarningLog::kDistinct + 1);  // the closing line
    EXPECT_NE(log[log.size() - 1].find("500 more warnings not kept"), std::string::npos)
        << log[log.size() - 1];
    EXPECT_EQ(log.total(), WarningLog::kDistinct + 500);
}

TEST(WarningLog, MergeKeepsCounts) {
    WarningLog a, b;
    for (int i = 0; i < 5; ++i) b.push_back(fmt::format("m.obj:{}: degenerate face", i));
    a.push_back("m.obj:99: degenerate face");
    a.merge(b);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_EQ(a.total(), 6u);
    EXPECT_EQ(a.entries()[0].count, 6u);
}
