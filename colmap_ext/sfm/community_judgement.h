// Judging a community's own model before the merge trusts it.
//
// A community is reconstructed from a part of the view graph only, and a
// part can be badly conditioned on its own: a short stretch of a walkway
// along a flat wall, a chain with little overlap. Its incremental mapper
// then bends the model, breaks it into pieces or leaves images out, and one
// similarity per community cannot align such a model to all its neighbours.
// The mapper's own result tells the likely cases, relative to the other
// communities of the same run (the same images, matcher and options):
//   - doubtful: it registered a smaller fraction of the images it was given
//     (in its largest model, if it broke into several) than
//     `min_registered_fraction` times the median fraction of all
//     communities (where every community leaves many images out, as along a
//     walkway of flat walls, that is the data, not one community's
//     failure). A doubtful community takes part with little weight; the
//     similarity averaging drops it where its similarities disagree with
//     the others (similarity_averaging.h).
//   - broken: its mean reprojection error exceeds
//     `max_relative_reprojection_error` times the median of the
//     communities' means. The same data fitted so much worse means wrong
//     matches or a wrong geometry inside the model: it leaves the merge,
//     and the merged model registers its images. On a generated courtyard
//     loop such a community, kept in the merge, left the merged model's
//     cameras metres off instead of centimetres (docs/design.md).
// A model that the mapper made beside a community's largest (an extra
// community of the merge, community_mapper.h) is judged against the
// communities' largest models, which alone set the medians: it is always
// in doubt (what is left of a community its mapper could not hold in one
// model), and broken by the same rule on its reprojection error.

#pragma once

#include <string>
#include <vector>

namespace colmap {

// What the incremental mapper of a community produced.
struct CommunityModelReport {
  // Images given to the mapper (its own and those it borrowed).
  int num_images = 0;
  // Registered images of the model that takes part in the merge (the
  // largest; 0 if there is none).
  int num_registered = 0;
  // Models the mapper made.
  int num_models = 0;
  // Mean reprojection error of the model that takes part (pixels).
  double mean_reprojection_error = 0.0;
  // Which of the mapper's models takes part: 1 for the largest, 2 for the
  // second largest (an extra community), ...
  int model_index = 1;
};

struct CommunityJudgementOptions {
  double min_registered_fraction = 0.9;
  double max_relative_reprojection_error = 1.5;

  bool Check() const;
};

struct CommunityJudgement {
  bool doubtful = false;
  bool broken = false;
  // Why, for the log (empty if neither).
  std::string reason;
};

// Judges each community against the others (communities without a model
// are not judged).
std::vector<CommunityJudgement> JudgeCommunityModels(
    const std::vector<CommunityModelReport>& reports,
    const CommunityJudgementOptions& options);

}  // namespace colmap
