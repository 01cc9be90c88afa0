// Outputs that never exist half-written.
//
// Each output is written beside its destination under a temporary name and
// renamed into place once complete, so that an interrupted run leaves either
// the previous output or the new one, never a mix.

#pragma once

#include "colmap/scene/reconstruction.h"

#include <string>

namespace colmap {

// Writes the model (COLMAP binary format) to the folder `path`, replacing
// a model that is there.
void WriteReconstructionAtomically(const Reconstruction& reconstruction,
                                   const std::string& path);

// Writes the text to the file `path`, replacing a file that is there.
void WriteTextFileAtomically(const std::string& text, const std::string& path);

// Whether the folder holds a COLMAP model (cameras, images, points3D).
bool IsModelDir(const std::string& path);

}  // namespace colmap
