#!/usr/bin/python3
"""Benchmark: `colmap community_mapper` against `colmap mapper` and
`colmap hierarchical_mapper`, side by side, on generated scenes and real
photographs.

    scripts/benchmark.py [--quick] [--out OUT] [--methods M,...]
                         [--seeds S,...] [--draws N] [--reuse M,...]
                         [--doc PATH] [SCENE ...]

Scenes (default: small medium):
  generated, with exact ground truth (build/scene_generator):
    small, medium, large   landmark clusters joined by walkways (loop; large
                           is an open chain of 10 landmarks, ~3000 images)
    huge                   an open chain of 30 landmarks, ~10,000 images
                           (for community_mapper alone: about an hour)
    huge_loop              the same 30 landmarks closed into a loop (10,050
                           images: scale without an open chain's drift)
    courtyard              a loop whose walkway pieces become weak
                           communities (420 images)
    chain                  an open chain, one camera per image with focal
                           lengths 5% off the nominal value (500 images)
    dense                  every overlapping pair verified, as after
                           exhaustive matching, cameras that see far (560)
  real photographs from ../shared/data (skipped where absent), with COLMAP's
  own SIFT (CPU) and exhaustive matching, the database cached in
  OUT/cache/NAME/ (the first run extracts and matches: South Building takes
  about 40 minutes on 2 cores):
    castle, herzjesu       Strecha's castle-P30 and Herz-Jesus-P25 (survey
                           ground truth)
    southbuilding          the CSfM paper's "Building" set, 128 photographs
                           (reference cameras of a full-resolution COLMAP
                           reconstruction)
    southbuilding512       the same photographs with SIFT run at 512 px
    southbuilding384       or 384 px (FeatureExtraction.max_image_size; 10
                           and 6 minutes)
    castle_split,          castle and herzjesu (their cached databases) with
    herzjesu_split         community_mapper splitting them anyway (inlier
                           weights, communities of 8 or more images, the
                           balance rule at one half): the
                           merge against survey ground truth; the group
                           `strecha_split` runs both
  South Building with part of its photographs left out at random (the
  cached database with the other images deleted; scenes nobody tuned for:
  weaker loops, communities joined by few or wrong matches):
    sbF_S                  a fraction F% of the photographs kept, chosen
                           with seed S, e.g. sb60_2; the group `sb_subsets`
                           runs ten of them (50-75%)
  South Building as a real open sequence (the cached database with the
  pairs of images more than W apart in the order of their names deleted,
  matches and two-view geometries: what `colmap sequential_matcher
  --SequentialMatching.overlap W` without loop detection compares):
    sbseqW                 e.g. sbseq10; the group `sb_sequences` runs
                           sbseq5, sbseq10 and sbseq20
  A generated scene with `_sS` appended (e.g. chain_s7) is the same kind of
  scene drawn with seed S: another layout and other noise, to tell a
  method's systematic error from one draw's luck.
  `generated` and `real` stand for all scenes of the kind, `all_kinds` for
  courtyard chain dense castle herzjesu southbuilding (every kind of scene,
  all three methods: the run docs/benchmark.md opens with).

For every scene the methods run one after another on the very same database:
  - mapper:        colmap mapper
  - community:     colmap community_mapper
  - hierarchical:  colmap hierarchical_mapper, with its defaults
  - hier_fair:     colmap hierarchical_mapper --leaf_max_num_images set to the
                   community mapper's median community size
  - global:        colmap global_mapper (COLMAP 4's global SfM, GLOMAP)
Each run is measured with /usr/bin/time (wall, CPU, peak resident memory)
and evaluated by build/model_evaluator against the ground truth. Results:
a Markdown table on stdout and in OUT/results.md (headed by the command
line that produced it), raw figures in OUT/results.csv, and PNG plots (wall time against images; top-down camera
centres of every method after alignment, beside the ground truth, coloured
by community for community_mapper). Camera errors: median, 90th percentile
and mean, and the images on which a method's camera is closer to the ground
truth than colmap mapper's (of those both registered). Where community_mapper
made several communities, a second table takes each community's own images
and gives their median error in the community's own model and in every
method's model, each aligned on those images alone: it tells a merge that
bent its communities (the merged model behind the community's own model)
from one that placed them badly against each other (as good on every
community, behind on the whole scene). Ratios against the
peers are computed within the same run: the machines are shared and noisy,
so absolute seconds are only context. `--methods` runs a subset (e.g.
without mapper on the large scene, where it takes hours); ratios to a method
not run are n/a.

`--seeds 0,1,2` runs every method once per seed of COLMAP's random number
generator (`--default_random_seed`: the RANSAC samples of every registration and
two-view estimate; 0 is COLMAP's default), the first seed's runs in
OUT/SCENE/ as without it, the others' in OUT/SCENE/seedS/. On a few hundred
real photographs two runs of one method differing in the seed alone differ
in the median camera error by several percent: the table then holds a row
per method and seed, each compared with the mapper of the same seed, and a
line per scene gives each method's median over the seeds with its range and
on how many seeds the bar's checks held.

`--draws N robustness` runs every robustness family (loop, chain, dense and
walkway, each `_clean`, `_random` with a quarter of the raw matches wrong at
random and `_mixed` with some of them near their epipolar line, all
verified by COLMAP: FAMILIES below) as N draws, scene seeds 1..N: a table
of every method on every draw, and a table per family of on how many draws
community_mapper had one model where the mapper has one, every image the
mapper registers, a median error at most 1.5x the mapper's, at most 1.25x
the better of the mapper's and global_mapper's, no worse than the
mapper's, with the medians over the draws of its error and time against
the mapper's. `--reuse mapper` takes the mapper's runs recorded in OUT by
an earlier run (OUT/SCENE/mapper.json) instead of running it again. A
generated scene in OUT is generated again only where its knobs or the scene
generator changed.

`--doc docs/benchmark.md` also writes the Markdown results into that file,
as a section headed by the scenes' names, with the command line that
produced them in a fenced block under the heading: a section of the file
whose first fenced block holds the same command line (`--doc` and its path
left aside) is replaced, otherwise the section is appended. Sections are
delimited by `## ` headings.
"""

import argparse
import csv
import json
import os
import random
import re
import shlex
import shutil
import sqlite3
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = os.environ.get("BUILD_DIR", os.path.join(ROOT, "build"))
COLMAP = os.path.join(BUILD, "colmap")
SCENE_GENERATOR = os.path.join(BUILD, "scene_generator")
MODEL_EVALUATOR = os.path.join(BUILD, "model_evaluator")
PARTITION_BENCHMARK = os.path.join(BUILD, "partition_benchmark")

