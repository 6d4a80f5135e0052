// `--at T` parsing of the shapesense CLI.

#include "time_arg.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <CLI/CLI.hpp>

namespace shapesense::cli {
namespace {

TEST(TimeArgument, SecondsAreExactNanoseconds) {
  EXPECT_EQ(parseTimeArgument("1700000000.033333"), 1700000000033333000LL);
  EXPECT_EQ(parseTimeArgument("1600000000.066667"), 1600000000066667000LL);
  EXPECT_EQ(parseTimeArgument("1700000000.123456789"), 1700000000123456789LL);
  EXPECT_EQ(parseTimeArgument("1700000000"), 1700000000000000000LL);
  EXPECT_EQ(parseTimeArgument("0.5"), 500'000'000);
}

TEST(TimeArgument, LatestNowAndEmptyMeanTheNewest) {
  EXPECT_EQ(parseTimeArgument("latest"), 0);
  EXPECT_EQ(parseTimeArgument("now"), 0);
  EXPECT_EQ(parseTimeArgument(""), 0);
  EXPECT_EQ(parseTimeArgument("0"), 0);
}

TEST(TimeArgument, RejectsNonTimesNamingTheText) {
  for (const char* bad : {"yesterday", "1e9", "-1", "-0.5", "1700000000.03x", "LATEST", " 1", "1,5",
                          "99999999999999999999"}) {
    try {
      parseTimeArgument(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const CLI::ValidationError& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(std::string("'") + bad + "'"));
    }
  }
}

}  // namespace
}  // namespace shapesense::cli
