#include "colmap_ext/workflow/community_io.h"

#include "colmap/util/file.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"

#include <algorithm>
#include <numeric>
#include <sstream>

namespace colmap {

std::string CommunitiesToText(const ViewGraph& view_graph,
                              const CommunityPartition& partition,
                              const double modularity_threshold,
                              const ViewGraphEdgeWeight edge_weight) {
  THROW_CHECK_EQ(partition.membership.size(), view_graph.NumVertices());
  std::ostringstream text;
  text << "# Communities of the view graph (CSfM, community_mapper)\n";
  text << StringPrintf(
      "# View graph: %d images, %d edges (%s weights), %d connected "
      "components\n",
      static_cast<int>(view_graph.NumVertices()),
      static_cast<int>(view_graph.NumEdges()),
      ViewGraphEdgeWeightToString(edge_weight).c_str(),
      partition.num_components);
  text << StringPrintf(
      "# Splits (Qmax > %.3f splits a graph, as does holding more than its "
      "share of the component (balance); depth 0 is a whole component):\n",
      modularity_threshold);
  for (const CommunityPartition::Split& split : partition.splits) {
    text << StringPrintf(
        "#   depth %d: %d images, Qmax %.4f, %d parts (largest conductance "
        "%.3f), %s\n",
        split.depth,
        split.num_vertices,
        split.modularity,
        split.num_parts,
        split.max_part_conductance,
        split.balance    ? "split (balance)"
        : split.accepted ? "split"
                         : "not split");
  }
  const std::vector<std::vector<int>> communities = partition.Communities();
  text << StringPrintf(
      "# %d communities (%d before merging small ones), sizes:",
      static_cast<int>(communities.size()),
      partition.num_communities_before_merge);
  for (const auto& community : communities) {
    text << " " << community.size();
  }
  text << "\n# IMAGE_NAME COMMUNITY_ID\n";

  std::vector<int> order(view_graph.NumVertices());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return view_graph.ImageNames()[a] < view_graph.ImageNames()[b];
  });
  for (const int vertex : order) {
    text << view_graph.ImageNames()[vertex] << " "
         << partition.membership[vertex] << "\n";
  }
  return text.str();
}

std::string ReadImageList(const std::string& path,
                          std::vector<std::string>* names) {
  names->clear();
  if (!ExistsFile(path)) {
    return "The image list " + path +
           " does not exist. Check --image_list_path: a text file with one "
           "image name per line, as in the database.";
  }
  *names = ReadTextFileLines(path);  // Trimmed, without empty lines.
  if (names->empty()) {
    return "The image list " + path +
           " names no image: give one image name per line.";
  }
  std::sort(names->begin(), names->end());
  names->erase(std::unique(names->begin(), names->end()), names->end());
  return "";
}

Eigen::Vector3ub CommunityColor(const int community_id) {
  // Tableau's 10 colours, then darker and lighter variants.
  static const uint8_t kPalette[10][3] = {{31, 119, 180},
                                          {255, 127, 14},
                                          {44, 160, 44},
                                          {214, 39, 40},
                                          {148, 103, 189},
                                          {140, 86, 75},
                                          {227, 119, 194},
                                          {127, 127, 127},
                                          {188, 189, 34},
                                          {23, 190, 207}};
  if (community_id < 0) {
    return Eigen::Vector3ub(160, 160, 160);
  }
  const uint8_t* color = kPalette[community_id % 10];
  const double factor = 1.0 - 0.3 * ((community_id / 10) % 3);
  return Eigen::Vector3ub(static_cast<uint8_t>(color[0] * factor),
                          static_cast<uint8_t>(color[1] * factor),
                          static_cast<uint8_t>(color[2] * factor));
}

std::string CommunityCamerasToPly(
    const Reconstruction& reconstruction,
    const std::unordered_map<image_t, int>& community_of_image) {
  std::vector<image_t> image_ids = reconstruction.RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  std::ostringstream text;
  text << "ply\nformat ascii 1.0\n";
  text << "comment camera centres coloured by community (community_mapper)\n";
  text << "element vertex " << image_ids.size() << "\n";
  text << "property float x\nproperty float y\nproperty float z\n";
  text << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  text << "end_header\n";
  for (const image_t image_id : image_ids) {
    const Eigen::Vector3d center =
        reconstruction.Image(image_id).ProjectionCenter();
    const auto it = community_of_image.find(image_id);
    const Eigen::Vector3ub color =
        CommunityColor(it == community_of_image.end() ? -1 : it->second);
    text << StringPrintf("%.6f %.6f %.6f %d %d %d\n",
                         center.x(),
                         center.y(),
                         center.z(),
                         color(0),
                         color(1),
                         color(2));
  }
  return text.str();
}

}  // namespace colmap
