#include "colmap_ext/merge/part_offers.h"

#include <gtest/gtest.h>

namespace colmap {
namespace {

// `n` view-graph edges between communities c1 < c2 (the images' ids do not
// matter here).
void AddEdges(const int c1, const int c2, const int n, CrossEdges* edges) {
  for (int i = 0; i < n; ++i) {
    (*edges)[{c1, c2}].emplace_back(100 * c1 + i, 100 * c2 + i);
  }
}

TEST(PlanPartOffers, NothingOfferedWhereEveryCommunityIsInOnePart) {
  CrossEdges edges;
  AddEdges(0, 1, 30, &edges);
  AddEdges(1, 2, 20, &edges);
  const PartOffers offers =
      PlanPartOffers({0, 0, 0}, {true, true, true}, edges);
  EXPECT_TRUE(offers.image_communities_of_part.empty());
}

TEST(PlanPartOffers, CommunityWithoutModelGoesWhereMostEdgesLead) {
  // Communities 0 and 1 form part 0, 2 is part 1; community 3 has no model
  // and more edges to part 1 (25) than to part 0 (10 + 10).
  CrossEdges edges;
  AddEdges(0, 1, 50, &edges);
  AddEdges(0, 3, 10, &edges);
  AddEdges(1, 3, 10, &edges);
  AddEdges(2, 3, 25, &edges);
  const PartOffers offers =
      PlanPartOffers({0, 0, 1, -1}, {true, true, true, false}, edges);
  EXPECT_EQ(offers.image_communities_of_part.at(1), std::vector<int>({3}));
  EXPECT_EQ(offers.image_communities_of_part.count(0), 0);
}

TEST(PlanPartOffers, UnjoinedPartGoesToAnEarlierPartAndOnward) {
  // Parts 0 {0}, 1 {1}, 2 {2, 3}: no kept similarity between them. Part 2
  // has more edges to part 1 than to part 0, part 1 to part 0: part 2 is
  // offered to part 1 and, through it, to part 0; part 1 to part 0.
  CrossEdges edges;
  AddEdges(0, 1, 40, &edges);
  AddEdges(0, 2, 5, &edges);
  AddEdges(1, 3, 30, &edges);
  AddEdges(2, 3, 60, &edges);
  const PartOffers offers =
      PlanPartOffers({0, 1, 2, 2}, {true, true, true, true}, edges);
  EXPECT_EQ(offers.image_communities_of_part.at(1), std::vector<int>({2, 3}));
  EXPECT_EQ(offers.image_communities_of_part.at(0),
            std::vector<int>({1, 2, 3}));
  EXPECT_EQ(offers.image_communities_of_part.count(2), 0);
}

TEST(PlanPartOffers, PartsWithoutEdgesStayApart) {
  // Two components of the view graph: nothing to offer across.
  CrossEdges edges;
  AddEdges(0, 1, 40, &edges);
  AddEdges(2, 3, 40, &edges);
  const PartOffers offers =
      PlanPartOffers({0, 0, 1, 1}, {true, true, true, true}, edges);
  EXPECT_TRUE(offers.image_communities_of_part.empty());
}

TEST(PlanPartOffers, EdgesOfCommunitiesWithoutModelsDoNotJoinParts) {
  // Parts 0 {0} and 1 {2} are linked only through community 1, which has
  // no model: its images go to part 0 (more edges); part 1 is not offered.
  CrossEdges edges;
  AddEdges(0, 1, 30, &edges);
  AddEdges(1, 2, 20, &edges);
  const PartOffers offers =
      PlanPartOffers({0, -1, 1}, {true, false, true}, edges);
  EXPECT_EQ(offers.image_communities_of_part.at(0), std::vector<int>({1}));
  EXPECT_EQ(offers.image_communities_of_part.count(1), 0);
}

}  // namespace
}  // namespace colmap
