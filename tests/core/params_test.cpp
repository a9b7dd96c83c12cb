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

TEST(ParamsRecords, EveryReadRecordsValueDefaultRangeDocAndComponent) {
    Params p;
    p.set("hr.max_level", int64_t(9));
    {
        Params::Scope scope(p, "hr solver");
        EXPECT_EQ(p.getInt({"hr.max_level", "deepest level"}, 14, 0, 31), 9);
        EXPECT_EQ(p.getEnum({"hr.basis", "basis"}, "constant", {"constant", "linear"}),
                  "constant");
    }
    const auto& r = p.records();
    ASSERT_EQ(r.size(), 2u);
    const Params::Record& lvl = r.at("hr.max_level");
    EXPECT_EQ(lvl.type, "integer");
    EXPECT_EQ(std::get<int64_t>(lvl.value), 9);
    EXPECT_EQ(lvl.def, "14");
    EXPECT_EQ(lvl.range, "[0, 31]");
    EXPECT_EQ(lvl.doc, "deepest level");
    EXPECT_EQ(lvl.component, "hr solver");
    EXPECT_TRUE(lvl.given);
    const Params::Record& basis = r.at("hr.basis");
    EXPECT_EQ(std::get<std::string>(basis.value), "constant");  // the default, absent
    EXPECT_EQ(basis.range, "constant | linear");
    EXPECT_FALSE(basis.given);
}

TEST(ParamsRecords, SubsetFeedsTheParentAndCopiesDoNot) {
    Params p;
    p.set("oracle.eps", 0.5);
    {
        Params::Scope scope(p, "oracle bfa");
        Params sub = p.subset("oracle");
        EXPECT_EQ(sub.getDouble({"eps", "threshold"}, 1e-3, 0.0, 1.0), 0.5);
    }
    ASSERT_EQ(p.records().count("oracle.eps"), 1u);
    EXPECT_EQ(p.records().at("oracle.eps").component, "oracle bfa");
    Params copy = p;
    copy.getBool("validate", true);
    EXPECT_EQ(p.records().count("validate"), 0u);
    EXPECT_EQ(copy.records().count("oracle.eps"), 1u);
}

TEST(ParamsRecords, ResolvedValueReplacesAnAutoChoice) {
    Params p;
    EXPECT_EQ(p.getString({"cluster.model", "model"}, "auto"), "auto");
    p.recordResolved("cluster.model", std::string("oriented"));
    const Params::Record& r = p.records().at("cluster.model");
    EXPECT_EQ(std::get<std::string>(r.used()), "oriented");
    EXPECT_EQ(std::get<std::string>(r.value), "auto");
    p.recordResolved("never.read", int64_t(1));  // only keys read are recorded
    EXPECT_EQ(p.records().count("never.read"), 0u);
}

TEST(ParamsRecords, SeveralReadersAreListedOnce) {
    Params p;
    {
        Params::Scope a(p, "oracle bfa");
        p.getDouble("oracle.eps", 1e-3);
    }
    {
        Params::Scope b(p, "oracle kv");
        p.getDouble({"oracle.eps", "the doc"}, 1e-3);
        p.getDouble("oracle.eps", 1e-3);
    }
    EXPECT_EQ(p.records().at("oracle.eps").component, "oracle bfa, oracle kv");
    EXPECT_EQ(p.records().at("oracle.eps").doc, "the doc");
}
