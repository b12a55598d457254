#!/usr/bin/env python3
"""Writes box.obj: a 2 x 1 x 1 box whose faces are grids of quads (20 x 10 x 10), so the
per-vertex radiance of a bake is resolved across each face; used by layered_block.toml."""

N = {0: 20, 1: 10, 2: 10}
SIZE = [2.0, 1.0, 1.0]


def main():
    verts, vl, faces = {}, [], []

    def vid(p):
        k = tuple(round(c, 6) for c in p)
        if k not in verts:
            verts[k] = len(vl) + 1
            vl.append(k)
        return verts[k]

    for axis in range(3):
        for sign in (-1, 1):
            u, v = [a for a in range(3) if a != axis]
            for i in range(N[u]):
                for j in range(N[v]):
                    q = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = sign * SIZE[axis] / 2
                        p[u] = -SIZE[u] / 2 + SIZE[u] * (i + di) / N[u]
                        p[v] = -SIZE[v] / 2 + SIZE[v] * (j + dj) / N[v]
                        q.append(vid(p))
                    if (sign > 0) != ((u + 1) % 3 == v):
                        q = q[::-1]
                    faces.append(q)
    with open("box.obj", "w") as f:
        f.write("# a 2 x 1 x 1 box, subdivided (gen_box.py) for layered_block.toml\n")
        for p in vl:
            f.write("v {:g} {:g} {:g}\n".format(*p))
        for q in faces:
            f.write("f {:d} {:d} {:d} {:d}\n".format(*q))


if __name__ == "__main__":
    main()
