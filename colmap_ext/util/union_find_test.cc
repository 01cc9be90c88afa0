#include "colmap_ext/util/union_find.h"

#include <gtest/gtest.h>

namespace colmap {
namespace {

TEST(UnionFind, JoinsSets) {
  UnionFind sets(5);
  EXPECT_TRUE(sets.Union(3, 4));
  EXPECT_TRUE(sets.Union(1, 4));
  EXPECT_FALSE(sets.Union(3, 1));
  EXPECT_EQ(sets.Find(4), 1);
  EXPECT_EQ(sets.Find(3), 1);
  EXPECT_EQ(sets.Find(0), 0);
  EXPECT_EQ(sets.Find(2), 2);
}

TEST(ConnectedComponentLabels, SmallestNodeLabelsItsComponent) {
  EXPECT_EQ(ConnectedComponentLabels(6, {{5, 2}, {4, 0}, {2, 3}}),
            (std::vector<int>{0, 1, 2, 2, 0, 2}));
  EXPECT_EQ(ConnectedComponentLabels(0, {}), std::vector<int>{});
}

}  // namespace
}  // namespace colmap
