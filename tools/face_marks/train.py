#!/usr/bin/env python3
"""Learn where CANDIDE-3's marked vertices lie among MediaPipe's face-mesh points.

The automatic fit reads MediaPipe's 468 face-mesh points on a picture of the head
(core/src/fit/automatic/learned_reading.rs). None of them is exactly where people mark an
eye corner, an alar wing or a chin: each sits a few millimetres off, by its own offset. This
script learns, for each of the ten vertices the shipped heads' landmark files mark, the
combination of face-mesh points and the offset that best predicts the vertex, from the
development members of `facewire population` (their references: landmark fits):

    mark(v) = sum_k w_k p_k + R s c    (sum_k w_k = 1)

with p_k face-mesh points on the surface (head units), R and s the rotation and scale of
the fit the face was read from (mask axes; s head units per mask unit) and c an offset in
mask units. The weights are scalars, so the sum turns and scales with the head; only the
offset needs the fit's frame. Mirror pairs of vertices (left and right eye corners, alar
wings, mouth corners) share one model, mirrored; the face-mesh points' own mirror map is
comes from the texture layout of MediaPipe's canonical face mesh (Apache-2.0, the
`uv_coords.js` of the npm package @tensorflow-models/facemesh 0.0.5) and is written beside
it, for the reading to make every point symmetric.

How many points, and how hard their weights are held to zero (a ridge), is chosen by
five-fold cross-validation over the development members alone (a head's variants in one
fold); the held-out members are
only reported. Data: `facewire population --json` (each member's face-mesh points and its
reference's marked vertices in the fitted mask's frame, mask units). Run:

    ./target/release/facewire population --json > /tmp/population.jsonl
    (cd /tmp && npm pack @tensorflow-models/facemesh@0.0.5 && tar xzf tensorflow-models-facemesh-0.0.5.tgz)
    python3 tools/face_marks/train.py /tmp/population.jsonl /tmp/package/dist/uv_coords.js \\
        data/models/face_marks.toml

Needs numpy. Prints each vertex's mean error (mm) on the development members (cross-
validated) and on the held-out ones.
"""
import json
import re
import sys

import numpy as np

MESH_POINTS = 468
# CANDIDE-3 vertices the landmark files mark, with their mirror partners on the mask: eye
# corners (outer 20/53, inner 23/56), nose tip 5, alar wings 26/59, mouth corners 31/64,
# chin 10.
MASK_MIRROR = {20: 53, 53: 20, 23: 56, 56: 23, 5: 5, 26: 59, 59: 26, 31: 64, 64: 31, 10: 10}
# The points considered for a vertex: the nearest this many by the spread of their offset.
CANDIDATES = 40
POINT_COUNTS = (1, 2, 4, 8, 12, 16)
RIDGES = (1e-4, 1e-3, 1e-2)
FOLDS = 5


def load(path):
    members = []
    for line in open(path):
        row = json.loads(line)
        fit = row["result"].get("Ok")
        if fit is None:
            continue
        points = np.array([p if p is not None else [np.nan] * 3 for p in fit["face_points_mask_units"]])
        if points.shape != (MESH_POINTS, 3):
            raise SystemExit(f"{row['member']}: {points.shape[0]} face-mesh points, not {MESH_POINTS}")
        members.append({
            "name": row["member"],
            "held_out": row["held_out"],
            "points": points,
            "reference": {v: np.array(p) for v, p in fit["reference_mask_units"]},
            "mm": fit["mm_per_mask_unit"],
            # Variants of one head (its face cut, low-poly, turned) share a fold.
            "identity": row["member"].split(",")[0].split(" turned")[0],
        })
    return members


def mirror_map(uv_coords_js):
    """Each face-mesh point's mirror image, from the texture coordinates of MediaPipe's
    canonical face mesh (a mirror-symmetric layout: point k's mirror image is the point at
    (1 - u, v))."""
    text = open(uv_coords_js).read()
    uv = np.array(re.findall(r"\[\s*([0-9.e-]+)\s*,\s*([0-9.e-]+)\s*\]", text), dtype=float)
    if uv.shape != (MESH_POINTS, 2):
        raise SystemExit(f"{uv_coords_js}: {len(uv)} texture coordinates, not {MESH_POINTS}")
    flipped = uv * np.array([-1.0, 1.0]) + np.array([1.0, 0.0])
    apart = np.linalg.norm(uv[:, None, :] - flipped[None, :, :], axis=2)
    mirror = apart.argmin(axis=1)
    worst = apart[np.arange(MESH_POINTS), mirror].max()
    if any(mirror[mirror[k]] != k for k in range(MESH_POINTS)) or worst > 0.005:
        raise SystemExit(f"{uv_coords_js}: the texture layout is not mirror-symmetric (worst {worst:.4f})")
    print(f"mirror map: {int((mirror == np.arange(MESH_POINTS)).sum())} points on the midline, "
          f"pairs within {worst:.4f} of each other's mirror image in texture space", file=sys.stderr)
    return mirror


def samples(members, vertex, mirror):
    """(points, target, mm per mask unit, fold) for `vertex`, and its mirror partner's data
    mirrored onto it."""
    flip = np.array([-1.0, 1.0, 1.0])
    identities = sorted({m["identity"] for m in members})
    out = []
    for m in members:
        i = identities.index(m["identity"])
        out.append((m["points"], m["reference"][vertex], m["mm"], i))
        partner = MASK_MIRROR[vertex]
        out.append((m["points"][mirror] * flip, m["reference"][partner] * flip, m["mm"], i))
    return out


