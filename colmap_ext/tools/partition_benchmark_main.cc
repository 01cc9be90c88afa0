// partition_benchmark: community detection on a large generated view graph,
// without any reconstruction (how the partition's cost grows).
//
//   partition_benchmark --num_images 100000 --num_images_per_place 100
//       --degree 60
//
// The graph has what a large photo collection's view graph has: places
// (landmarks, streets) of num_images_per_place images, each image matched
// to `degree` others of its place on average (mostly its neighbours along
// the place, as consecutive viewpoints), and places linked to the next ones
// by a few images, as walkways link landmarks. Prints "key value" lines: the
// graph's size, seconds, communities and the peak modularity.

#include "colmap_ext/partition/community_detection.h"
#include "colmap_ext/util/process_memory.h"

#include "colmap/controllers/option_manager.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"
#include "colmap/util/timer.h"

#include <iostream>
#include <random>
#include <unordered_set>

namespace colmap {
namespace {

WeightedGraph GenerateViewGraph(const int num_images,
                                const int num_images_per_place,
                                const int degree,
                                const int seed) {
  std::mt19937 random(seed);
  WeightedGraph graph;
  graph.num_vertices = num_images;
  std::unordered_set<int64_t> edges;
  auto add = [&](int a, int b) {
    if (a == b || a < 0 || b < 0 || a >= num_images || b >= num_images) {
      return;
    }
    const int64_t key =
        static_cast<int64_t>(std::min(a, b)) * num_images + std::max(a, b);
    if (edges.insert(key).second) {
      graph.edges.push_back({std::min(a, b), std::max(a, b), 1.0});
    }
  };
  const int num_places =
      (num_images + num_images_per_place - 1) / num_images_per_place;
  // Within a place: neighbours along it, at distances drawn around degree/2.
  std::geometric_distribution<int> offset(2.0 / degree);
  for (int image = 0; image < num_images; ++image) {
    const int place = image / num_images_per_place;
    const int begin = place * num_images_per_place;
    const int end = std::min(num_images, begin + num_images_per_place);
    for (int k = 0; k < degree / 2; ++k) {
      const int other =
          begin + (image - begin + 1 + offset(random)) % (end - begin);
      add(image, other);
    }
  }
  // Walkways: each place linked to the next two by a few image pairs.
  std::uniform_int_distribution<int> in_place(0, num_images_per_place - 1);
  for (int place = 0; place < num_places; ++place) {
    for (const int next : {place + 1, place + 7}) {
      if (next >= num_places) continue;
      for (int k = 0; k < 3; ++k) {
        add(place * num_images_per_place + in_place(random),
            next * num_images_per_place + in_place(random));
      }
    }
  }
  return graph;
}

int RunPartitionBenchmark(int argc, char** argv) {
  int num_images = 100000;
  int num_images_per_place = 100;
  int degree = 60;
  int seed = 1;
  CommunityDetectionOptions detection_options;
  OptionManager options(/*add_project_options=*/false);
  options.AddDefaultOption("num_images", &num_images);
  options.AddDefaultOption("num_images_per_place", &num_images_per_place);
  options.AddDefaultOption("degree", &degree);
  options.AddDefaultOption("seed", &seed);
  options.AddDefaultOption("modularity_threshold",
                           &detection_options.modularity_threshold);
  options.AddDefaultOption("min_community_size",
                           &detection_options.min_community_size);
  if (!options.Parse(argc, argv)) {
    return EXIT_FAILURE;
  }
  THROW_CHECK_GT(num_images, 1);
  THROW_CHECK_GT(num_images_per_place, 1);
  THROW_CHECK_GE(degree, 2);

  Timer timer;
  timer.Start();
  const WeightedGraph graph =
      GenerateViewGraph(num_images, num_images_per_place, degree, seed);
  const double generation_seconds = timer.ElapsedSeconds();
  timer.Restart();
  const CommunityPartition partition = DetectCommunities(
      graph, GreedyModularityPartitioner(), detection_options);
  const double seconds = timer.ElapsedSeconds();

  std::cout << "num_images " << graph.num_vertices << "\n"
            << "num_edges " << graph.edges.size() << "\n"
            << StringPrintf("generation_seconds %.3f\n", generation_seconds)
            << StringPrintf("partition_seconds %.3f\n", seconds)
            << "num_communities " << partition.NumCommunities() << "\n"
            << "num_splits " << partition.splits.size() << "\n"
            << StringPrintf("max_modularity %.4f\n", partition.MaxModularity())
            << StringPrintf("peak_memory_mb %.0f\n",
                            ReadProcessMemory().peak_resident_mb)
            << std::flush;
  return EXIT_SUCCESS;
}

}  // namespace
}  // namespace colmap

int main(int argc, char** argv) {
  colmap::InitializeGlog(argv);
  return colmap::RunPartitionBenchmark(argc, argv);
}
