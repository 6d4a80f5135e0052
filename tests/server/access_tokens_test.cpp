// The token file: its format, its refusals, and the role each method needs.

#include "shapesense/server/access_tokens.h"

#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_paths.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string parseError(const std::string& text) {
  try {
    AccessTokens::parse(text, "tokens");
    return "";
  } catch (const std::runtime_error& e) {
    return e.what();
  }
}

TEST(AccessTokens, ParsesNamesRolesAndTokensAndIgnoresComments) {
  const AccessTokens tokens = AccessTokens::parse(
      "# clients of the robot\n\n  robot read aaaaaaaaaaaaaaaa  \nops\trecord bbbbbbbbbbbbbbbbbb # "
      "x\n",
      "tokens");
  ASSERT_EQ(tokens.size(), 2u);
  const auto robot = tokens.find("aaaaaaaaaaaaaaaa");
  ASSERT_TRUE(robot);
  EXPECT_EQ(robot->name, "robot");
  EXPECT_EQ(robot->role, Role::kRead);
  const auto ops = tokens.find("bbbbbbbbbbbbbbbbbb");
  ASSERT_TRUE(ops);
  EXPECT_EQ(ops->role, Role::kRecord);
  EXPECT_FALSE(tokens.find("aaaaaaaaaaaaaaa"));    // a prefix
  EXPECT_FALSE(tokens.find("aaaaaaaaaaaaaaaaa"));  // longer
  EXPECT_FALSE(tokens.find(""));
}

TEST(AccessTokens, RefusesMalformedFiles) {
  EXPECT_THAT(parseError(""), HasSubstr("holds no token"));
  EXPECT_THAT(parseError("# only a comment\n"), HasSubstr("holds no token"));
  EXPECT_THAT(parseError("robot read\n"), HasSubstr("line 1: expected NAME ROLE TOKEN"));
  EXPECT_THAT(parseError("\nrobot read aaaaaaaaaaaaaaaa extra\n"), HasSubstr("line 2"));
  EXPECT_THAT(parseError("robot admin aaaaaaaaaaaaaaaa\n"),
              HasSubstr("role must be read or record"));
  EXPECT_THAT(parseError("robot read short\n"), HasSubstr("at least 16"));
  EXPECT_THAT(parseError("a read aaaaaaaaaaaaaaaa\nb record aaaaaaaaaaaaaaaa\n"),
              HasSubstr("line 2: token repeated"));
}

TEST(AccessTokens, LoadRefusesAFileGroupOrOthersCanRead) {
  const fs::path file = testing::scratchDir("access_tokens") / "tokens";
  std::ofstream(file) << "robot read aaaaaaaaaaaaaaaa\n";
  fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(AccessTokens::load(file).size(), 1u);
  for (const auto extra : {fs::perms::group_read, fs::perms::others_read, fs::perms::group_write}) {
    fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write | extra);
    try {
      AccessTokens::load(file);
      ADD_FAILURE() << "loaded with mode " << static_cast<int>(extra);
    } catch (const std::runtime_error& e) {
      EXPECT_THAT(e.what(), HasSubstr("group or others may read it"));
    }
  }
  EXPECT_THROW(AccessTokens::load(file.parent_path() / "missing"), std::runtime_error);
  EXPECT_THROW(AccessTokens::load(file.parent_path()), std::runtime_error);  // a directory
}

TEST(AccessTokens, ClientTokenIsTheFirstLineThatIsNotACommentOrBlank) {
  const fs::path dir = testing::scratchDir("access_tokens_client");
  std::ofstream(dir / "token") << "# for the robot\n\n  abcdefabcdefabcdef  \nignored\n";
  EXPECT_EQ(readClientToken(dir / "token"), "abcdefabcdefabcdef");
  std::ofstream(dir / "empty") << "# nothing\n";
  EXPECT_THROW(readClientToken(dir / "empty"), std::runtime_error);
}

TEST(AccessTokens, OnlyRecordAndTeachObjectNeedTheRecordRoleAndUnknownMethodsDoToo) {
  EXPECT_EQ(requiredRole("/shapesense.v1.ShapeSense/Record"), Role::kRecord);
  // It writes a model file.
  EXPECT_EQ(requiredRole("/shapesense.v1.ShapeSense/TeachObject"), Role::kRecord);
  for (const char* method :
       {"/shapesense.v1.ShapeSense/GetStatus", "/shapesense.v1.ShapeSense/Watch",
        "/shapesense.v1.ShapeSense/EstimateBox", "/shapesense.v1.ShapeSense/GetBowls",
        "/shapesense.v1.ShapeSense/ListObjectModels", "/shapesense.v1.ShapeSense/FindObjects",
        "/grpc.health.v1.Health/Check"}) {
    EXPECT_EQ(requiredRole(method), Role::kRead) << method;
  }
  EXPECT_EQ(requiredRole("/shapesense.v1.ShapeSense/SomethingNew"), Role::kRecord);
  EXPECT_TRUE(allows(Role::kRecord, Role::kRead));
  EXPECT_TRUE(allows(Role::kRecord, Role::kRecord));
  EXPECT_TRUE(allows(Role::kRead, Role::kRead));
  EXPECT_FALSE(allows(Role::kRead, Role::kRecord));
}

}  // namespace
}  // namespace shapesense
