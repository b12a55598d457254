#!/usr/bin/env python3
"""Writes a box whose faces are grids of quads, so the per-vertex radiance of a bake resolves
each face. Two boxes of the examples, by name:

    python3 gen_box.py box    box.obj: 2 x 1 x 1, centred, 20 x 10 x 10 quads along the axes;
                              used by layered_block.toml
    python3 gen_box.py slab   slab.obj: the block of `transcut acquire synth`'s default data set
                              (40 x 40 x 12 nodes at 0.5 mm: 19.5 x 19.5 x 5.5 mm, its corner
                              at the origin like the acquired voxel grid), 0.5 mm quads; used by
                              acquire_veined_block.toml
"""

import sys

# name: (size, quads along each axis, corner at the origin (else centred), the file's comment)
BOXES = {
    "box": ([2.0, 1.0, 1.0], [20, 10, 10], False, "a 2 x 1 x 1 box, subdivided (gen_box.py) for layered_block.toml"),
    "slab": (
        [19.5, 19.5, 5.5],
        [39, 39, 11],
        True,
        "a 19.5 x 19.5 x 5.5 mm slab from the origin (gen_box.py slab), for acquire_veined_block.toml",
    ),
}


def box(size, n, at_origin):
    """The box's vertices and outward-facing quads (1-based indices, shared corners welded)."""
    verts, vl, faces = {}, [], []

    def vid(p):
        k = tuple(round(c, 6) for c in p)
        if k not in verts:
            verts[k] = len(vl) + 1
            vl.append(k)
        return verts[k]

    lo = [0.0 if at_origin else -s / 2 for s in size]
    for axis in range(3):
        for side in (0, 1):
            u, v = [a for a in range(3) if a != axis]
            for i in range(n[u]):
                for j in range(n[v]):
                    q = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = lo[axis] + side * size[axis]
                        p[u] = lo[u] + size[u] * (i + di) / n[u]
                        p[v] = lo[v] + size[v] * (j + dj) / n[v]
                        q.append(vid(p))
                    if (side > 0) != ((u + 1) % 3 == v):
                        q = q[::-1]
                    faces.append(q)
    return vl, faces


def main():
    if len(sys.argv) != 2 or sys.argv[1] not in BOXES:
        sys.exit("usage: python3 gen_box.py box|slab")
    name = sys.argv[1]
    size, n, at_origin, comment = BOXES[name]
    vl, faces = box(size, n, at_origin)
    with open(f"{name}.obj", "w") as f:
        f.write(f"# {comment}\n")
        for p in vl:
            f.write("v {:g} {:g} {:g}\n".format(*p))
        for q in faces:
            f.write("f {:d} {:d} {:d} {:d}\n".format(*q))


if __name__ == "__main__":
    main()
