#!/usr/bin/env python3
"""Writes the meshes of cornell_marble.toml (millimetres, +Y up): a 200 mm Cornell box open at
the front (z = 200) and a 60 x 120 x 60 mm block on its floor, turned 15 degrees about Y.

- cornell_white.obj: floor (y = 0), ceiling (y = 200) and back wall (z = 0), one quad each;
- cornell_red.obj: the left wall (x = 0); cornell_green.obj: the right wall (x = 200);
- cornell_block.obj: the block, each face a grid of 10 mm quads (the user's vertices, where a
  bake reports radiance).

Every face is counter-clockwise about the side that faces into the box (the walls) or out of
the block, so `sides = "front"` is the side the light reaches.
"""

import math

S = 200.0
BLOCK = (60.0, 120.0, 60.0)
TURN_DEG = 15.0
CELL = 10.0


def write(name, comment, verts, faces):
    with open(name, "w") as f:
        f.write(f"# {comment} (gen_cornell.py, for cornell_marble.toml)\n")
        for p in verts:
            f.write("v {:.6g} {:.6g} {:.6g}\n".format(*p))
        for q in faces:
            f.write("f " + " ".join(str(i + 1) for i in q) + "\n")


def quads(corner_lists):
    verts, faces = [], []
    for corners in corner_lists:
        faces.append([len(verts) + k for k in range(4)])
        verts.extend(corners)
    return verts, faces


def walls():
    floor = [(0, 0, 0), (0, 0, S), (S, 0, S), (S, 0, 0)]  # faces +y
    ceiling = [(0, S, 0), (S, S, 0), (S, S, S), (0, S, S)]  # faces -y
    back = [(0, 0, 0), (S, 0, 0), (S, S, 0), (0, S, 0)]  # faces +z
    left = [(0, 0, 0), (0, S, 0), (0, S, S), (0, 0, S)]  # faces +x
    right = [(S, 0, 0), (S, 0, S), (S, S, S), (S, S, 0)]  # faces -x
    write("cornell_white.obj", "floor, ceiling and back wall", *quads([floor, ceiling, back]))
    write("cornell_red.obj", "the left wall", *quads([left]))
    write("cornell_green.obj", "the right wall", *quads([right]))


def block():
    size = BLOCK
    n = [round(s / CELL) for s in size]
    index, verts, faces = {}, [], []
    turn = math.radians(TURN_DEG)

    def place(p):
        x, y, z = p[0] - size[0] / 2, p[1], p[2] - size[2] / 2
        c, s = math.cos(turn), math.sin(turn)
        return (S / 2 + c * x + s * z, y, S / 2 - s * x + c * z)

    def vid(p):
        key = tuple(round(c, 6) for c in p)
        if key not in index:
            index[key] = len(verts)
            verts.append(place(key))
        return index[key]

    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        for side in (0, 1):
            for i in range(n[u]):
                for j in range(n[v]):
                    q = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = side * size[axis]
                        p[u] = size[u] * (i + di) / n[u]
                        p[v] = size[v] * (j + dj) / n[v]
                        q.append(vid(p))
                    # (u, v, axis) right-handed: counter-clockwise about +axis.
                    right_handed = (u + 1) % 3 == v
                    if right_handed != (side == 1):
                        q.reverse()
                    faces.append(q)
    write("cornell_block.obj", "a 60 x 120 x 60 mm block, turned 15 degrees", verts, faces)


if __name__ == "__main__":
    walls()
    block()
