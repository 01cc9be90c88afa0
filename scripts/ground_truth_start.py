#!/usr/bin/python3
"""Does a model's error come from its data or from where its optimisation
stopped? Bundle adjustment of the model's own observations, started from the
ground truth.

    scripts/ground_truth_start.py --model M --ground_truth GT --out DIR
                                  [--iterations 10,50,200]
                                  [--model_iterations N]

The start model keeps M's images, 2D points and tracks (every observation,
exactly as M has them) and takes its poses and intrinsics from GT, moved
into M's frame by the similarity that fits the camera centres; every point
is triangulated anew (linear, from its whole track). `colmap
bundle_adjuster` then runs from that start for each iteration count, and
from M itself, with the same options (`bundle_adjuster` holds the gauge
with the first image it reads: the first by name in the start model, the
first in M's file for M). For each result the script prints the
final cost (Ceres' RMS reprojection error) and the camera error against GT
(build/model_evaluator).

`--model_iterations` bounds the adjustment from M (default: the largest of
`--iterations`).

Reading: if the adjustment from the ground truth stops near it at a cost at
most M's, the observations determine the geometry and M's error is the
optimisation's; if it walks metres away while the cost changes in the
fourth digit, or stops at a higher cost, the observations leave the
geometry undetermined at that level, and which method lands closer to the
ground truth is not decided by the data. Needs python3-numpy and the build.
"""

import argparse
import os
import re
import subprocess
import sys

import numpy as np

from benchmark import COLMAP, MODEL_EVALUATOR, evaluate

# Camera models whose parameters are their focal lengths (this many), the
# principal point, then distortion (ignored for the linear triangulation of
# the start; the adjustment refines from there).
NUM_FOCAL_LENGTHS = {
    "SIMPLE_PINHOLE": 1,
    "SIMPLE_RADIAL": 1,
    "RADIAL": 1,
    "PINHOLE": 2,
    "OPENCV": 2,
    "FULL_OPENCV": 2,
}


def quaternion_to_matrix(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def matrix_to_quaternion(r):
    w = np.sqrt(max(0.0, 1 + np.trace(r))) / 2
    x = np.copysign(np.sqrt(max(0.0, 1 + r[0, 0] - r[1, 1] - r[2, 2])) / 2,
                    r[2, 1] - r[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1 - r[0, 0] + r[1, 1] - r[2, 2])) / 2,
                    r[0, 2] - r[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1 - r[0, 0] - r[1, 1] + r[2, 2])) / 2,
                    r[1, 0] - r[0, 1])
    return np.array([w, x, y, z])


def data_lines(path):
    with open(path) as f:
        return [line for line in f if line.strip() and not line.startswith("#")]


def read_text_model(path):
    """cameras {id: [model, width, height, params...]}, images {name: {...}}"""
    cameras = {int(l.split()[0]): l.split()[1:] for l in
               data_lines(os.path.join(path, "cameras.txt"))}
    images = {}
    # An image with no 2D points has an empty second line, which
    # data_lines drops: read the file in pairs by position instead.
    with open(os.path.join(path, "images.txt")) as f:
        lines = [l for l in f if not l.startswith("#")]
    for header, points in zip(lines[0::2], lines[1::2]):
        v = header.split()
        images[v[9]] = {
            "id": int(v[0]),
            "R": quaternion_to_matrix(np.array(v[1:5], dtype=float)),
            "t": np.array(v[5:8], dtype=float),
            "camera_id": int(v[8]),
            "points2D": np.array(points.split(), dtype=float).reshape(-1, 3),
            "points_line": points,
        }
    return cameras, images


def to_text(model_path, out_path):
    os.makedirs(out_path, exist_ok=True)
    subprocess.run([COLMAP, "model_converter", "--input_path", model_path,
                    "--output_path", out_path, "--output_type", "TXT"],
                   check=True, stdout=subprocess.DEVNULL)


def fit_similarity(src, dst):
    """s, R, t minimising |dst - (s R src + t)|^2 (Umeyama 1991)."""
    mu_s, mu_d = src.mean(0), dst.mean(0)
    xs, xd = src - mu_s, dst - mu_d
    u, d, vt = np.linalg.svd(xd.T @ xs / len(src))
    e = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        e[2, 2] = -1
    r = u @ e @ vt
    s = np.trace(np.diag(d) @ e) / xs.var(0).sum()
    return s, r, mu_d - s * r @ mu_s


