#!/usr/bin/env bash
# The main job on built-in demo data: generates a scene with community
# structure (3 landmarks, each photographed by a cluster of cameras, joined by
# walkways in a loop), reconstructs it with `colmap community_mapper`, and
# prints the model's accuracy against the scene's ground truth.
#
#   scripts/demo.sh [OUT]     (default OUT: demo/)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
OUT=${1:-demo}

rm -rf "$OUT"
"$BUILD_DIR/scene_generator" --output_path "$OUT/scene" \
  --num_clusters 3 --num_images_per_cluster 40 --num_images_per_link 25 \
  --seed 7
mkdir -p "$OUT/sparse"
"$BUILD_DIR/colmap" community_mapper \
  --database_path "$OUT/scene/database.db" \
  --image_path "$OUT/scene/images" \
  --output_path "$OUT/sparse" 2>&1 | tee "$OUT/community_mapper.log" |
  grep -E "Split |communities \(|Communities [0-9]+-[0-9]+: [0-9]+ shared|Merged model|Registered .* of|Time " || true

echo
echo "Accuracy of $OUT/sparse/0 against the ground truth ($OUT/scene/ground_truth):"
"$BUILD_DIR/model_evaluator" --model_path "$OUT/sparse" \
  --ground_truth_path "$OUT/scene/ground_truth" 2>/dev/null
echo
echo "Open it in COLMAP's GUI:"
echo "  $BUILD_DIR/colmap gui --import_path $OUT/sparse/0 --database_path $OUT/scene/database.db --image_path $OUT/scene/images"
