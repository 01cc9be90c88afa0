// Joining community reconstructions into one model.
//
// CSfM (Cui et al., ICIP 2017), section 3.4: every community's cameras and
// points are transformed by its world_from_community (similarity_averaging.h),
//     X_g = s_i R_i X + T_i,  R_g = R R_i^T,  C_g = s_i R_i C + T_i,
// and joined. The tracks across communities are the refinement's
// retriangulation's (global_refinement.h).

#pragma once

#include "colmap/geometry/sim3.h"
#include "colmap/scene/reconstruction.h"

#include <memory>
#include <unordered_set>
#include <vector>

namespace colmap {

// Transforms every reconstruction into the global frame and joins their
// rigs, cameras, registered frames with their images, and points into
// `merged` (which must be empty). Each image comes from the one
// reconstruction owning it (`owned_image_ids`; a border image is owned by
// one) with its whole frame (from the first owner of any of its images);
// other reconstructions' observations in it are dropped, and points left
// without any. A shared camera (rig) takes the parameters of the
// reconstruction owning the most images (frames) with it. Ids are kept; the
// reconstructions are transformed in place.
void JoinReconstructions(
    const std::vector<Reconstruction*>& reconstructions,
    const std::vector<Sim3d>& world_from_reconstruction,
    const std::vector<std::unordered_set<image_t>>& owned_image_ids,
    Reconstruction* merged);

// The reconstruction without the registered frames that have none of their
// images in `image_ids` (e.g. a community model without the images it
// borrowed from its neighbours), their observations, and the points left
// with fewer than two observations. Returns `reconstruction` itself if all
// its registered images are in `image_ids`, a new reconstruction otherwise.
std::shared_ptr<Reconstruction> RestrictToImages(
    const std::unordered_set<image_t>& image_ids,
    std::shared_ptr<Reconstruction> reconstruction);

}  // namespace colmap