# Generated scenes: the scene generator's knobs.
SCENES = {
    "quick": dict(num_clusters=3, num_images_per_cluster=25,
                  num_images_per_link=20, close_loop=1),
    "small": dict(num_clusters=3, num_images_per_cluster=80,
                  num_images_per_link=20, close_loop=1),
    "medium": dict(num_clusters=6, num_images_per_cluster=130,
                   num_images_per_link=37, close_loop=1),
    "large": dict(num_clusters=10, num_images_per_cluster=240,
                  num_images_per_link=60, close_loop=0),
    # About 10,000 images (community_mapper alone; the mapper would take
    # days on 2 cores).
    "huge": dict(num_clusters=30, num_images_per_cluster=275,
                 num_images_per_link=60, close_loop=0),
    "huge_loop": dict(num_clusters=30, num_images_per_cluster=275,
                      num_images_per_link=60, close_loop=1),
    "courtyard": dict(num_clusters=3, num_images_per_cluster=60,
                      num_images_per_link=80, close_loop=1,
                      seed=5),
    "chain": dict(num_clusters=4, num_images_per_cluster=80,
                  num_images_per_link=60, close_loop=0, single_camera=0,
                  focal_length_noise=0.05, keypoint_noise=1.0,
                  num_false_pairs=30),
    "dense": dict(num_clusters=4, num_images_per_cluster=100,
                  num_images_per_link=40, close_loop=1,
                  max_viewing_distance=90, seed=4),
    # A loop photographed by a two-camera rig (300 images, 150 frames).
    "rig": dict(num_clusters=3, num_images_per_cluster=30,
                num_images_per_link=20, close_loop=1, num_rig_cameras=2,
                rig_baseline=0.3),
}
# The robustness families: each kind of generated scene small enough to be
# drawn many times (--draws), with its raw matches verified by COLMAP's own
# geometric verification as a matcher's: `_clean` without wrong matches,
# `_random` with a quarter of every pair's raw matches wrong at random (which
# the verification rejects), `_mixed` with a quarter of them wrong, a quarter
# of those near their epipolar line (which it keeps, as repeated texture
# along the line makes them); both with pairs matched by chance and pairs
# matched on repeated planar texture (the same poster on two walls).
CLEAN = dict(wrong_match_fraction=0, num_false_pairs=0,
             num_repeated_texture_pairs=0)
RANDOM = dict(wrong_match_fraction=0.25, epipolar_wrong_match_share=0,
              num_false_pairs=30, num_repeated_texture_pairs=10)
MIXED = dict(wrong_match_fraction=0.25, epipolar_wrong_match_share=0.25,
             num_false_pairs=30, num_repeated_texture_pairs=10)
FAMILIES = {
    "loop": dict(num_clusters=3, num_images_per_cluster=40,
                 num_images_per_link=30, close_loop=1),
    "chain": dict(num_clusters=4, num_images_per_cluster=30,
                  num_images_per_link=25, close_loop=0, single_camera=0,
                  focal_length_noise=0.05, keypoint_noise=1.0),
    "dense": dict(num_clusters=3, num_images_per_cluster=50,
                  num_images_per_link=25, close_loop=1,
                  max_viewing_distance=90),
    # Loops whose walkways are longer than their landmark clusters (420
    # images): walkway communities along flat walls, the ones an own mapper
    # bends or breaks, each the loop's only way round.
    "walkway": dict(num_clusters=3, num_images_per_cluster=60,
                    num_images_per_link=80, close_loop=1),
}
# The clean walkway loop with a third of the points along its walkways:
# links between walkway communities rest on few points, so that the
# averaging has links to drop (run as draws: --draws N walkway_thin).
SCENES["walkway_thin"] = dict(FAMILIES["walkway"], num_points_per_link=400,
                              **CLEAN)
# Four landmark clusters of 60 joined by walkways of 60 into one clean loop
# (480 images).
SCENES["walkway_four"] = dict(FAMILIES["walkway"], num_clusters=4,
                              num_images_per_link=60, **CLEAN)
# Families no rule of the merge was set on (run as draws): five small
# clusters joined by short walkways, where the mapper leaves most images out
# and writes several models; the loop family with a camera per image and a
# real matcher's noise; and the loop family with half the points, each seen
# from at most 30 units instead of 40, and noisier keypoints.
SCENES["pent_random"] = dict(num_clusters=5, num_images_per_cluster=30,
                             num_images_per_link=15, close_loop=1, **RANDOM)
SCENES["camloop_mixed"] = dict(FAMILIES["loop"], single_camera=0,
                               focal_length_noise=0.05, keypoint_noise=1.0,
                               **MIXED)
SCENES["sparse_random"] = dict(FAMILIES["loop"], num_points_per_cluster=1500,
                              num_points_per_link=500,
                              max_viewing_distance=30, keypoint_noise=1.2,
                              **RANDOM)
for family, knobs in FAMILIES.items():
    SCENES[family + "_clean"] = dict(knobs, **CLEAN)
    SCENES[family + "_random"] = dict(knobs, **RANDOM)
    SCENES[family + "_mixed"] = dict(knobs, **MIXED)
# Realism shared by all generated scenes (a scene's own knobs win): a
# matcher's raw matches, a quarter of them wrong, pairs matched by chance
# and on repeated texture, all verified by COLMAP.
COMMON = dict(keypoint_noise=0.7, wrong_match_fraction=0.25,
              epipolar_wrong_match_share=0.25, num_false_pairs=20,
              num_repeated_texture_pairs=10, seed=3)

SHARED_DATA = os.environ.get(
    "SHARED_DATA_DIR", os.path.join(os.path.dirname(ROOT), "shared", "data"))
# community_mapper's flags that split a small scene without community
# structure (the *_split scenes).
SPLIT_FLAGS = ["--CommunityMapper.edge_weights", "num_inliers",
               "--CommunityMapper.min_community_size", "8",
               "--CommunityMapper.max_community_fraction", "0.5"]
# Real photographs: folder under SHARED_DATA, feature extraction, and
# optionally the scene whose cached database it shares and community_mapper
# flags of its own.
REAL = {
    "castle": dict(path="strecha/castle-P30", camera_model="PINHOLE",
                   max_num_features=8192),
    "herzjesu": dict(path="strecha/Herz-Jesus-P25", camera_model="PINHOLE",
                     max_num_features=8192),
    "southbuilding": dict(path="south-building", camera_model="SIMPLE_RADIAL",
                          max_num_features=4096),
    # The same photographs with SIFT run on them at 512 px (COLMAP scales
    # the keypoints back): fewer, coarser features, and the matcher verifies
    # fewer of the pairs that close the walk.
    "southbuilding512": dict(path="south-building",
                             camera_model="SIMPLE_RADIAL",
                             max_num_features=4096, max_image_size=512),
    # At 384 px the matcher verifies fewer still: on the photographs resized
    # to 384 px both links of one community failed the co-visibility check.
    "southbuilding384": dict(path="south-building",
                             camera_model="SIMPLE_RADIAL",
                             max_num_features=4096, max_image_size=384),
    # Strecha's sets split although their view graphs show no community
    # structure (inlier weights, communities of 8 images or more), on the
    # databases cached for castle and herzjesu: the merge at work on the
    # only photographs here with survey ground truth.
    "castle_split": dict(path="strecha/castle-P30", camera_model="PINHOLE",
                         max_num_features=8192, cache="castle",
                         community_flags=SPLIT_FLAGS),
    "herzjesu_split": dict(path="strecha/Herz-Jesus-P25",
                           camera_model="PINHOLE", max_num_features=8192,
                           cache="herzjesu", community_flags=SPLIT_FLAGS),
}
# South Building subsets (see the docstring): name -> (fraction kept, seed).
SUBSETS = {f"sb{round(100 * fraction)}_{seed}": (fraction, seed)
           for fraction, seed in [(0.5, 4), (0.5, 5), (0.6, 1), (0.6, 2),
                                  (0.6, 6), (0.6, 7), (0.6, 8), (0.7, 9),
                                  (0.7, 10), (0.75, 3)]}
SUBSET_PATTERN = re.compile(r"^sb(\d+)_(\d+)$")
# South Building as a sequence: sbseqW (see the docstring).
SEQUENCE_PATTERN = re.compile(r"^sbseq(\d+)$")
# A generated scene drawn with another seed: NAME_sSEED.
SEED_PATTERN = re.compile(r"^([a-z_]+)_s(\d+)$")


