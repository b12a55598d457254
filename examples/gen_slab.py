#!/usr/bin/env python3
"""Writes slab.obj: the block of `transcut acquire synth`'s default data set (40 x 40 x 12 nodes
at 0.5 mm: 19.5 x 19.5 x 5.5 mm, its corner at the origin, as the acquired voxel grid), its faces
grids of 0.5 mm quads so the per-vertex radiance of a bake resolves the cells; used by
acquire_veined_block.toml."""

SIZE = [19.5, 19.5, 5.5]
N = [39, 39, 11]


def main():
    verts, vl, faces = {}, [], []

    def vid(p):
        k = tuple(round(c, 6) for c in p)
        if k not in verts:
            verts[k] = len(vl) + 1
            vl.append(k)
        return verts[k]

    for axis in range(3):
        for side in (0, 1):
            u, v = [a for a in range(3) if a != axis]
            for i in range(N[u]):
                for j in range(N[v]):
                    q = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = side * SIZE[axis]
                        p[u] = SIZE[u] * (i + di) / N[u]
                        p[v] = SIZE[v] * (j + dj) / N[v]
                        q.append(vid(p))
                    if (side > 0) != ((u + 1) % 3 == v):
                        q = q[::-1]
                    faces.append(q)
    with open("slab.obj", "w") as f:
        f.write("# a 19.5 x 19.5 x 5.5 mm slab from the origin (gen_slab.py), for acquire_veined_block.toml\n")
        for p in vl:
            f.write("v {:g} {:g} {:g}\n".format(*p))
        for q in faces:
            f.write("f {:d} {:d} {:d} {:d}\n".format(*q))


if __name__ == "__main__":
    main()
