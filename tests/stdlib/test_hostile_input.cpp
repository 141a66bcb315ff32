// SPDX-License-Identifier: GPL-3.0-or-later
// The input-file and JSON defences of docs/security.md (issue 15).
#include <gtest/gtest.h>

#include "scratch.hpp"

#include <filesystem>
#include <fstream>

#include <unistd.h>

#include "metron/stdlib/file_access.hpp"
#include "metron/stdlib/geometry/mesh.hpp"
#include "metron/stdlib/json_reader.hpp"

namespace {
namespace fs = std::filesystem;

TEST(HostileInput, ReadInputFileRefusesDevicesDirectoriesAndHugeFiles) {
  EXPECT_NE(metron::read_input_file("/dev/zero").error().find("not a regular file"), std::string::npos);
  EXPECT_NE(metron::read_input_file("/tmp").error().find("is a directory"), std::string::npos);
  EXPECT_NE(metron::read_input_file("/no/such/file").error().find("no such file"), std::string::npos);
  const fs::path p = metron::test_support::scratch_root("metron_hostile_input") / "big";
  std::ofstream(p) << std::string(2000, 'x');
  EXPECT_NE(metron::read_input_file(p.string(), 1000).error().find("exceeds the limit of 1000 bytes"),
            std::string::npos);
  EXPECT_EQ(metron::read_input_file(p.string(), 2000)->size(), 2000u);
  fs::remove(p);
}

TEST(HostileInput, CadReadersRefuseDevicesBeforeTheLibraryReadsThem) {
  // Before: CGAL and OCCT read whatever the path named; /dev/zero linked in as part.stl never ended.
  const fs::path d = metron::test_support::scratch_root("metron_hostile_input") / "cad";
  fs::remove_all(d);
  fs::create_directories(d);
  for (const char* name : {"zero.stl", "zero.off", "zero.step"}) {
    fs::create_symlink("/dev/zero", d / name);
    const auto mesh = metron::geometry::load_mesh((d / name).string());
    ASSERT_FALSE(mesh) << name;
    EXPECT_NE(mesh.error().message.find("not a regular file"), std::string::npos) << mesh.error().message;
  }
  EXPECT_NE(metron::refuse_input_file(d.string()).value_or("").find("is a directory"), std::string::npos);
  EXPECT_NE(metron::refuse_input_file("/no/such.stl").value_or("").find("no such file"), std::string::npos);
  fs::remove_all(d);
}

TEST(HostileInput, JsonNumbersOutOfRangeAndDeepNestingAreErrorsNotCrashes) {
  // Before: 1e400 aborted with an uncaught exception; 70k levels overflowed the stack.
  const auto big = metron::strict_json::parse_document(R"({"machine": {"dt_s": 1e400}})");
  ASSERT_FALSE(big);
  EXPECT_NE(big.error().find("number overflow"), std::string::npos) << big.error();
  const auto deep = metron::strict_json::parse_document(std::string(70'000, '[') + std::string(70'000, ']'));
  ASSERT_FALSE(deep);
  EXPECT_NE(deep.error().find("nested more than 256 levels"), std::string::npos) << deep.error();
  // Brackets inside strings and comments do not count.
  EXPECT_TRUE(metron::strict_json::parse_document("// [[[[\n{\"a\": \"" + std::string(1000, '[') + "\"}"));
  EXPECT_TRUE(metron::strict_json::parse_document(std::string(200, '[') + std::string(200, ']')));
}

TEST(HostileInput, PolicyResolvesDotDotAndSymlinks) {
  const fs::path d = metron::test_support::scratch_root("metron_hostile_input") / "policy";
  fs::remove_all(d);
  fs::create_directories(d / "prog" / "sub");
  fs::create_directories(d / "out");
  const metron::FileAccessPolicy policy({(d / "prog").string()}, (d / "out").string());
  EXPECT_FALSE(policy.refuse_read((d / "prog" / "sub" / "a.dmi").string()));
  EXPECT_TRUE(policy.refuse_read((d / "prog" / ".." / "x.dmi").string()));
  EXPECT_TRUE(policy.refuse_read("/etc/passwd"));
  EXPECT_TRUE(policy.refuse_read((d / "prog2" / "a.dmi").string()));  // a prefix is not a folder
  EXPECT_FALSE(policy.refuse_write((d / "out" / "c.json").string()));
  EXPECT_TRUE(policy.refuse_write((d / "out" / ".." / "c.json").string()));
  EXPECT_TRUE(policy.refuse_write((d / "out").string()));
  fs::create_symlink("/etc", d / "prog" / "etc");
  EXPECT_TRUE(policy.refuse_read((d / "prog" / "etc" / "passwd").string()));
  fs::remove_all(d);
}

TEST(HostileInput, Utf8AndPrintable) {
  EXPECT_EQ(metron::valid_utf8("caf\xe9"), "caf\xef\xbf\xbd");
  EXPECT_EQ(metron::valid_utf8("caf\xc3\xa9"), "caf\xc3\xa9");
  EXPECT_EQ(metron::valid_utf8("\xc0\xaf"), "\xef\xbf\xbd\xef\xbf\xbd");                  // overlong '/'
  EXPECT_EQ(metron::valid_utf8("\xed\xa0\x80"), "\xef\xbf\xbd\xef\xbf\xbd\xef\xbf\xbd");  // a surrogate
  EXPECT_EQ(metron::printable("a\x1b[31mb"), "a\\x1b[31mb");
  EXPECT_EQ(metron::printable(std::string(300, 'x'), 10), "xxxxxxxxxx...");
}

}  // namespace
