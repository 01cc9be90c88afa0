// The files through which users inspect a partition.
//
// communities.txt: a comment header (view-graph size, every split with its
// peak modularity, community sizes), then one line per image of the view
// graph, "IMAGE_NAME COMMUNITY_ID", community ids 0..K-1 with the largest
// community first, images sorted by name.
//
// Image lists (--image_list_path of community_mapper and model_evaluator,
// as COLMAP's): one image name per line, as in the database.
//
// communities.ply: the camera centres of a model as coloured vertices, one
// colour per community (COLMAP's GUI imports it with File > Import; MeshLab
// and CloudCompare open it too).

#pragma once

#include "colmap_ext/partition/community_detection.h"
#include "colmap_ext/partition/view_graph.h"

#include "colmap/scene/reconstruction.h"

#include <string>
#include <unordered_map>
#include <vector>

namespace colmap {

std::string CommunitiesToText(const ViewGraph& view_graph,
                              const CommunityPartition& partition,
                              double modularity_threshold,
                              ViewGraphEdgeWeight edge_weight);

// Reads an image list into its distinct names, sorted, each without the
// blanks around it; empty lines are skipped. Returns the problem, for the
// user (empty if none): a missing file, or one that names no image.
std::string ReadImageList(const std::string& path,
                          std::vector<std::string>* names);

// A distinct, stable colour per community id.
Eigen::Vector3ub CommunityColor(int community_id);

// The registered images' camera centres, coloured by community (images
// without a community are grey), as an ASCII PLY text.
std::string CommunityCamerasToPly(
    const Reconstruction& reconstruction,
    const std::unordered_map<image_t, int>& community_of_image);

}  // namespace colmap
