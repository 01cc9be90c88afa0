#include "colmap_ext/util/union_find.h"

#include <gtest/gtest.h>

namespace colmap {
namespace {

TEST(DisjointSets, JoinsSets) {
  DisjointSets sets(5);
  EXPECT_TRUE(sets.Union(3, 4));
  EXPECT_TRUE(sets.Union(1, 4));
  EXPECT_FALSE(sets.Union(3, 1));
  EXPECT_EQ(sets.Find(4), 1);
  EXPECT_EQ(sets.Find(3), 1);
  EXPECT_EQ(sets.Find(0), 0);
  EXPECT_EQ(sets.Find(2), 2);
}

TEST(DisjointSets, LongChainIsFoundWithoutRecursion) {
  // The view graph of a video sequence: every frame matched to the next,
  // joined from the end, so that the last frame is a million steps from
  // the first.
  const int num_elements = 1000000;
  DisjointSets sets(num_elements);
  for (int element = num_elements - 1; element > 0; --element) {
    EXPECT_TRUE(sets.Union(element - 1, element));
  }
  EXPECT_EQ(sets.Find(num_elements - 1), 0);
  EXPECT_FALSE(sets.Union(0, num_elements / 2));
}

TEST(ConnectedComponentLabels, SmallestNodeLabelsItsComponent) {
  EXPECT_EQ(ConnectedComponentLabels(6, {{5, 2}, {4, 0}, {2, 3}}),
            (std::vector<int>{0, 1, 2, 2, 0, 2}));
  EXPECT_EQ(ConnectedComponentLabels(0, {}), std::vector<int>{});
}

}  // namespace
}  // namespace colmap
