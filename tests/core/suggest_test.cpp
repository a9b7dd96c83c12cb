// core/suggest.h: the "did you mean" of the CLI, the setting keys and the scene names.
#include <gtest/gtest.h>

#include "core/params.h"
#include "core/suggest.h"

using namespace hrad;

TEST(Suggest, EditDistanceCountsInsertionsDeletionsSubstitutionsAndSwaps) {
    EXPECT_EQ(editDistance("solve", "solve"), 0u);
    EXPECT_EQ(editDistance("solv", "solve"), 1u);     // insertion
    EXPECT_EQ(editDistance("--epz", "--eps"), 1u);    // substitution
    EXPECT_EQ(editDistance("--widht", "--width"), 1u);  // adjacent swap
    EXPECT_EQ(editDistance("", "abc"), 3u);
    EXPECT_EQ(editDistance("kitten", "sitting"), 3u);
}

TEST(Suggest, NearestNamesWithinAThirdOfTheWord) {
    const std::vector<std::string> commands = {"info", "solve", "render", "sweep", "results",
                                               "reference", "settings"};
    EXPECT_EQ(nearestNames("solv", commands), std::vector<std::string>{"solve"});
    EXPECT_EQ(nearestNames("refrence", commands), std::vector<std::string>{"reference"});
    EXPECT_TRUE(nearestNames("xyzzy", commands).empty());
    EXPECT_TRUE(nearestNames("solve", commands).empty());  // the word itself is no suggestion
    EXPECT_EQ(didYouMean({"a"}), "did you mean 'a'?");
    EXPECT_EQ(didYouMean({"a", "b", "c"}), "did you mean 'a', 'b' or 'c'?");
    EXPECT_EQ(didYouMean({}), "");
}

TEST(Suggest, DottedKeysMatchTheirLastSegment) {
    const std::vector<std::string> keys = {"oracle.eps", "hr.min_area", "hr.max_level", "ff.vis_rays"};
    EXPECT_EQ(nearestKeys("hr.max_levl", keys), std::vector<std::string>{"hr.max_level"});
    EXPECT_EQ(nearestKeys("hr.epz", keys), std::vector<std::string>{"oracle.eps"});
    EXPECT_TRUE(nearestKeys("hr.nothing_like_it", keys).empty());
}

// The unknown-setting error names the near keys among those the readers declared.
TEST(Suggest, UnknownSettingNamesTheNearestReadKey) {
    Params p;
    p.set("oracle.epz", 1e-3, {"study.toml", 7, 0});
    (void)p.getDouble({"oracle.eps", "threshold"}, 1e-2);
    (void)p.getInt({"hr.max_level", "deepest level"}, 14);
    try {
        p.reportUnused();
        FAIL() << "expected an error";
    } catch (const InputError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("study.toml:7"), std::string::npos) << m;
        EXPECT_NE(m.find("did you mean 'oracle.eps'?"), std::string::npos) << m;
    }
}