def write_start(model_txt, gt_txt, out):
    _, images = read_text_model(model_txt)
    gt_cameras, gt_images = read_text_model(gt_txt)
    names = sorted(images)
    missing = [n for n in names if n not in gt_images]
    if missing or len(names) < 3:
        sys.exit("error: every image of the model needs a ground-truth pose "
                 "(%d of %d missing, e.g. %s)" % (
                     len(missing), len(names), missing[:1]))
    centre = lambda im: -im["R"].T @ im["t"]
    s, r, t = fit_similarity(np.array([centre(gt_images[n]) for n in names]),
                             np.array([centre(images[n]) for n in names]))
    os.makedirs(out, exist_ok=True)
    intrinsics, poses = {}, {}
    with open(os.path.join(out, "cameras.txt"), "w") as f:
        for n in names:
            camera_id = images[n]["camera_id"]
            gt_camera = gt_cameras[gt_images[n]["camera_id"]]
            if camera_id in intrinsics:
                continue
            if gt_camera[0] not in NUM_FOCAL_LENGTHS:
                sys.exit("error: camera model %s of the ground truth is not "
                         "supported (%s)" % (gt_camera[0],
                                            ", ".join(NUM_FOCAL_LENGTHS)))
            params = np.array(gt_camera[3:], dtype=float)
            nf = NUM_FOCAL_LENGTHS[gt_camera[0]]
            intrinsics[camera_id] = (params[0], params[nf - 1], params[nf],
                                     params[nf + 1])
            f.write(" ".join([str(camera_id)] + gt_camera) + "\n")
    with open(os.path.join(out, "images.txt"), "w") as f:
        for n in names:
            im, gt = images[n], gt_images[n]
            rotation = gt["R"] @ r.T
            translation = -rotation @ (s * r @ centre(gt) + t)
            poses[im["id"]] = (rotation, translation, im)
            f.write("%d %s %s %d %s\n" % (
                im["id"], " ".join(map(repr, matrix_to_quaternion(rotation))),
                " ".join(map(repr, translation)), im["camera_id"], n))
            f.write(im["points_line"])
    with open(os.path.join(model_txt, "points3D.txt")) as fin, \
            open(os.path.join(out, "points3D.txt"), "w") as fout:
        for line in fin:
            if line.startswith("#") or not line.strip():
                continue
            v = line.split()
            track = np.array(v[8:], dtype=int).reshape(-1, 2)
            rows = []
            for image_id, point2D_idx in track:
                rotation, translation, im = poses[image_id]
                fx, fy, cx, cy = intrinsics[im["camera_id"]]
                x, y = im["points2D"][point2D_idx, :2]
                p = np.hstack([rotation, translation[:, None]])
                rows += [(x - cx) / fx * p[2] - p[0], (y - cy) / fy * p[2] - p[1]]
            xyz = np.linalg.svd(np.array(rows))[2][-1]
            xyz = xyz[:3] / xyz[3]
            fout.write("%s %s %s %s\n" % (v[0], " ".join(map(repr, xyz)),
                                          " ".join(v[4:8]), " ".join(v[8:])))
    return len(names)


def adjust(start, out, iterations, log):
    os.makedirs(out, exist_ok=True)
    with open(log, "w") as f:
        subprocess.run([COLMAP, "bundle_adjuster", "--input_path", start,
                        "--output_path", out,
                        "--BundleAdjustmentCeres.max_num_iterations",
                        str(iterations)], check=True, stdout=f, stderr=f)
    with open(log) as f:
        text = f.read()
    costs = re.findall(r"(Initial|Final) cost\s*:\s*([0-9.eE+-]+)", text)
    return dict(costs)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", required=True)
    parser.add_argument("--ground_truth", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--iterations", default="10,50,200")
    parser.add_argument("--model_iterations", type=int)
    args = parser.parse_args()
    for tool in (COLMAP, MODEL_EVALUATOR):
        if not os.path.exists(tool):
            sys.exit("error: %s not found: build first (scripts/build.sh)" % tool)
    iterations = [int(i) for i in args.iterations.split(",")]
    to_text(args.model, os.path.join(args.out, "model_txt"))
    to_text(args.ground_truth, os.path.join(args.out, "ground_truth_txt"))
    start = os.path.join(args.out, "start")
    n = write_start(os.path.join(args.out, "model_txt"),
                    os.path.join(args.out, "ground_truth_txt"), start)
    print("%d images; start: the model's tracks, ground-truth poses" % n)
    print("| start | iterations | cost before | cost after | median / p90 "
          "position error | median rotation error (deg) |")
    print("| --- | --- | --- | --- | --- | --- |")
    runs = [("ground truth", start, i) for i in iterations]
    runs.append(("the model", args.model,
                 args.model_iterations or max(iterations)))
    for label, source, i in runs:
        out = os.path.join(args.out, "%s_%d" % (label.split()[-1], i))
        cost = adjust(source, out, i, out + ".log")
        errors = evaluate(out, args.ground_truth, out + "_centers.txt")
        print("| %s | %d | %s | %s | %.6f / %.6f | %.6f |" % (
            label, i, cost.get("Initial", "?"), cost.get("Final", "?"),
            errors["median_position_error"], errors["p90_position_error"],
            errors["median_rotation_error_deg"]))


if __name__ == "__main__":
    main()
