#include "colmap_ext/sfm/unexplained_matches.h"

#include "colmap_ext/util/union_find.h"

#include <algorithm>
#include <unordered_map>
#include <unordered_set>

namespace colmap {

std::vector<image_t> FindImagesApartFromTheirMatches(
    const Reconstruction& reconstruction,
    const CorrespondenceGraph& correspondence_graph) {
  const std::vector<image_t> reg_image_ids = reconstruction.RegImageIds();
  std::unordered_map<image_t, int> index_of_image;
  for (size_t i = 0; i < reg_image_ids.size(); ++i) {
    index_of_image.emplace(reg_image_ids[i], static_cast<int>(i));
  }

  // Per pair of registered images: matches whose two keypoints observe 3D
  // points, and of those the ones that observe the same point. Each pair is
  // counted from its image of the smaller id, once over all
  // correspondences.
  struct PairCounts {
    int num_observed = 0;
    int num_same_point = 0;
  };
  std::unordered_map<image_pair_t, PairCounts> counts;
  for (const image_t image_id1 : reg_image_ids) {
    if (!correspondence_graph.ExistsImage(image_id1)) {
      continue;
    }
    const Image& image1 = reconstruction.Image(image_id1);
    for (point2D_t point2D_idx1 = 0; point2D_idx1 < image1.NumPoints2D();
         ++point2D_idx1) {
      const Point2D& point2D1 = image1.Point2D(point2D_idx1);
      if (!point2D1.HasPoint3D()) {
        continue;
      }
      const CorrespondenceGraph::CorrespondenceRange range =
          correspondence_graph.FindCorrespondences(image_id1, point2D_idx1);
      for (const CorrespondenceGraph::Correspondence* corr = range.beg;
           corr < range.end;
           ++corr) {
        if (corr->image_id <= image_id1 ||
            index_of_image.count(corr->image_id) == 0) {
          continue;
        }
        const Point2D& point2D2 =
            reconstruction.Image(corr->image_id).Point2D(corr->point2D_idx);
        if (!point2D2.HasPoint3D()) {
          continue;
        }
        PairCounts& pair_counts =
            counts[ImagePairToPairId(image_id1, corr->image_id)];
        ++pair_counts.num_observed;
        if (point2D2.point3D_id == point2D1.point3D_id) {
          ++pair_counts.num_same_point;
        }
      }
    }
  }

  DisjointSets groups(static_cast<int>(reg_image_ids.size()));
  for (const auto& [pair_id, pair_counts] : counts) {
    if (2 * pair_counts.num_same_point > pair_counts.num_observed) {
      const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
      groups.Union(index_of_image.at(image_id1), index_of_image.at(image_id2));
    }
  }
  std::unordered_map<int, int> group_sizes;
  for (size_t i = 0; i < reg_image_ids.size(); ++i) {
    ++group_sizes[groups.Find(static_cast<int>(i))];
  }
  // The largest group (ties: the one of the smallest index, as the groups'
  // representatives are their smallest elements).
  int largest = -1;
  int largest_size = 0;
  for (const auto& [group, size] : group_sizes) {
    if (size > largest_size || (size == largest_size && group < largest)) {
      largest = group;
      largest_size = size;
    }
  }
  // A group is apart where pairs join it to the largest group, none of them
  // explained (else they would be one group): its matches place it
  // elsewhere. A group that no pair with observed matches joins to the
  // largest (a weak link whose images lost their points) says nothing
  // against its place.
  std::unordered_set<int> contradicted_groups;
  for (const auto& [pair_id, pair_counts] : counts) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    const int group1 = groups.Find(index_of_image.at(image_id1));
    const int group2 = groups.Find(index_of_image.at(image_id2));
    if (group1 == largest && group2 != largest) {
      contradicted_groups.insert(group2);
    } else if (group2 == largest && group1 != largest) {
      contradicted_groups.insert(group1);
    }
  }
  std::vector<image_t> apart;
  for (size_t i = 0; i < reg_image_ids.size(); ++i) {
    if (contradicted_groups.count(groups.Find(static_cast<int>(i)))) {
      apart.push_back(reg_image_ids[i]);
    }
  }
  std::sort(apart.begin(), apart.end());
  return apart;
}

}  // namespace colmap
