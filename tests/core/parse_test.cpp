#include <gtest/gtest.h>

#include "core/parse.h"

namespace hrad {
namespace {

TEST(StrictParse, AcceptsWholeFiniteNumbersOnly) {
    EXPECT_EQ(parseFiniteDouble("0.5"), 0.5);
    EXPECT_EQ(parseFiniteDouble("-1e3"), -1000.0);
    EXPECT_EQ(parseFiniteDouble("+2"), 2.0);
    EXPECT_EQ(parseFiniteDouble(".25"), 0.25);
    for (const char* bad : {"", "abc", "10x", "1.2.3", "inf", "-inf", "nan", "1e400", "0x10", "+",
                            "+-1", " 1", "1 ", "1,5"})
        EXPECT_FALSE(parseFiniteDouble(bad).has_value()) << bad;
}

TEST(StrictParse, IntegersRefuseExponentsFractionsAndOverflow) {
    EXPECT_EQ(parseInt64("4000"), 4000);
    EXPECT_EQ(parseInt64("-7"), -7);
    EXPECT_EQ(parseInt64("+9"), 9);
    for (const char* bad : {"", "4e3", "4.0", "0x10", "12a", "99999999999999999999", "+"})
        EXPECT_FALSE(parseInt64(bad).has_value()) << bad;
}

}  // namespace
}  // namespace hrad
