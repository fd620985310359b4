#!/usr/bin/env python3
"""Writes a two-handed session on a baked liver: a grasper takes the edge of a lobe,
lifts it 20 mm and holds it while a probe presses the surface beside it; then both let go.

    PYTHONPATH=build/python python3 tools/sessions/retract_and_probe.py demo_output/liver.organ \\
        -o data_samples/liver_retract_and_probe.session

The lobe's edge is the thinnest place (measured along the inward normal) among the
surface vertices that face the laparoscope (anterior, −y in LPS) and lie in the farther
half from the clamp; the probe's site is the thickest anterior vertex 25–40 mm from it.
Both tools approach along the outward normal from 10 mm away. The file is session
format 3 (docs/session-format.md): positions in mm, model frame.
"""
import argparse
import sys

import numpy as np

import organsim

ANTERIOR = np.array([0.0, -1.0, 0.0])  # LPS: the patient lies on the back, the laparoscope looks down onto −y


def vertex_normals(vertices, triangles):
    """Area-weighted outward unit normals (the surface is closed and outward-wound)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    face = np.cross(b - a, c - a)
    normals = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(normals, triangles[:, k], face)
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)


def thickness(vertices, triangles, origin, direction):
    """m: the distance from `origin` along `direction` to the surface's first triangle (Möller–Trumbore)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    e1, e2 = b - a, c - a
    p = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-15
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = origin - a
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    v = (q @ direction) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-4)
    return t[hit].min() if hit.any() else np.inf


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model", help="a baked liver (.organ)")
    parser.add_argument("-o", "--output", required=True, help="the session file to write")
    parser.add_argument("--hold", type=float, default=1.8,
                        help="seconds the edge is held up (default 1.8; tools/scripts/soak_held_grasp.sh holds it for minutes)")
    args = parser.parse_args()
    if not args.hold >= 1.5:
        sys.exit("--hold must be at least 1.5 s: the probe presses while the edge is held up")

    model = organsim.load(args.model)
    vertices = np.asarray(model.surface_vertices, dtype=float)
    triangles = np.asarray(model.surface_triangles, dtype=np.int64)
    normals = vertex_normals(vertices, triangles)
    clamp = np.asarray(model.fixed_points, dtype=float)[0]
    from_clamp = np.linalg.norm(vertices - clamp, axis=1)
    facing = normals @ ANTERIOR > 0.7
    far = from_clamp > np.median(from_clamp)
    candidates = np.flatnonzero(facing & far)
    if candidates.size == 0:
        sys.exit("no anterior surface far from the clamp: is this a liver in the LPS frame?")
    depth = np.array([thickness(vertices, triangles, vertices[i] - 1e-4 * normals[i], -normals[i]) for i in candidates])
    graspable = depth > 0.006  # a sliver thinner than the jaws' bite is not a lobe's edge
    edge = candidates[graspable][np.argmin(depth[graspable])]
    apart = np.linalg.norm(vertices - vertices[edge], axis=1)
    beside = np.flatnonzero(facing & (apart > 0.025) & (apart < 0.040))
    if beside.size == 0:
        sys.exit("no anterior surface 25-40 mm from the lobe's edge")
    beside_depth = np.array([thickness(vertices, triangles, vertices[i] - 1e-4 * normals[i], -normals[i])
                             for i in beside])
    probe = beside[np.argmax(beside_depth)]

    def at(vertex, outward_mm):
        return (vertices[vertex] + outward_mm * 1e-3 * normals[vertex]) * 1e3

    # (time s, mm along the outward normal from the vertex)
    held_until = 1.9 + args.hold
    grasper = [(0.0, 10), (0.5, 0), (0.7, -2), (0.9, -2), (1.9, 20), (held_until, 20), (held_until + 0.4, 40)]
    prober = [(0.0, 10), (1.9, 10), (2.2, 0), (2.4, -5), (3.0, -5), (3.3, 10), (held_until + 0.4, 10)]
    lines = [
        "# organsim session 3",
        f"# Written by tools/sessions/retract_and_probe.py from {args.model} (model frame, mm).",
        f"# Tool 1, a grasper, presses 2 mm into the lobe's edge at {at(edge, 0).round(2).tolist()}, closes its",
        "# jaws, lifts the edge 20 mm along its outward normal, holds it, opens and draws back.",
        f"# Tool 2, a probe, presses 5 mm into {at(probe, 0).round(2).tolist()} while the edge is held up.",
        "tip,1,2.5",
        "tip,2,2.5",
        "jaw,1,0.8,closed",
        f"jaw,1,{held_until - 0.1:g},open",
        "# time_s,tool,x_mm,y_mm,z_mm",
    ]
    for tool, (vertex, path) in enumerate([(edge, grasper), (probe, prober)], start=1):
        for time, outward in path:
            x, y, z = at(vertex, outward)
            lines.append(f"{time:.3f},{tool},{x:.3f},{y:.3f},{z:.3f}")
    with open(args.output, "w", encoding="utf-8") as out:
        out.write("\n".join(lines) + "\n")
    print(f"lobe edge {depth[graspable].min() * 1e3:.1f} mm thick, {from_clamp[edge] * 1e3:.0f} mm from the clamp; "
          f"probe site {beside_depth.max() * 1e3:.1f} mm thick, {apart[probe] * 1e3:.0f} mm from the edge")
    return 0


if __name__ == "__main__":
    sys.exit(main())
