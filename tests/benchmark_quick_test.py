#!/usr/bin/python3
"""Runs scripts/benchmark.py --quick and checks that it reports every figure
for every method (not how fast anything is)."""

import csv
import math
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def check_seed_variants():
    """NAME_sS draws a generated scene of kind NAME with seed S, its other
    knobs unchanged; anything else is not a generated scene."""
    sys.path.insert(0, os.path.join(ROOT, "scripts"))
    import benchmark
    chain = benchmark.generated_knobs("chain")
    chain7 = benchmark.generated_knobs("chain_s7")
    assert chain7["seed"] == 7 and chain["seed"] != 7, (chain, chain7)
    assert dict(chain7, seed=chain["seed"]) == chain, chain7
    # A scene whose own knobs set a seed takes the variant's.
    assert benchmark.generated_knobs("courtyard_s9")["seed"] == 9
    assert benchmark.generated_knobs("huge_loop_s2")["close_loop"] == 1
    for name in ("castle", "sb60_2", "nosuchscene_s3", "chain_s"):
        assert benchmark.generated_knobs(name) is None, name


def check_ground_truth_start(out, community):
    """scripts/ground_truth_start.py on the quick scene's merged model: one
    row per start, each cost no higher after its adjustment than before, and
    the start from the ground truth still near it after five iterations."""
    result = subprocess.run(
        [sys.executable, os.path.join(ROOT, "scripts", "ground_truth_start.py"),
         "--model", os.path.join(out, "quick", "community", "0"),
         "--ground_truth", os.path.join(out, "quick", "scene", "ground_truth"),
         "--out", os.path.join(out, "ground_truth_start"), "--iterations", "5",
         "--model_iterations", "2"],
        check=True, capture_output=True, text=True)
    rows = [[cell.strip() for cell in line.strip("|").split("|")]
            for line in result.stdout.splitlines()
            if line.startswith(("| ground truth", "| the model"))]
    assert [row[:2] for row in rows] == [["ground truth", "5"],
                                         ["the model", "2"]], result.stdout
    for row in rows:
        assert float(row[3]) <= float(row[2]), row
    extent = float(community["median_pos_err"]) / max(
        float(community["median_pos_err_frac"]), 1e-12)
    median_from_truth = float(rows[0][4].split("/")[0])
    assert 0 <= median_from_truth < 0.01 * extent, (rows[0], extent)


def check_seeds():
    """--seeds runs every method once per seed, with that seed: a row per
    method and seed, the first seed's runs where a run without --seeds puts
    them, the others' in SCENE/seedS/, and the table's seed summary."""
    out = tempfile.mkdtemp(prefix="benchmark_seeds_")
    subprocess.run([sys.executable, os.path.join(ROOT, "scripts",
                                                 "benchmark.py"),
                    "--quick", "--out", out, "--methods", "mapper,community",
                    "--seeds", "3,7"], check=True)
    rows = list(csv.DictReader(open(os.path.join(out, "results.csv"))))
    assert [(row["method"], row["seed"]) for row in rows] == [
        ("mapper", "3"), ("community", "3"), ("mapper", "7"),
        ("community", "7")], rows
    for path, seed in ((os.path.join(out, "quick"), 3),
                       (os.path.join(out, "quick", "seed7"), 7)):
        for method in ("mapper", "community"):
            log = open(os.path.join(path, method + ".log")).read()
            # /usr/bin/time -v logs the command it ran.
            assert f"--default_random_seed {seed}" in log, (path, method)
            assert os.path.isdir(os.path.join(path, method, "0")), path
    table = open(os.path.join(out, "results.md")).read()
    for text in ("colmap mapper, seed 7", "Over the seeds 3,7",
                 "of 2 seeds"):
        assert text in table, text
    result = subprocess.run(
        [sys.executable, os.path.join(ROOT, "scripts", "benchmark.py"),
         "--quick", "--out", out, "--seeds", "1,x"],
        capture_output=True, text=True)
    assert result.returncode != 0 and "--seeds" in result.stderr, result


def main():
    check_seed_variants()
    out = tempfile.mkdtemp(prefix="benchmark_quick_")
    subprocess.run([sys.executable, os.path.join(ROOT, "scripts",
                                                 "benchmark.py"),
                    "--quick", "--out", out], check=True)
    rows = list(csv.DictReader(open(os.path.join(out, "results.csv"))))
    methods = [row["method"] for row in rows]
    assert methods == ["mapper", "community", "hierarchical", "hier_fair",
                       "global"], \
        methods
    numeric = ["wall_s", "cpu_s", "peak_rss_mb", "models", "registered",
               "mean_reproj_px", "median_pos_err", "p90_pos_err",
               "median_pos_err_frac", "p90_pos_err_frac", "median_rot_err_deg",
               "time_vs_mapper", "time_vs_hierarchical", "time_vs_hier_fair",
               "time_vs_global", "error_vs_global", "memory_vs_mapper",
               "mean_pos_err"]
    for row in rows:
        assert row["exit"] == "0", row
        for field in numeric:
            value = float(row[field])
            assert math.isfinite(value) and value >= 0, (row["method"], field)
        assert float(row["wall_s"]) > 0 and float(row["peak_rss_mb"]) > 0
        assert int(row["registered"]) > 0, row
    # Image by image against the mapper: every other method is paired with
    # it on the images both registered.
    assert rows[0]["closer_than_mapper"] == "", rows[0]
    for row in rows[1:]:
        closer, common = int(row["closer_than_mapper"]), \
            int(row["common_images"])
        assert 0 <= closer <= common and common > 0, row
        assert common <= min(int(row["registered"]),
                             int(rows[0]["registered"])), row
    community = rows[1]
    for phase in ("partition", "communities", "pairwise_similarities",
                  "similarity_averaging", "global_refinement", "registration"):
        assert float(community[f"phase_{phase}_s"]) >= 0, phase
    assert int(community["communities"]) >= 2
    # Every community's own images, measured in its own model and in every
    # method's, each aligned on them alone; together they are the scene.
    entries = [entry.split(":") for entry in community["per_community"].split()]
    assert len(entries) == int(community["communities"]), entries
    assert sum(int(size) for _, size, _ in entries) == int(community["images"])
    for _, _, errors in entries:
        values = [float(value) for value in errors.split("/")]
        assert len(values) == 1 + len(methods), errors
        assert all(math.isfinite(value) and value >= 0 for value in values), \
            errors
    table = open(os.path.join(out, "results.md")).read()
    for text in ("colmap mapper", "colmap community_mapper",
                 "colmap global_mapper", "time / global",
                 "median error / global",
                 "time / mapper", "closer than mapper", "Bar:",
                 "Each community's own images"):
        assert text in table, text
    for png in ("time_vs_images.png", "cameras_quick.png"):
        path = os.path.join(out, png)
        assert os.path.getsize(path) > 10000, path
        assert open(path, "rb").read(8) == b"\x89PNG\r\n\x1a\n", path
    check_ground_truth_start(out, community)
    check_seeds()
    print(f"benchmark --quick reported every figure ({out})")


if __name__ == "__main__":
    main()
