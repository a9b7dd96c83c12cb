#include <gtest/gtest.h>

#include "core/params.h"

using namespace hrad;

TEST(Params, ReadsTypedValuesAndMarksThemUsed) {
    Params p;
    p.setFromText("eps", "1e-3", {"study.toml", 4});
    p.setFromText("depth", "5", {"study.toml", 5});
    p.setFromText("flag", "true", {"study.toml", 6});
    p.setFromText("name", "bfa", {"study.toml", 7});
    EXPECT_DOUBLE_EQ(p.getDouble("eps", 0.0), 1e-3);
    EXPECT_EQ(p.getInt("depth", 0), 5);
    EXPECT_TRUE(p.getBool("flag", false));
    EXPECT_EQ(p.getString("name", ""), "bfa");
    EXPECT_NO_THROW(p.reportUnused());
}

TEST(Params, UnusedKeyIsAnErrorNamingKeyAndLine) {
    Params p;
    p.setFromText("epsilon", "1e-3", {"study.toml", 12});
    p.getDouble("eps", 0.1);
    try {
        p.reportUnused();
        FAIL() << "expected InputError";
    } catch (const InputError& e) {
        std::string msg = e.what();
        EXPECT_NE(msg.find("study.toml:12"), std::string::npos) << msg;
        EXPECT_NE(msg.find("epsilon"), std::string::npos) << msg;
    }
}

TEST(Params, RangeAndTypeErrorsNameTheKey) {
    Params p;
    p.setFromText("eps", "-1", {"cli", 0});
    EXPECT_THROW(p.getDouble("eps", 0.1, 0.0, 1.0, true), InputError);
    p.setFromText("oracle", "nope", {"cli", 0});
    try {
        p.getEnum("oracle", "bfa", {"ff", "bfa", "uniform"});
        FAIL();
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("ff, bfa, uniform"), std::string::npos);
    }
    p.setFromText("n", "abc", {});
    EXPECT_THROW(p.getInt("n", 1), InputError);
    // Issue 16: text values are numbers only when the whole text is a finite number.
    for (const char* bad : {"nan", "inf", "1e400", "0x10", "10x", "4e3x"}) {
        p.setFromText("x", bad, {"cli", 0});
        EXPECT_THROW(p.getDouble("x", 1.0), InputError) << bad;
    }
    p.setFromText("x", "4e3", {"cli", 0});
    EXPECT_EQ(p.getDouble("x", 1.0), 4000.0);
}

TEST(Params, SubsetStripsPrefix) {
    Params p;
    p.setFromText("oracle.eps", "0.5", {});
    p.setFromText("solver", "hr", {});
    Params s = p.subset("oracle");
    EXPECT_TRUE(s.has("eps"));
    EXPECT_FALSE(s.has("solver"));
}