def generated_knobs(name):
    """The scene generator's knobs of a generated scene (None if `name` is
    not one), with the seed of a NAME_sSEED variant."""
    if name in SCENES:
        return dict(COMMON, **SCENES[name])
    match = SEED_PATTERN.match(name)
    if match and match.group(1) in SCENES:
        return dict(dict(COMMON, **SCENES[match.group(1)]),
                    seed=int(match.group(2)))
    return None

GROUPS = {
    "generated": ["small", "medium", "courtyard", "chain", "dense"],
    "real": list(REAL),
    "all_kinds": ["courtyard", "chain", "dense", "castle", "herzjesu",
                  "southbuilding"],
    "sb_subsets": list(SUBSETS),
    "sb_sequences": ["sbseq5", "sbseq10", "sbseq20"],
    "strecha_split": ["castle_split", "herzjesu_split"],
    "robustness": [family + suffix for family in FAMILIES
                   for suffix in ("_clean", "_random", "_mixed")],
}

METHODS = ["mapper", "community", "hierarchical", "hier_fair", "global"]
LABELS = {
    "mapper": "colmap mapper",
    "community": "colmap community_mapper",
    "hierarchical": "colmap hierarchical_mapper (defaults)",
    "hier_fair": "colmap hierarchical_mapper (leaf = median community)",
    "global": "colmap global_mapper",
}
COLORS = {"mapper": "tab:blue", "community": "tab:red",
          "hierarchical": "tab:green", "hier_fair": "tab:olive",
          "global": "tab:purple"}
PHASES = ["Partition", "Communities", "Pairwise similarities",
          "Similarity averaging", "Global refinement", "Registration"]


def log(message):
    print(message, file=sys.stderr, flush=True)


def run_timed(command, log_path):
    """Runs command under /usr/bin/time -v; returns (exit, wall, cpu, rss)."""
    with open(log_path, "w") as log_file:
        start = time.time()
        status = subprocess.call(["/usr/bin/time", "-v"] + command,
                                 stdout=log_file, stderr=subprocess.STDOUT)
        wall = time.time() - start
    text = open(log_path, errors="replace").read()

    def field(name):
        match = re.search(re.escape(name) + r":\s*([0-9.:]+)", text)
        return match.group(1) if match else None

    cpu = float(field("User time (seconds)") or 0) + \
        float(field("System time (seconds)") or 0)
    rss_mb = float(field("Maximum resident set size (kbytes)") or 0) / 1024
    return status, wall, cpu, rss_mb


def evaluate(model_path, ground_truth_path, centers_path=None,
             image_list_path=None):
    """build/model_evaluator's figures of the model (those of the images in
    `image_list_path` alone, aligned on them, if given), by key; writes the
    aligned camera centres to `centers_path` if given."""
    arguments = [MODEL_EVALUATOR, "--model_path", model_path,
                 "--ground_truth_path", ground_truth_path]
    if centers_path:
        arguments += ["--aligned_centers_path", centers_path]
    if image_list_path:
        arguments += ["--image_list_path", image_list_path]
    output = subprocess.run(arguments, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True,
                            check=True).stdout
    figures = {}
    for line in output.splitlines():
        key, value = line.split()
        figures[key] = float(value)
    return figures


def subset_median_error(model_path, ground_truth_path, list_path):
    """Median camera error of the images listed in `list_path` in the model,
    aligned on them alone (NaN where they cannot be aligned)."""
    return evaluate(model_path, ground_truth_path,
                    image_list_path=list_path)["median_position_error"]


def per_community_errors(scene_dir, ground_truth, methods):
    """For every community of the community_mapper run in scene_dir: its own
    images (communities.txt) and the median error of their cameras in the
    community's own model and in every method's model, each aligned on those
    images alone. Where the merged model is behind the communities' own
    models on their images, the merge bent them; where it is as good there
    but behind on the whole scene, the communities' placement (the joints)
    holds the error. Returns [(community, images, {"own": error, method:
    error, ...})]."""
    run_dir = os.path.join(scene_dir, "community")
    communities_path = os.path.join(run_dir, "communities.txt")
    if not os.path.exists(communities_path):
        return []
    members = {}
    for name, community in read_communities(communities_path).items():
        members.setdefault(community, []).append(name)
    if len(members) < 2:
        return []
    rows = []
    for community, names in sorted(members.items()):
        list_path = os.path.join(scene_dir, f"community{community}_images.txt")
        with open(list_path, "w") as file:
            file.write("".join(name + "\n" for name in sorted(names)))
        errors = {"own": subset_median_error(
            os.path.join(run_dir, "communities", str(community)),
            ground_truth, list_path)}
        for method in methods:
            errors[method] = subset_median_error(
                os.path.join(scene_dir, method), ground_truth, list_path)
        rows.append((community, len(names), errors))
    return rows


def read_communities(path):
    communities = {}
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        name, community = line.rsplit(" ", 1)
        communities[name] = int(community)
    return communities


def read_centers(path):
    """Camera centres per image name, from a model_evaluator
    --aligned_centers_path file: (aligned X Y Z, ground truth X Y Z)."""
    centers = {}
    for line in open(path):
        fields = line.split()
        if line.startswith("#") or len(fields) != 7:
            continue
        values = [float(value) for value in fields[1:]]
        centers[fields[0]] = (values[:3], values[3:])
    return centers


def center_errors(centers):
    """Camera centre error per image name, from read_centers."""
    return {name: sum((a - b) ** 2 for a, b in zip(aligned, truth)) ** 0.5
            for name, (aligned, truth) in centers.items()}


def closer_count(errors, reference):
    """On how many of the images both error maps hold the first's camera is
    the closer one, and how many they both hold. A median can fall between
    the modes of a bimodal error distribution (South Building's reference
    has such modes): a method a hair's breadth different then moves the
    median by several percent. The paired count says which model is closer
    image by image."""
    common = [name for name in errors if name in reference]
    return sum(1 for name in common if errors[name] < reference[name]), \
        len(common)


def community_phases(run_dir):
    """Phase seconds by snake-case name, from OUT/summary.txt."""
    phases = {}
    path = os.path.join(run_dir, "summary.txt")
    if os.path.exists(path):
        for line in open(path):
            fields = line.split()
            if len(fields) == 3 and fields[0] == "phase_seconds":
                phases[fields[1]] = float(fields[2])
    return phases


def partition_graph_section(num_images):
    """Community detection alone on a generated view graph of num_images."""
    log(f"== Partition of a generated view graph of {num_images} images")
    output = subprocess.run(
        [PARTITION_BENCHMARK, "--num_images", str(num_images)],
        check=True, capture_output=True, text=True).stdout
    figures = {}
    for line in output.splitlines():
        key, value = line.split()
        figures[key] = float(value)
    log(f"   -> {figures['partition_seconds']:.1f}s, "
        f"{int(figures['num_communities'])} communities")
    return (f"\n### Partition of a generated view graph\n\n"
            f"{int(figures['num_images'])} images, "
            f"{int(figures['num_edges'])} edges (places of 100 images linked "
            f"by walkways; build/partition_benchmark): community detection "
            f"took {figures['partition_seconds']:.1f} s "
            f"({int(figures['num_splits'])} splits, "
            f"{int(figures['num_communities'])} communities, Qmax "
            f"{figures['max_modularity']:.3f}), peak memory "
            f"{figures['peak_memory_mb']:.0f} MB.\n")


