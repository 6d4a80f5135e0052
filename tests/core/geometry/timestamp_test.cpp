// Exact decimal-seconds <-> nanoseconds conversions (core/timestamp.h).

#include "shapesense/core/geometry/timestamp.h"

#include <cstdint>
#include <limits>
#include <string>

#include <gtest/gtest.h>

namespace shapesense {
namespace {

TEST(ParseSecondsToNs, ExactAtEpochScale) {
  // Through a double this would come out ~100 ns off.
  EXPECT_EQ(parseSecondsToNs("1700000000.033333"),
            std::optional<TimestampNs>(1700000000033333000LL));
  EXPECT_EQ(parseSecondsToNs("1600000000.066667"),
            std::optional<TimestampNs>(1600000000066667000LL));
  EXPECT_EQ(parseSecondsToNs("1700000000.123456789"),
            std::optional<TimestampNs>(1700000000123456789LL));
  EXPECT_EQ(parseSecondsToNs("1700000000.999999999"),
            std::optional<TimestampNs>(1700000000999999999LL));
}

TEST(ParseSecondsToNs, WholeAndFractionForms) {
  EXPECT_EQ(parseSecondsToNs("0"), std::optional<TimestampNs>(0));
  EXPECT_EQ(parseSecondsToNs("1"), std::optional<TimestampNs>(1'000'000'000));
  EXPECT_EQ(parseSecondsToNs("1."), std::optional<TimestampNs>(1'000'000'000));
  EXPECT_EQ(parseSecondsToNs(".5"), std::optional<TimestampNs>(500'000'000));
  EXPECT_EQ(parseSecondsToNs("0.000000001"), std::optional<TimestampNs>(1));
  EXPECT_EQ(parseSecondsToNs("+2.5"), std::optional<TimestampNs>(2'500'000'000LL));
  EXPECT_EQ(parseSecondsToNs("1700000000"), std::optional<TimestampNs>(1700000000000000000LL));
}

TEST(ParseSecondsToNs, RoundsPastTheNinthDecimal) {
  EXPECT_EQ(parseSecondsToNs("0.0000000004"), std::optional<TimestampNs>(0));
  EXPECT_EQ(parseSecondsToNs("0.0000000005"), std::optional<TimestampNs>(1));
  EXPECT_EQ(parseSecondsToNs("0.0000000009"), std::optional<TimestampNs>(1));
  EXPECT_EQ(parseSecondsToNs("1.1234567894999"), std::optional<TimestampNs>(1'123'456'789));
  EXPECT_EQ(parseSecondsToNs("1.1234567895"), std::optional<TimestampNs>(1'123'456'790));
  // Rounding carries into the whole seconds.
  EXPECT_EQ(parseSecondsToNs("1.9999999995"), std::optional<TimestampNs>(2'000'000'000));
  EXPECT_EQ(parseSecondsToNs("1700000000.03333333333333"),
            std::optional<TimestampNs>(1700000000033333333LL));
  EXPECT_EQ(parseSecondsToNs("1700000000.03333333366666"),
            std::optional<TimestampNs>(1700000000033333334LL));
}

TEST(ParseSecondsToNs, RejectsGarbage) {
  for (const char* bad : {"",      "-",   "+",   ".",    "-.",  "abc", "12a",
                          "1.2.3", "1,5", " 1",  "1 ",   "1e9", "1E9", "1.5e3",
                          "0x10",  "--1", "+-1", "1.-5", "inf", "nan", "1700000000.0333x"}) {
    EXPECT_FALSE(parseSecondsToNs(bad).has_value()) << "'" << bad << "'";
  }
}

TEST(ParseSecondsToNs, RejectsOverflow) {
  // int64 nanoseconds reach 9223372036.854775807 s.
  EXPECT_FALSE(parseSecondsToNs("9223372037").has_value());
  EXPECT_FALSE(parseSecondsToNs("99999999999999999999").has_value());
  EXPECT_FALSE(parseSecondsToNs("99999999999999999999999999999999999999.5").has_value());
  EXPECT_FALSE(parseSecondsToNs("-99999999999999999999").has_value());
  // Far from the limit values still parse.
  EXPECT_EQ(parseSecondsToNs("4000000000.5"), std::optional<TimestampNs>(4000000000500000000LL));
}

TEST(ParseSecondsToNs, Negative) {
  EXPECT_EQ(parseSecondsToNs("-1"), std::optional<TimestampNs>(-1'000'000'000));
  EXPECT_EQ(parseSecondsToNs("-0.5"), std::optional<TimestampNs>(-500'000'000));
  EXPECT_EQ(parseSecondsToNs("-1700000000.033333"),
            std::optional<TimestampNs>(-1700000000033333000LL));
  EXPECT_EQ(parseSecondsToNs("-0"), std::optional<TimestampNs>(0));
}

TEST(FormatNsAsSeconds, DefaultSixDecimals) {
  EXPECT_EQ(formatNsAsSeconds(1700000000033333000LL), "1700000000.033333");
  EXPECT_EQ(formatNsAsSeconds(0), "0.000000");
  EXPECT_EQ(formatNsAsSeconds(1'000'000'000), "1.000000");
  EXPECT_EQ(formatNsAsSeconds(1600000000066666667LL), "1600000000.066667");
}

TEST(FormatNsAsSeconds, RoundsToTheRequestedDigits) {
  EXPECT_EQ(formatNsAsSeconds(1'499'999'999, 0), "1");
  EXPECT_EQ(formatNsAsSeconds(1'500'000'000, 0), "2");
  EXPECT_EQ(formatNsAsSeconds(1'999'999'999, 6), "2.000000");
  EXPECT_EQ(formatNsAsSeconds(1'000'000'499, 6), "1.000000");
  EXPECT_EQ(formatNsAsSeconds(1'000'000'500, 6), "1.000001");
  EXPECT_EQ(formatNsAsSeconds(1700000000123456789LL, 9), "1700000000.123456789");
  EXPECT_EQ(formatNsAsSeconds(1700000000123456789LL, 3), "1700000000.123");
  EXPECT_EQ(formatNsAsSeconds(5, 9), "0.000000005");
  // Out-of-range digit counts are clamped.
  EXPECT_EQ(formatNsAsSeconds(1700000000123456789LL, 12), "1700000000.123456789");
  EXPECT_EQ(formatNsAsSeconds(1'600'000'000, -3), "2");
}

TEST(FormatNsAsSeconds, Negative) {
  EXPECT_EQ(formatNsAsSeconds(-1'500'000'000, 6), "-1.500000");
  EXPECT_EQ(formatNsAsSeconds(-1700000000033333000LL, 6), "-1700000000.033333");
  EXPECT_EQ(formatNsAsSeconds(std::numeric_limits<std::int64_t>::min(), 9),
            "-9223372036.854775808");
  EXPECT_EQ(formatNsAsSeconds(std::numeric_limits<std::int64_t>::max(), 9), "9223372036.854775807");
}

TEST(TimestampRoundTrip, FormatThenParseIsExactAtNineDigits) {
  for (TimestampNs ns :
       {TimestampNs{0}, TimestampNs{1}, TimestampNs{999'999'999},
        TimestampNs{1700000000033333000LL}, TimestampNs{1700000000123456789LL}, TimestampNs{-42},
        TimestampNs{-1700000000000000001LL}, TimestampNs{9000000000999999999LL}}) {
    const std::string text = formatNsAsSeconds(ns, 9);
    EXPECT_EQ(parseSecondsToNs(text), std::optional<TimestampNs>(ns)) << text;
  }
}

TEST(TimestampRoundTrip, ParseThenFormatReproducesTumText) {
  for (const char* text : {"1700000000.033333", "1600000000.000000", "1600000000.166667",
                           "1305031102.175304", "0.000001"}) {
    const auto ns = parseSecondsToNs(text);
    ASSERT_TRUE(ns.has_value()) << text;
    EXPECT_EQ(formatNsAsSeconds(*ns, 6), text);
  }
}

TEST(TimestampRoundTrip, MicrosecondStampsSurviveSixDigitFormatting) {
  // What TumRecordingWriter relies on: a microsecond-exact stamp formats and parses back.
  for (TimestampNs us = 1700000000000000LL; us < 1700000000000000LL + 2000; us += 37) {
    const TimestampNs ns = us * 1000;
    EXPECT_EQ(parseSecondsToNs(formatNsAsSeconds(ns, 6)), std::optional<TimestampNs>(ns));
  }
}

}  // namespace
}  // namespace shapesense
