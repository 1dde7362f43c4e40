// Tests of frame patterns and frame ranges.
#include <gtest/gtest.h>

#include <fstream>

#include "meniscus/errors.hpp"
#include "meniscus/sequence.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

TEST(FramePattern, HashesBracesAndPrintf) {
  auto p = parse_frame_pattern("sim/fluid_####.bgeo");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->format(7), "sim/fluid_0007.bgeo");
  EXPECT_EQ(p->format(12345), "sim/fluid_12345.bgeo");
  p = parse_frame_pattern("out/mesh_{}.ply");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->format(42), "out/mesh_42.ply");
  p = parse_frame_pattern("f_%04d.ply");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->format(3), "f_0003.ply");
  p = parse_frame_pattern("f_%d.ply");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->format(3), "f_3.ply");
  EXPECT_FALSE(parse_frame_pattern("plain.ply"));
  EXPECT_FALSE(parse_frame_pattern("dir#1/plain.ply"));  // placeholders only count in the name
  EXPECT_FALSE(parse_frame_pattern("100%.ply"));
}

TEST(FramePattern, MatchesOnlyItsOwnNames) {
  const auto p = parse_frame_pattern("a/f_####.ply");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->match("a/f_0012.ply"), 12);
  EXPECT_EQ(p->match("a/f_12345.ply"), 12345);
  EXPECT_FALSE(p->match("a/f_12.ply"));     // not padded to 4
  EXPECT_FALSE(p->match("a/f_0012.bgeo"));
  EXPECT_FALSE(p->match("a/f_00x2.ply"));
}

TEST(FrameRanges, ParsesRangesStepsAndLists) {
  EXPECT_EQ(parse_frame_ranges("1-5"), (std::vector<int>{1, 2, 3, 4, 5}));
  EXPECT_EQ(parse_frame_ranges("1-9:4"), (std::vector<int>{1, 5, 9}));
  EXPECT_EQ(parse_frame_ranges("3,1-2,3"), (std::vector<int>{3, 1, 2}));
  EXPECT_EQ(parse_frame_ranges("-2-1"), (std::vector<int>{-2, -1, 0, 1}));
  for (const char* bad : {"", "a-b", "5-1", "1-5:0", "1-", "1,,2", "0-2000000000"})
    EXPECT_THROW(parse_frame_ranges(bad), InvalidParameter) << bad;
}

TEST(FramePattern, DiscoversTheFramesOnDisk) {
  test::TempDir tmp;
  for (int f : {3, 1, 10}) std::ofstream(tmp.file("p_" + std::to_string(1000 + f).substr(1) + ".ply")) << "x";
  std::ofstream(tmp.file("p_abc.ply")) << "x";
  std::ofstream(tmp.file("other_001.ply")) << "x";
  const auto p = parse_frame_pattern(tmp.file("p_###.ply"));
  ASSERT_TRUE(p);
  EXPECT_EQ(discover_frames(*p), (std::vector<int>{1, 3, 10}));
}

TEST(FrameRanges, FormatsRunsThatParseBack) {
  EXPECT_EQ(format_frame_ranges({}), "");
  EXPECT_EQ(format_frame_ranges({7}), "7");
  EXPECT_EQ(format_frame_ranges({1, 2, 3, 4, 7}), "1-4,7");
  EXPECT_EQ(format_frame_ranges({3, 5, 6, 10}), "3,5-6,10");
  for (const std::vector<int>& frames : {std::vector<int>{1, 2, 3, 9, 10, 12}, std::vector<int>{40, 41, 2}})
    EXPECT_EQ(parse_frame_ranges(format_frame_ranges(frames)), frames);
}

}  // namespace
}  // namespace meniscus
