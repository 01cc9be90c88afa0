// Outputs that never exist half-written.
//
// Each output is written beside its destination under a temporary name
// (tagged with the writer's host and process) and renamed into place once
// complete, so that an interrupted run leaves either the previous output or
// the new one, never a mix; the next writer of the same output removes what
// an interrupted one left beside it.

#pragma once

#include "colmap/scene/reconstruction.h"

#include <string>

namespace colmap {

std::string HostName();

// The writer's tag (HOST-PID) in its temporary names, which tells the
// leftovers of an ended process from what a running one is writing.
std::string WriterTag();

// Whether `tag` (HOST-PID) names a process of this host that has ended
// (no longer runs, or a zombie nobody reaped yet).
bool IsEndedWriterOfThisHost(const std::string& tag);

// Writes the model (COLMAP binary format: rigs, cameras, frames, images,
// points3D) to the folder `path`, replacing a model that is there.
void WriteReconstructionAtomically(const Reconstruction& reconstruction,
                                   const std::string& path);

// Writes the text to the file `path`, replacing a file that is there.
void WriteTextFileAtomically(const std::string& text, const std::string& path);

// Removes from `folder` what writers of this host that no longer run left
// there: their temporaries, and a previous output they had moved aside where
// the output itself is there again (otherwise it is the only copy). What
// running processes or other hosts (a cluster's jobs) write is left alone.
// Both writers above call it once their output is in place. Returns the
// number of leftovers removed.
int RemoveLeftoversOfEndedWriters(const std::string& folder);

// Whether the folder holds a COLMAP model (cameras, images, points3D, in
// binary or text format; rigs and frames beside them where it has them).
bool IsModelDir(const std::string& path);

}  // namespace colmap