def generate_scene(name, out_dir):
    """Generates the scene, unless OUT holds it generated with the same
    knobs by the scene generator as it is now (older than the scene);
    returns (database, images, ground truth, number of images, knobs)."""
    scene_dir = os.path.join(out_dir, name, "scene")
    knobs = generated_knobs(name)
    log(f"== Scene {name}: {knobs}")
    clusters = os.path.join(scene_dir, "clusters.txt")
    record = os.path.join(scene_dir, "knobs.json")
    if not (os.path.exists(clusters) and os.path.exists(record) and
            json.load(open(record)) == knobs and
            os.path.getmtime(SCENE_GENERATOR) < os.path.getmtime(record)):
        if os.path.exists(record):
            os.remove(record)  # A generation cut short keeps no record.
        arguments = [SCENE_GENERATOR, "--output_path", scene_dir,
                     "--overwrite", "1"]
        for key, value in knobs.items():
            arguments += ["--" + key, str(value)]
        subprocess.run(arguments, check=True, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
        with open(record, "w") as file:
            json.dump(knobs, file)
    num_images = sum(1 for line in open(clusters)
                     if not line.startswith("#"))
    return (os.path.join(scene_dir, "database.db"),
            os.path.join(scene_dir, "images"),
            os.path.join(scene_dir, "ground_truth"), num_images, knobs)


def prepare_real_scene(name, out_dir):
    """Extracts and matches the photographs once (cached in OUT/cache/NAME);
    returns what generate_scene returns."""
    spec = REAL[name]
    data = os.path.join(SHARED_DATA, spec["path"])
    images = os.path.join(data, "images")
    cache = os.path.join(out_dir, "cache", spec.get("cache", name))
    database = os.path.join(cache, "database.db")
    knobs = dict(photos=spec["path"], camera_model=spec["camera_model"],
                 max_num_features=spec["max_num_features"],
                 matcher="exhaustive (CPU)")
    if "community_flags" in spec:
        knobs["community_mapper"] = " ".join(spec["community_flags"])
    extraction = ["--SiftExtraction.max_num_features",
                  str(spec["max_num_features"])]
    if "max_image_size" in spec:
        knobs["max_image_size"] = spec["max_image_size"]
        extraction += ["--FeatureExtraction.max_image_size",
                       str(spec["max_image_size"])]
    log(f"== Scene {name}: {knobs}")
    if not os.path.exists(os.path.join(cache, "matched")):
        shutil.rmtree(cache, ignore_errors=True)
        os.makedirs(cache)
        log(f"   extracting and matching {images} (cached in {cache}) ...")
        with open(os.path.join(cache, "features.log"), "w") as log_file:
            subprocess.run(
                [COLMAP, "feature_extractor", "--database_path", database,
                 "--image_path", images,
                 "--ImageReader.camera_model", spec["camera_model"],
                 "--ImageReader.single_camera", "1",
                 "--FeatureExtraction.use_gpu", "0"] + extraction,
                check=True, stdout=log_file, stderr=subprocess.STDOUT)
            subprocess.run(
                [COLMAP, "exhaustive_matcher", "--database_path", database,
                 "--FeatureMatching.use_gpu", "0"],
                check=True, stdout=log_file, stderr=subprocess.STDOUT)
        open(os.path.join(cache, "matched"), "w").write("1\n")
    num_images = len(os.listdir(images))
    return (database, images, os.path.join(data, "ground_truth"), num_images,
            knobs)


def copy_southbuilding_database(name, out_dir):
    """South Building's cached database copied to OUT/cache/NAME; returns
    the copy's path, then what prepare_real_scene returns after the
    database."""
    database, images, ground_truth, num_images, knobs = prepare_real_scene(
        "southbuilding", out_dir)
    cache = os.path.join(out_dir, "cache", name)
    copy = os.path.join(cache, "database.db")
    shutil.rmtree(cache, ignore_errors=True)
    os.makedirs(cache)
    shutil.copy(database, copy)
    return copy, images, ground_truth, num_images, knobs


def delete_pairs(connection, doomed):
    """Deletes the matches and two-view geometries of every image pair
    (image_id1, image_id2) for which doomed(image_id1, image_id2) holds."""
    max_image_id = 2147483647  # COLMAP's pair id: id1 * this + id2.
    for table in ("matches", "two_view_geometries"):
        pair_ids = [pair_id for (pair_id,) in
                    connection.execute(f"SELECT pair_id FROM {table}")]
        connection.executemany(
            f"DELETE FROM {table} WHERE pair_id = ?",
            [(pair_id,) for pair_id in pair_ids
             if doomed(pair_id // max_image_id, pair_id % max_image_id)])


def prepare_subset_scene(name, out_dir):
    """South Building's cached database with the images of a random subset
    only (their keypoints, matches and verified pairs; the others deleted);
    returns what generate_scene returns."""
    match = SUBSET_PATTERN.match(name)
    fraction, seed = int(match.group(1)) / 100, int(match.group(2))
    subset, images, ground_truth, _, knobs = copy_southbuilding_database(
        name, out_dir)
    connection = sqlite3.connect(subset)
    rows = connection.execute(
        "SELECT image_id, name FROM images ORDER BY name").fetchall()
    rng = random.Random(seed)
    dropped = {image_id for image_id, _ in rows if rng.random() > fraction}
    delete_pairs(connection, lambda image_id1, image_id2:
                 image_id1 in dropped or image_id2 in dropped)
    for table in ("keypoints", "descriptors", "images"):
        connection.executemany(f"DELETE FROM {table} WHERE image_id = ?",
                               [(image_id,) for image_id in dropped])
    connection.commit()
    connection.close()
    knobs = dict(knobs, subset=f"{len(rows) - len(dropped)} of {len(rows)} "
                 f"photographs (seed {seed})")
    log(f"   {name}: kept {len(rows) - len(dropped)} of {len(rows)} images")
    return (subset, images, ground_truth, len(rows) - len(dropped), knobs)


def prepare_sequence_scene(name, out_dir):
    """South Building's cached database with only the pairs of images at
    most W apart in the order of their names (as sequential matching without
    loop detection compares them); returns what generate_scene returns."""
    window = int(SEQUENCE_PATTERN.match(name).group(1))
    sequence, images, ground_truth, num_images, knobs = \
        copy_southbuilding_database(name, out_dir)
    connection = sqlite3.connect(sequence)
    rank = {image_id: k for k, (image_id, _) in enumerate(connection.execute(
        "SELECT image_id, name FROM images ORDER BY name"))}
    delete_pairs(connection, lambda image_id1, image_id2:
                 abs(rank[image_id1] - rank[image_id2]) > window)
    connection.commit()
    connection.close()
    knobs = dict(knobs, matcher=f"exhaustive (CPU), then only the pairs at "
                 f"most {window} apart in name order kept")
    log(f"   {name}: pairs of images at most {window} apart")
    return (sequence, images, ground_truth, num_images, knobs)


def run_scene(name, out_dir, threads, methods, seeds, reuse):
    if SEQUENCE_PATTERN.match(name):
        database, images, ground_truth, num_images, knobs = \
            prepare_sequence_scene(name, out_dir)
    elif SUBSET_PATTERN.match(name):
        database, images, ground_truth, num_images, knobs = \
            prepare_subset_scene(name, out_dir)
    elif name in REAL:
        database, images, ground_truth, num_images, knobs = \
            prepare_real_scene(name, out_dir)
    else:
        database, images, ground_truth, num_images, knobs = \
            generate_scene(name, out_dir)
    rows = []
    for index, seed in enumerate(seeds):
        scene_dir = os.path.join(out_dir, name) if index == 0 else \
            os.path.join(out_dir, name, f"seed{seed}")
        if len(seeds) > 1:
            log(f"   seed {seed}:")
        rows += run_methods(name, scene_dir, database, images, ground_truth,
                            num_images, threads, methods, seed, reuse)
    return rows, knobs


def run_methods(name, scene_dir, database, images, ground_truth, num_images,
                threads, methods, seed, reuse):
    """Runs every method once on the prepared scene, with the PRNG seed;
    returns a row of figures per method. A method in `reuse` whose earlier
    run on the scene is recorded (SCENE_DIR/METHOD.json) is not run again."""
    results = {}
    reused = set()
    leaf_size = None
    for method in methods:
        run_dir = os.path.join(scene_dir, method)
        record = os.path.join(scene_dir, method + ".json")
        if method in reuse and os.path.exists(record):
            results[method] = json.load(open(record))
            reused.add(method)
            log(f"   {LABELS[method]}: the earlier run in {run_dir}")
            continue
        shutil.rmtree(run_dir, ignore_errors=True)
        os.makedirs(run_dir)
        common = ["--database_path", database, "--image_path", images,
                  "--output_path", run_dir, "--default_random_seed", str(seed)]
        if method == "mapper":
            command = [COLMAP, "mapper"] + common + \
                ["--Mapper.num_threads", str(threads)]
        elif method == "community":
            command = [COLMAP, "community_mapper"] + common + \
                REAL.get(name, {}).get("community_flags", [])
        elif method == "hierarchical":
            command = [COLMAP, "hierarchical_mapper"] + common
        elif method == "global":
            command = [COLMAP, "global_mapper"] + common
        else:
            # Without a partition there is no fair leaf size: use the
            # hierarchical mapper's own default.
            command = [COLMAP, "hierarchical_mapper"] + common + \
                (["--leaf_max_num_images", str(leaf_size)]
                 if leaf_size else [])
        log(f"   {LABELS[method]} ...")
        log_path = os.path.join(scene_dir, method + ".log")
        status, wall, cpu, rss = run_timed(command, log_path)
        row = dict(scene=name, method=method, seed=seed, images=num_images,
                   exit=status, wall_s=wall, cpu_s=cpu, peak_rss_mb=rss)
        figures = evaluate(run_dir, ground_truth,
                           os.path.join(scene_dir, method + "_centers.txt"))
        row.update(
            models=int(figures["num_models"]),
            registered=int(figures["registered_images"]),
            mean_reproj_px=figures["mean_reprojection_error_px"],
            extent=figures["extent"],
            median_pos_err=figures["median_position_error"],
            p90_pos_err=figures["p90_position_error"],
            median_pos_err_frac=figures["median_position_error_fraction"],
            p90_pos_err_frac=figures["p90_position_error_fraction"],
            median_rot_err_deg=figures["median_rotation_error_deg"])
        for figure in ("rig_rotation_error_deg", "rig_baseline_error_fraction"):
            if figure in figures:
                row[figure] = figures[figure]
        if method == "community":
            for phase, seconds in community_phases(run_dir).items():
                row["phase_" + phase + "_s"] = seconds
            communities_path = os.path.join(run_dir, "communities.txt")
            communities = read_communities(communities_path) \
                if os.path.exists(communities_path) else {}
            sizes = {}
            for community in communities.values():
                sizes[community] = sizes.get(community, 0) + 1
            row["communities"] = len(sizes)
            if sizes:
                leaf_size = int(statistics.median(sizes.values()))
            row["median_community_size"] = leaf_size or 0
        with open(record, "w") as file:
            json.dump(row, file)
        log(f"   -> {wall:.1f}s, {row['registered']}/{num_images} images in "
            f"{row['models']} model(s), median error "
            f"{row['median_pos_err']:.4f}")
        results[method] = row
    if "community" in results and "community" not in reused:
        # Recorded with the run: a reuse takes them from the record.
        results["community"]["per_community"] = " ".join(
            f"{community}:{size}:" + "/".join(
                f"{errors[key]:.4f}" for key in ["own"] + methods)
            for community, size, errors in per_community_errors(
                scene_dir, ground_truth, methods))
        with open(os.path.join(scene_dir, "community.json"), "w") as file:
            json.dump(results["community"], file)
    nan = float("nan")
    errors = {method: center_errors(read_centers(
        os.path.join(scene_dir, method + "_centers.txt")))
              for method in methods}
    for method in methods:
        row = results[method]
        row["mean_pos_err"] = statistics.mean(errors[method].values()) \
            if errors[method] else nan
        row["closer_than_mapper"], row["common_images"] = \
            closer_count(errors[method], errors["mapper"]) \
            if "mapper" in errors and method != "mapper" else (None, None)
        for peer in ("mapper", "hierarchical", "hier_fair", "global"):
            row[f"time_vs_{peer}"] = \
                row["wall_s"] / results[peer]["wall_s"] \
                if peer in results else nan
        row["error_vs_global"] = \
            row["median_pos_err"] / max(results["global"]["median_pos_err"],
                                        1e-12) \
            if "global" in results else nan
        row["memory_vs_mapper"] = \
            row["peak_rss_mb"] / max(results["mapper"]["peak_rss_mb"], 1e-9) \
            if "mapper" in results else nan
    return [results[method] for method in methods]


def ratio(value, digits):
    return "n/a" if value != value else f"{value:.{digits}f}"


def closer_text(row):
    if row["closer_than_mapper"] is None:
        return "n/a"
    return f"{row['closer_than_mapper']}/{row['common_images']}"


def bar_checks(scene, rows):
    """The bar for one run of every method on the scene: one
    model where the mapper has one, as many images, no larger median error,
    and half the mapper's time from 500 images on and on South Building.
    (text, passed) per check; passed is None where the peer did not run."""
    community = [row for row in rows if row["method"] == "community"][0]
    mapper = [row for row in rows if row["method"] == "mapper"]
    hier = [row for row in rows
            if row["method"] in ("hierarchical", "hier_fair")]
    needs_speed = (community["images"] >= 500 or
                   scene.startswith("southbuilding"))
    return [
        ("one model where mapper has one",
         community["models"] == 1 or mapper[0]["models"] > 1
         if mapper else community["models"] == 1),
        ("registers at least as many images as mapper",
         community["registered"] >= mapper[0]["registered"]
         if mapper else None),
        ("median position error no worse than mapper's",
         community["median_pos_err"] <= mapper[0]["median_pos_err"]
         if mapper else None),
        ("at most half of mapper's time" +
         ("" if needs_speed else " (not required under 500 images)"),
         community["time_vs_mapper"] <= 0.5 if mapper else None),
        ("faster than hierarchical_mapper in both settings",
         all(community["wall_s"] < row["wall_s"] for row in hier)
         if len(hier) == 2 else None),
    ]


def seeds_summary(scene_rows, seeds):
    """Per method, the median over the seeds of its median camera error,
    with their range, and of its time against the mapper's."""
    parts = []
    for method in METHODS:
        method_rows = [row for row in scene_rows if row["method"] == method]
        if not method_rows:
            continue
        medians = [row["median_pos_err"] for row in method_rows]
        text = (f"{LABELS[method]} {statistics.median(medians):.4f} "
                f"[{min(medians):.4f}-{max(medians):.4f}]")
        ratios = [row["time_vs_mapper"] for row in method_rows
                  if row["time_vs_mapper"] == row["time_vs_mapper"]]
        if method != "mapper" and ratios:
            text += f", time / mapper {statistics.median(ratios):.3f}"
        parts.append(text)
    return (f"Over the seeds {','.join(str(seed) for seed in seeds)}, median "
            "position error (median over the seeds [range]): " +
            "; ".join(parts))


def per_community_section(scene_rows, seeds):
    """The per-community errors (per_community_errors) of a scene's
    community_mapper runs, as a table; none for a single community."""
    methods = [row["method"] for row in scene_rows
               if row["seed"] == seeds[0]]
    lines = []
    for row in scene_rows:
        if row["method"] != "community" or not row.get("per_community"):
            continue
        if not lines:
            lines += ["", "Each community's own images, each model aligned "
                      "on them alone (median camera error):", "",
                      "| seed | community | images | its own model | " +
                      " | ".join(LABELS[method] for method in methods) +
                      " |", "|" + "---|" * (4 + len(methods))]
        for entry in row["per_community"].split():
            community, size, errors = entry.split(":")
            lines.append(f"| {row['seed']} | {community} | {size} | " +
                         " | ".join(errors.split("/")) + " |")
    return lines


def markdown(rows, scene_knobs, seeds):
    lines = []
    for scene, knobs in scene_knobs.items():
        scene_rows = [row for row in rows if row["scene"] == scene]
        lines.append(f"### Scene `{scene}`: {scene_rows[0]['images']} images")
        lines.append("")
        lines.append("Knobs: " + ", ".join(f"{key}={value}"
                                           for key, value in knobs.items()))
        lines.append("")
        lines.append("| method | wall s | CPU s | peak MB | models | "
                     "registered | reproj px | median pos err (frac) | "
                     "p90 pos err (frac) | mean pos err | closer than "
                     "mapper | median rot deg | time / mapper | "
                     "time / hier. | time / hier. fair | time / global | "
                     "median error / global | memory / mapper |")
        lines.append("|" + "---|" * 18)
        for row in scene_rows:
            label = LABELS[row["method"]] + \
                (f", seed {row['seed']}" if len(seeds) > 1 else "")
            lines.append(
                f"| {label} | {row['wall_s']:.1f} | "
                f"{row['cpu_s']:.1f} | {row['peak_rss_mb']:.0f} | "
                f"{row['models']} | {row['registered']}/{row['images']} | "
                f"{row['mean_reproj_px']:.3f} | "
                f"{row['median_pos_err']:.4f} "
                f"({row['median_pos_err_frac']:.2e}) | "
                f"{row['p90_pos_err']:.4f} ({row['p90_pos_err_frac']:.2e}) | "
                f"{row['mean_pos_err']:.4f} | "
                f"{closer_text(row)} | "
                f"{row['median_rot_err_deg']:.3f} | "
                f"{ratio(row['time_vs_mapper'], 3)} | "
                f"{ratio(row['time_vs_hierarchical'], 3)} | "
                f"{ratio(row['time_vs_hier_fair'], 3)} | "
                f"{ratio(row['time_vs_global'], 3)} | "
                f"{ratio(row['error_vs_global'], 2)} | "
                f"{ratio(row['memory_vs_mapper'], 2)} |")
        community = [row for row in scene_rows
                     if row["method"] == "community"][0]
        phases = ", ".join(
            f"{phase} {community.get('phase_' + phase.lower().replace(' ', '_') + '_s', float('nan')):.1f}s"
            for phase in PHASES)
        lines.append("")
        lines.append(f"community_mapper: {community['communities']} "
                     f"communities (median size "
                     f"{community['median_community_size']}); phases: "
                     f"{phases}")
        # Each seed's runs judged together; with several seeds, on how many
        # the check held.
        per_seed = [bar_checks(scene, [row for row in scene_rows
                                       if row["seed"] == seed])
                    for seed in seeds]
        texts = []
        for index, (text, _) in enumerate(per_seed[0]):
            results = [checks[index][1] for checks in per_seed]
            if results[0] is None:
                texts.append(f"{text}: n/a")
            elif len(seeds) == 1:
                texts.append(f"{text}: {'yes' if results[0] else 'NO'}")
            else:
                num_held = sum(1 for passed in results if passed)
                texts.append(
                    f"{text}: {'yes' if num_held == len(seeds) else 'NO'} "
                    f"({num_held} of {len(seeds)} seeds)")
        lines += per_community_section(scene_rows, seeds)
        lines.append("")
        lines.append("Bar: " + "; ".join(texts))
        if len(seeds) > 1:
            lines.append("")
            lines.append(seeds_summary(scene_rows, seeds))
        lines.append("")
    first_rows = [row for row in rows if row["seed"] == seeds[0]]
    lines += scaling(first_rows, scene_knobs)
    return "\n".join(lines)


def robustness_section(rows, families, draws):
    """Every method on every draw of every family (the scenes FAMILY_sDRAW):
    a row per draw with each method's models, registered images, median
    error and time against the mapper; then a row per family (and one over
    all) with on how many draws community_mapper held each check against
    the mapper and against the better of the mapper and global_mapper, and
    the medians over the draws of its error and time against the mapper's
    and of the other methods' errors against the mapper's."""
    peers = [method for method in ("mapper", "hierarchical", "hier_fair",
                                   "global")
             if any(row["method"] == method for row in rows)]
    header = (["family", "draw", "images"] +
              [f"{LABELS[method].split(' (')[0]}" for method in peers] +
              ["community_mapper", "error / mapper",
               "error / best of mapper, global"])
    lines = ["Each method: models, registered images, median camera "
             "error, time / mapper.", "",
             "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    summary = []
    everything = []
    for family in families:
        draws_held = []
        for draw in draws:
            scene = f"{family}_s{draw}"
            by_method = {row["method"]: row for row in rows
                         if row["scene"] == scene}
            if "mapper" not in by_method or "community" not in by_method:
                continue
            mapper, community = by_method["mapper"], by_method["community"]

            def cell(row):
                return (f"{row['models']}, {row['registered']}, "
                        f"{row['median_pos_err']:.4f}, "
                        f"{ratio(row['time_vs_mapper'], 2)}")
            def ratio_to_mapper(method):
                return by_method[method]["median_pos_err"] / \
                    max(mapper["median_pos_err"], 1e-12) \
                    if method in by_method else float("nan")
            error_ratio = ratio_to_mapper("community")
            best = min(by_method[method]["median_pos_err"]
                       for method in ("mapper", "global")
                       if method in by_method)
            best_ratio = community["median_pos_err"] / max(best, 1e-12)
            lines.append(
                f"| {family} | {draw} | {mapper['images']} | " +
                " | ".join(cell(by_method[method]) if method in by_method
                           else "n/a" for method in peers) +
                f" | {cell(community)} | {error_ratio:.2f} | "
                f"{best_ratio:.2f} |")
            draws_held.append(dict(
                one_model=community["models"] == 1 or mapper["models"] > 1,
                registered=community["registered"] >= mapper["registered"],
                within=error_ratio <= 1.5, within_best=best_ratio <= 1.25,
                no_worse=error_ratio <= 1.0,
                error_ratio=error_ratio,
                time_ratio=community["time_vs_mapper"],
                hierarchical_ratio=ratio_to_mapper("hierarchical"),
                global_ratio=ratio_to_mapper("global")))
        everything += draws_held
        summary.append(robustness_row(f"`{family}`", draws_held))
    summary.append(robustness_row("all", everything))
    return (lines + ["", "community_mapper over the draws: on how many it "
                     "held each check, and medians over the draws (worst "
                     "in brackets) of its median error and time against "
                     "the mapper's, and of hierarchical_mapper's and "
                     "global_mapper's median errors against the "
                     "mapper's.", "",
                     "| family | draws | one model where the mapper has "
                     "one | every image the mapper registers | error at "
                     "most 1.5x the mapper's | at most 1.25x the better of "
                     "mapper, global_mapper | no worse than the mapper's | "
                     "error / mapper | time / mapper | hierarchical_mapper "
                     "error / mapper | global_mapper error / mapper |",
                     "|---|---|---|---|---|---|---|---|---|---|---|"] +
            summary +
            [""])


def robustness_row(name, draws_held):
    """A row of robustness_section's summary over the draws `draws_held`."""
    count = len(draws_held)
    if not count:
        return f"| {name} | 0 |" + " n/a |" * 9

    def held(check):
        return f"{sum(draw[check] for draw in draws_held)}/{count}"

    def median(figure, with_worst=True):
        values = [draw[figure] for draw in draws_held
                  if draw[figure] == draw[figure]]
        if not values:
            return "n/a"
        return f"{statistics.median(values):.2f}" + \
            (f" ({max(values):.2f})" if with_worst else "")
    return (f"| {name} | {count} | {held('one_model')} | "
            f"{held('registered')} | {held('within')} | "
            f"{held('within_best')} | {held('no_worse')} | "
            f"{median('error_ratio')} | {median('time_ratio')} | "
            f"{median('hierarchical_ratio', False)} | "
            f"{median('global_ratio', False)} |")


def command_line(argv):
    """The benchmark's command line as run, from the repository's root."""
    return " ".join(["scripts/benchmark.py"] +
                    [shlex.quote(argument) for argument in argv[1:]])


def without_doc(command):
    """The command line without `--doc PATH` (or `--doc=PATH`): the
    results do not depend on it."""
    words, kept, skip = shlex.split(command), [], False
    for word in words:
        if skip:
            skip = False
        elif word == "--doc":
            skip = True
        elif not word.startswith("--doc="):
            kept.append(word)
    return " ".join(kept)


def repository_commit():
    """The repository's commit (with -dirty where the work tree differs),
    or None outside a git checkout."""
    try:
        return subprocess.run(
            ["git", "-C", ROOT, "describe", "--always", "--dirty"],
            check=True, capture_output=True, text=True).stdout.strip() or None
    except (OSError, subprocess.CalledProcessError):
        return None


def doc_section(scenes, command, table):
    """The results as a section of a Markdown document: a heading naming
    the scenes, the command line in a fenced block, the tables."""
    heading = ("## Scenes " + ", ".join(f"`{scene}`" for scene in scenes)
               if scenes else "## Community detection alone")
    commit = repository_commit()
    lines = [heading, "", "```", command, "```", "",
             f"Run on {time.strftime('%Y-%m-%d')} with the binaries in "
             f"{os.path.relpath(BUILD, ROOT)}/" +
             (f", this repository at {commit}." if commit else "."), "", ""]
    # The results' own headings sit one level below the section's.
    return "\n".join(lines) + table.strip("\n") + "\n"


def write_doc_section(path, command, section):
    """Replaces the section of the Markdown file at `path` whose first
    fenced block is `command` (compared without --doc), or appends the
    section; sections start at lines beginning with `## ` (or `# `)."""
    text = open(path).read() if os.path.exists(path) else ""
    lines = text.split("\n")
    starts, fence = [], False
    for index, line in enumerate(lines):
        if line.startswith("```"):
            fence = not fence
        elif not fence and (line.startswith("## ") or line.startswith("# ")):
            starts.append(index)
    wanted = without_doc(command)
    for number, start in enumerate(starts):
        if not lines[start].startswith("## "):
            continue
        end = starts[number + 1] if number + 1 < len(starts) else len(lines)
        fenced = None
        for index in range(start + 1, end - 1):
            if lines[index].startswith("```"):
                fenced = lines[index + 1].strip()
                break
        try:
            same = fenced is not None and without_doc(fenced) == wanted
        except ValueError:  # not a command line shlex can split
            same = False
        if same:
            before = "\n".join(lines[:start])
            after = "\n".join(lines[end:])
            text = before + ("\n" if before else "") + section + \
                ("\n" + after if after else "")
            break
    else:
        text = text.rstrip("\n") + ("\n\n" if text.strip() else "") + section
    with open(path + ".tmp", "w") as file:
        file.write(text)
    os.replace(path + ".tmp", path)
    return path


def scaling(rows, scene_knobs):
    """Per scene (smallest first): every method's wall time and its growth
    from the previous scene, community_mapper's peak memory and the share of
    its time each phase took."""
    if len(scene_knobs) < 2:
        return []
    methods = [method for method in METHODS
               if any(row["method"] == method for row in rows)]
    lines = ["### Scaling", "",
             "| scene | images | " + " | ".join(
                 f"{LABELS[method]} s (growth)" for method in methods) +
             " | community_mapper peak MB | " +
             " | ".join(f"{phase} share" for phase in PHASES) + " |",
             "|" + "---|" * (len(methods) + 3 + len(PHASES))]
    previous = {}
    num_images = {row["scene"]: row["images"] for row in rows}
    for scene in sorted(scene_knobs, key=lambda scene: num_images[scene]):
        scene_rows = {row["method"]: row for row in rows
                      if row["scene"] == scene}
        cells = []
        for method in methods:
            row = scene_rows.get(method)
            if row is None:
                cells.append("n/a")
                continue
            cell = f"{row['wall_s']:.1f}"
            if method in previous:
                cell += f" (x{row['wall_s'] / previous[method]:.2f})"
            cells.append(cell)
            previous[method] = row["wall_s"]
        community = scene_rows.get("community", {})
        cells.append(f"{community.get('peak_rss_mb', float('nan')):.0f}")
        for phase in PHASES:
            seconds = community.get(
                "phase_" + phase.lower().replace(" ", "_") + "_s",
                float("nan"))
            share = 100 * seconds / community.get("wall_s", float("nan"))
            cells.append(f"{share:.2f}%" if share < 1 else f"{share:.1f}%")
        lines.append(f"| {scene} | {num_images[scene]} | " +
                     " | ".join(cells) + " |")
    lines.append("")
    return lines


def plot(rows, scene_knobs, out_dir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # (1) Wall time against number of images.
    methods = [method for method in METHODS
               if any(row["method"] == method for row in rows)]
    figure, axes = plt.subplots(figsize=(6, 4.5))
    for method in methods:
        points = sorted((row["images"], row["wall_s"]) for row in rows
                        if row["method"] == method)
        axes.plot([p[0] for p in points], [p[1] for p in points], "o-",
                  color=COLORS[method], label=LABELS[method])
    axes.set_xlabel("images")
    axes.set_ylabel("wall time (s)")
    axes.set_title("Wall time against scene size")
    axes.grid(alpha=0.3)
    axes.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(os.path.join(out_dir, "time_vs_images.png"), dpi=120)
    plt.close(figure)

    # (2) Top-down camera centres per method, after alignment.
    for scene in scene_knobs:
        methods = [row["method"] for row in rows if row["scene"] == scene]
        figure, all_axes = plt.subplots(1, len(methods) + 1,
                                        figsize=(4 * (len(methods) + 1), 4.3))
        centers = {}
        for method in methods:
            path = os.path.join(out_dir, scene, method + "_centers.txt")
            centers[method] = read_centers(path)
        communities = read_communities(
            os.path.join(out_dir, scene, "community", "communities.txt"))
        axes = all_axes[0]
        all_truth = {}
        for method in methods:
            for name, (_, truth) in centers[method].items():
                all_truth[name] = (truth[0], truth[1])
        axes.scatter([p[0] for p in all_truth.values()],
                     [p[1] for p in all_truth.values()], s=3, c="black")
        axes.set_title("ground truth", fontsize=9)
        for axes, method in zip(all_axes[1:], methods):
            entries = centers[method]
            if method == "community":
                colors = [plt.cm.tab10(communities.get(name, -1) % 10)
                          for name in entries]
            else:
                colors = COLORS[method]
            axes.scatter([aligned[0] for aligned, _ in entries.values()],
                         [aligned[1] for aligned, _ in entries.values()],
                         s=3, c=colors)
            row = [r for r in rows
                   if r["scene"] == scene and r["method"] == method][0]
            axes.set_title(f"{LABELS[method]}\n{row['registered']} images, "
                           f"{row['models']} model(s), median err "
                           f"{row['median_pos_err']:.3f}", fontsize=8)
        for axes in all_axes:
            axes.set_aspect("equal")
            axes.tick_params(labelsize=7)
            if all_truth:
                xs = [p[0] for p in all_truth.values()]
                ys = [p[1] for p in all_truth.values()]
                margin = 0.05 * (max(xs) - min(xs) + 1)
                axes.set_xlim(min(xs) - margin, max(xs) + margin)
                axes.set_ylim(min(ys) - margin, max(ys) + margin)
        figure.suptitle(f"Scene {scene}: camera centres from above, aligned "
                        f"to the ground truth (community_mapper coloured by "
                        f"community)", fontsize=10)
        figure.tight_layout(rect=(0, 0, 1, 0.9))
        figure.savefig(os.path.join(out_dir, f"cameras_{scene}.png"), dpi=110)
        plt.close(figure)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scenes", nargs="*", default=None,
                        help="scenes or groups, see above (default: small "
                        "medium)")
    parser.add_argument("--quick", action="store_true",
                        help="one tiny scene: checks that the benchmark works")
    parser.add_argument("--out", default=os.path.join(ROOT, "benchmark"),
                        help="output folder (default: benchmark/)")
    parser.add_argument("--threads", type=int, default=os.cpu_count(),
                        help="threads for colmap mapper")
    parser.add_argument("--partition_graph", type=int, default=0,
                        metavar="N",
                        help="also time community detection alone on a "
                        "generated view graph of N images (e.g. 100000; "
                        "build/partition_benchmark)")
    parser.add_argument("--seeds", default="0",
                        help="comma-separated PRNG seeds (--default_random_seed): "
                        "every method runs once per seed (default: 0, "
                        "COLMAP's default)")
    parser.add_argument("--methods", default=",".join(METHODS),
                        help="comma-separated subset of " + ",".join(METHODS) +
                        " (community always runs: hier_fair needs its "
                        "community sizes)")
    parser.add_argument("--doc", metavar="PATH",
                        help="also write the Markdown results into PATH "
                        "(e.g. docs/benchmark.md) as a section headed by "
                        "the scenes and this command line, replacing the "
                        "section of the same command line if there is one")
    parser.add_argument("--draws", type=int, default=0, metavar="N",
                        help="run every generated scene named as N draws, "
                        "NAME_s1 ... NAME_sN, and give the robustness table "
                        "(community_mapper against mapper on every draw) "
                        "instead of a table per scene")
    parser.add_argument("--reuse", default="", metavar="M,...",
                        help="methods whose earlier runs on a scene, "
                        "recorded in OUT, are taken instead of run again "
                        "(e.g. mapper, while community_mapper changes)")
    arguments = parser.parse_args()
    if arguments.doc and not os.path.isdir(
            os.path.dirname(os.path.abspath(arguments.doc))):
        parser.error(f"--doc {arguments.doc}: its folder does not exist")
    methods = arguments.methods.split(",")
    for method in methods:
        if method not in METHODS:
            parser.error(f"unknown method {method}")
    if "community" not in methods:
        methods.append("community")
    methods = [method for method in METHODS if method in methods]
    reuse = [method for method in arguments.reuse.split(",") if method]
    for method in reuse:
        if method not in METHODS:
            parser.error(f"--reuse: unknown method {method}")
    try:
        seeds = [int(seed) for seed in arguments.seeds.split(",")]
    except ValueError:
        parser.error(f"--seeds {arguments.seeds}: give integers, e.g. 0,1,2")
    if len(set(seeds)) != len(seeds) or min(seeds) < 0:
        parser.error(f"--seeds {arguments.seeds}: give distinct seeds >= 0")
    scenes, families = [], []
    default_scenes = [] if arguments.partition_graph else ["small", "medium"]
    for scene in (["quick"] if arguments.quick else
                  (arguments.scenes or default_scenes)):
        for member in GROUPS.get(scene, [scene]):
            if (generated_knobs(member) is None and member not in REAL and
                    not SUBSET_PATTERN.match(member) and
                    not SEQUENCE_PATTERN.match(member)):
                parser.error(f"unknown scene {member}")
            photos = "southbuilding" if (SUBSET_PATTERN.match(member) or
                                         SEQUENCE_PATTERN.match(member)) \
                else member
            if photos in REAL and not os.path.isdir(
                    os.path.join(SHARED_DATA, REAL[photos]["path"])):
                log(f"== Scene {member}: skipped, "
                    f"{os.path.join(SHARED_DATA, REAL[photos]['path'])} is "
                    f"absent")
                continue
            if arguments.draws > 0:
                if member not in SCENES:
                    parser.error(f"--draws: {member} is not a generated "
                                 "scene")
                families.append(member)
                scenes += [f"{member}_s{draw}"
                           for draw in range(1, arguments.draws + 1)]
            elif member not in scenes:
                scenes.append(member)
    for binary in (COLMAP, SCENE_GENERATOR, MODEL_EVALUATOR):
        if not os.path.exists(binary):
            parser.error(f"{binary} is missing: run scripts/build.sh first")
    os.makedirs(arguments.out, exist_ok=True)

    rows = []
    scene_knobs = {}
    for scene in scenes:
        scene_rows, knobs = run_scene(scene, arguments.out, arguments.threads,
                                      methods, seeds, reuse)
        rows += scene_rows
        scene_knobs[scene] = knobs

    fields = []
    for row in rows:
        fields += [key for key in row if key not in fields]
    with open(os.path.join(arguments.out, "results.csv"), "w",
              newline="") as file:
        writer = csv.DictWriter(file, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    if families:
        table = "\n".join(robustness_section(
            rows, families, range(1, arguments.draws + 1)))
    else:
        table = markdown(rows, scene_knobs, seeds) if rows else ""
    if arguments.partition_graph > 0:
        table += partition_graph_section(arguments.partition_graph)
    command = command_line(sys.argv)
    with open(os.path.join(arguments.out, "results.md"), "w") as file:
        file.write("# community_mapper benchmark\n\n```\n" + command +
                   "\n```\n\n" + table + "\n")
    if arguments.doc:
        write_doc_section(arguments.doc, command,
                          doc_section(families or scenes, command, table))
    plotted = False
    if rows and not families:
        try:
            plot([row for row in rows if row["seed"] == seeds[0]],
                 scene_knobs, arguments.out)
            plotted = True
        except ImportError as error:
            # The figures are in results.md and results.csv all the same.
            log(f"No plots ({error}): install python3-matplotlib "
                "(scripts/install_deps.sh does) for them")
    print(table)
    log(f"Results in {arguments.out}: results.md, results.csv" +
        (", time_vs_images.png, cameras_<scene>.png" if plotted else "") +
        (f"; section in {arguments.doc}" if arguments.doc else ""))


if __name__ == "__main__":
    main()
