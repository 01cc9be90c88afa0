// Helpers for colmap_ext's tests (linked into the test binaries and the
// options doc tool only).

#pragma once

#include "colmap_ext/testing/synthetic_scene.h"

#include "colmap/geometry/sim3.h"
#include "colmap/scene/reconstruction.h"

#include <set>
#include <string>
#include <unordered_map>

namespace colmap {

// A new, empty folder for the running test, named after it. (Not
// CreateTestDir: COLMAP's tests define colmap::CreateTestDir.)
std::string CreateTestFolder();

// Runs a shell command, capturing stdout and stderr together. Returns its
// exit status (-1 if it could not be run or was killed).
int RunCommand(const std::string& command, std::string* output = nullptr);

// Quotes a string for the shell.
std::string ShellQuote(const std::string& text);

// Reads communities.txt (see workflow/community_io.h) into image name ->
// community id. Throws on malformed lines and on an image listed twice.
std::unordered_map<std::string, int> ReadCommunities(const std::string& path);

// docs/options.md: every option of the `--CommunityMapper.*` table (see
// exe/community_mapper_options.h) with its default and help, users' first.
std::string CommunityMapperOptionsMarkdown();

// Two landmarks joined by a walkway, without noise (seed 7, 20 images per
// landmark, 10 on the walkway); `landmark1_images` receives landmark 1's
// images, `other_images` the rest.
void SynthesizeTwoLandmarks(bool single_camera,
                            SyntheticScene* scene,
                            std::set<image_t>* other_images,
                            std::set<image_t>* landmark1_images);

// A community's model as its mapper would give it, cut from a ground truth:
// only the frames of `image_ids` registered (the other images stay,
// unregistered; points they alone held leave with them, tracks cut to the
// rest), moved into a coordinate frame of its own by `model_from_world`.
Reconstruction CommunityModel(const Reconstruction& ground_truth,
                              const std::set<image_t>& image_ids,
                              const Sim3d& model_from_world);

// A group of a model's images misplaced as a community's mapper misplaces a
// stretch onto a look-alike structure: the frames of `image_ids` moved by
// `offset` (in world coordinates) together with their own copy of every
// point they observe, so that they fit their own observations and the
// other images fit theirs; each point keeps the observations of the images
// on its side, and a copy observed by fewer than two images is dropped.
void MoveImagesWithTheirPoints(const std::set<image_t>& image_ids,
                               const Eigen::Vector3d& offset,
                               Reconstruction* model);

}  // namespace colmap