def fit_model(data, count, ridge, mirror=None):
    """The `count` points whose offsets to the target spread least, and their weights and
    offset by ridge regression. With `mirror` (for a vertex on the midline, whose samples
    come in mirror pairs) the points are completed with their mirror images, so that the
    solution is its own mirror image."""
    points = np.stack([d[0] for d in data])
    target = np.stack([d[1] for d in data])
    offsets = target[:, None, :] - points
    spread = np.linalg.norm(offsets - offsets.mean(axis=0), axis=2)
    score = spread.mean(axis=0)
    chosen = [int(k) for k in np.argsort(score)[:count]]
    if mirror is not None:
        chosen += [int(mirror[k]) for k in chosen if int(mirror[k]) not in chosen]
    first, rest = chosen[0], chosen[1:]
    n = len(data)
    columns = [(points[:, k] - points[:, first]).reshape(-1) for k in rest]
    design = np.hstack([np.stack(columns, axis=1) if columns else np.zeros((3 * n, 0)), np.tile(np.eye(3), (n, 1))])
    goal = (target - points[:, first]).reshape(-1)
    penalty = ridge * n * np.diag([1.0] * len(rest) + [0.0] * 3)
    solution = np.linalg.solve(design.T @ design + penalty, design.T @ goal)
    weights = np.concatenate([[1.0 - solution[:len(rest)].sum()], solution[:len(rest)]])
    return {"points": chosen, "weights": weights, "offset": solution[len(rest):]}


def midline(vertex, mirror):
    """The face-mesh mirror map for a vertex on the mask's midline, else None."""
    return mirror if MASK_MIRROR[vertex] == vertex else None


def predict(model, points):
    return (model["weights"][:, None] * points[model["points"]]).sum(axis=0) + model["offset"]


def error_mm(model, data):
    return [np.linalg.norm(predict(model, p) - t) * mm for p, t, mm, _ in data]


def cross_validated(members, vertex, mirror, count, ridge):
    errors = []
    for fold in range(FOLDS):
        train = [d for d in samples(members, vertex, mirror) if d[3] % FOLDS != fold]
        test = [d for d in samples(members, vertex, mirror) if d[3] % FOLDS == fold and not np.isnan(d[0]).any()]
        train = [d for d in train if not np.isnan(d[0]).any()]
        errors += error_mm(fit_model(train, count, ridge, midline(vertex, mirror)), test[::2])
    return float(np.mean(errors))


def main(source, uv_coords_js, out):
    members = load(source)
    development = [m for m in members if not m["held_out"]]
    held_out = [m for m in members if m["held_out"]]
    mirror = mirror_map(uv_coords_js)
    # One vertex of each mirror pair; its partner's model is its mirror image.
    vertices = [20, 23, 5, 26, 31, 10]
    grid = {}
    for count in POINT_COUNTS:
        for ridge in RIDGES:
            grid[(count, ridge)] = np.mean([cross_validated(development, v, mirror, count, ridge) for v in vertices])
            print(f"{count:2d} points, ridge {ridge:g}: cross-validated mean error {grid[(count, ridge)]:.3f} mm", file=sys.stderr)
    count, ridge = min(grid, key=grid.get)
    print(f"chosen: {count} points, ridge {ridge:g}", file=sys.stderr)
    flip = np.array([-1.0, 1.0, 1.0])
    models = {}
    for v in vertices:
        clean = [d for d in samples(development, v, mirror) if not np.isnan(d[0]).any()]
        model = fit_model(clean, count, ridge, midline(v, mirror))
        models[v] = model
        partner = MASK_MIRROR[v]
        if partner != v:
            models[partner] = {"points": [int(mirror[k]) for k in model["points"]], "weights": model["weights"], "offset": model["offset"] * flip}
    for v in sorted(models):
        dev = np.mean(error_mm(models[v], [(m["points"], m["reference"][v], m["mm"], 0) for m in development if not np.isnan(m["points"][models[v]["points"]]).any()]))
        held = np.mean(error_mm(models[v], [(m["points"], m["reference"][v], m["mm"], 0) for m in held_out if not np.isnan(m["points"][models[v]["points"]]).any()]))
        print(f"vertex {v:2d}: development {dev:.2f} mm (cross-validated {cross_validated(development, v, mirror, count, ridge):.2f}), held out {held:.2f} mm", file=sys.stderr)
    with open(out, "w") as f:
        f.write("# Where CANDIDE-3's marked vertices lie among MediaPipe's face-mesh points: written by\n")
        f.write("# tools/face_marks/train.py from `facewire population --json` (development members only,\n")
        f.write(f"# {len(development)} of them; {count} points a vertex, ridge {ridge:g}, chosen by {FOLDS}-fold cross-validation).\n")
        f.write("# mark = sum(weights * points) + offset turned and scaled by the fit (mask units, mask axes).\n")
        f.write("# `mirror`: each face-mesh point's mirror image across the face, from the texture layout of\n")
        f.write("# MediaPipe's canonical face mesh (Apache-2.0; data/models/LICENSES.md).\n")
        f.write("mirror = [" + ", ".join(str(int(k)) for k in mirror) + "]\n")
        for v in sorted(models):
            m = models[v]
            f.write(f"\n[[mark]]\nmask_vertex = {v}\n")
            f.write("points = [" + ", ".join(str(k) for k in m["points"]) + "]\n")
            f.write("weights = [" + ", ".join(f"{w:.6f}" for w in m["weights"]) + "]\n")
            f.write("offset = [" + ", ".join(f"{c:.6f}" for c in m["offset"]) + "]\n")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    main(*sys.argv[1:])
