// SPDX-License-Identifier: GPL-3.0-or-later
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "metron/stdlib/fitting/point_file.hpp"

namespace metron::fitting {
namespace {

/// A file in the temporary directory, removed at the end of the test.
class TempFile {
 public:
  explicit TempFile(const std::string& contents) {
    static int counter = 0;
    m_path = std::filesystem::temp_directory_path() /
             ("metron_point_file_" + std::to_string(std::random_device{}()) + "_" + std::to_string(counter++) + ".txt");
    std::ofstream(m_path, std::ios::binary) << contents;
  }
  ~TempFile() {
    std::error_code ec;
    std::filesystem::remove(m_path, ec);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  [[nodiscard]] std::string path() const { return m_path.string(); }

 private:
  std::filesystem::path m_path;
};

TEST(PointFile, NistLayoutWithTabsAndCrlf) {
  const auto pts = parse_point_text("3\r\n1.5\t-2\t3e2\r\n0 0 0\r\n\r\n-1e-3   +4 5\r\n");
  ASSERT_TRUE(pts) << pts.error().message;
  ASSERT_EQ(pts->size(), 3u);
  EXPECT_EQ((*pts)[0], Vec3(1.5, -2, 300));
  EXPECT_EQ((*pts)[2], Vec3(-1e-3, 4, 5));
}

TEST(PointFile, CsvWithHeaderAndBlankLines) {
  const TempFile file("x,y,z\n\n1, 2, 3\n4,5,6\n\n");
  const auto pts = read_point_file(file.path());
  ASSERT_TRUE(pts) << pts.error().message;
  ASSERT_EQ(pts->size(), 2u);
  EXPECT_EQ((*pts)[1], Vec3(4, 5, 6));
}

TEST(PointFile, CountBeforeCsvRecords) {
  const auto pts = parse_point_text("2\n1,2,3\n4,5,6\n");
  ASSERT_TRUE(pts) << pts.error().message;
  EXPECT_EQ(pts->size(), 2u);
}

TEST(PointFile, PlainXyzWithoutCount) {
  auto pts = parse_point_text("1 2 3\n4 5 6");
  ASSERT_TRUE(pts);
  EXPECT_EQ(pts->size(), 2u);
  pts = parse_point_text("XYZ\n1 2 3\n");
  ASSERT_TRUE(pts) << pts.error().message;
  EXPECT_EQ(pts->size(), 1u);
}

TEST(PointFile, ErrorsNameTheRecord) {
  auto e = parse_point_text("3\n1 2 3\n4 5 6\n\n\n7 8\n");
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().message, "line 6: expected 3 numbers, got 2");
  EXPECT_EQ(e.error().line, 6u);

  e = parse_point_text("40\n1 2 3\n4 5 6\n");
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().message, "declared 40 points but found 2");
  EXPECT_EQ(e.error().line, 1u);

  e = parse_point_text("1\n1 2 3\n4 5 6\n");
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().message, "declared 1 points but found 2");

  e = parse_point_text("x,y,z\n1,2,3\n1,two,3\n");
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().message, "line 3: 'two' is not a number");

  e = parse_point_text("1,2,3,4\n");
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().message, "line 1: expected 3 numbers, got 4");

  const auto tiny = parse_point_text("1e-999 0 0\n");
  ASSERT_TRUE(tiny);
  EXPECT_EQ((*tiny)[0].x(), 0.0);

  e = parse_point_text("2.5\n1 2 3\n");
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().line, 1u);
}

TEST(PointFile, NonFiniteCoordinatesAreErrors) {
  for (const char* text : {"1 nan 3\n", "2\n1 2 3\ninf 0 0\n", "1,2,-inf\n", "1 2 1e999\n"}) {
    const auto e = parse_point_text(text);
    ASSERT_FALSE(e) << text;
    EXPECT_NE(e.error().message.find("not finite"), std::string::npos) << e.error().message;
  }
}

TEST(PointFile, MissingEmptyAndDirectory) {
  auto e = read_point_file("/nonexistent/metron/points.ds");
  ASSERT_FALSE(e);
  EXPECT_NE(e.error().message.find("cannot open"), std::string::npos);
  EXPECT_EQ(e.error().line, 0u);
  EXPECT_FALSE(parse_point_text(""));
  EXPECT_FALSE(parse_point_text("\n\n  \n"));
  EXPECT_FALSE(read_point_file(std::filesystem::temp_directory_path().string()));
  const auto zero = parse_point_text("0\n");
  ASSERT_TRUE(zero);
  EXPECT_TRUE(zero->empty());
}

TEST(PointFile, RandomBytesNeverCrash) {
  std::mt19937 rng(2024);
  std::uniform_int_distribution<int> byte(0, 255);
  const std::string alphabet = "0123456789 .,-+eE\n\t\rnaif";
  std::uniform_int_distribution<std::size_t> pick(0, alphabet.size() - 1);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string text;
    const int length = trial % 97;
    for (int i = 0; i < length; ++i) text += trial % 2 ? static_cast<char>(byte(rng)) : alphabet[pick(rng)];
    const auto r = parse_point_text(text);
    if (!r) {
      EXPECT_FALSE(r.error().message.empty());
    } else {
      for (const Vec3& p : *r) EXPECT_TRUE(p.allFinite());
    }
  }
}

TEST(PointFile, ReadsEveryNistSet) {
  const std::filesystem::path dir = std::filesystem::path(METRON_SHARED_DATA) / "nist-fitting";
  if (!std::filesystem::is_directory(dir)) GTEST_SKIP() << "NIST reference data not found at " << dir.string();
  int files = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (entry.path().extension() != ".ds") continue;
    const auto pts = read_point_file(entry.path().string());
    ASSERT_TRUE(pts) << entry.path() << ": " << pts.error().message;
    EXPECT_GE(pts->size(), 4u) << entry.path();
    ++files;
  }
  EXPECT_EQ(files, 120);
}

}  // namespace
}  // namespace metron::fitting
