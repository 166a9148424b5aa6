#!/usr/bin/env python3
"""Generates terrain_ground.stl: 16 x 16 m of uneven seabed as a binary STL, in metres.

Object frame: z up, the mean seabed level at z = 0. Heights (metres) over a 0.25 m grid:
  two long swells (0.35 m and 0.2 m, 9-13 m wavelengths, oblique to the axes);
  a ridge of 0.6 m running diagonally with a saddle in it;
  four mounds (0.3-0.9 m, 1-2 m across) and two scour pits (0.4-0.5 m deep) near them;
  a 0.1 m ripple field (1.1 m wavelength) on one side.
Nothing stands higher than 1.2 m over the mean, so a vehicle 1.5 m above the mean level clears it.
The surface is one sheet (no sides or bottom): the simulator's sonar and collision checks use
triangles, and the seabed is only ever seen from above.

Usage: python3 make_terrain.py [out.stl]   (deterministic: same file every run)
"""
import math
import sys

from stl import write_stl

SIZE_M = 16.0
STEP_M = 0.25
MOUNDS = [  # (x, y, height, radius)
    (-3.5, 2.5, 0.9, 1.0),
    (2.0, -3.0, 0.5, 1.6),
    (4.5, 4.0, 0.3, 2.0),
    (-1.0, -5.0, 0.6, 1.2),
]
PITS = [(-2.2, 3.6, 0.5, 0.7), (3.3, -1.8, 0.4, 0.8)]  # (x, y, depth, radius)


def height(x, y):
    h = 0.35 * math.sin(2 * math.pi * (0.8 * x + 0.6 * y) / 13.0)
    h += 0.2 * math.sin(2 * math.pi * (-0.5 * x + 0.87 * y) / 9.0 + 1.0)
    # Ridge along y = -x + 1 with a saddle where it crosses y = 0.5.
    d = (x + y - 1.0) / math.sqrt(2.0)
    along = (y - x) / math.sqrt(2.0)
    h += 0.6 * math.exp(-(d / 0.9) ** 2) * (1.0 - 0.7 * math.exp(-(along / 1.5) ** 2))
    for mx, my, mh, r in MOUNDS:
        h += mh * math.exp(-((x - mx) ** 2 + (y - my) ** 2) / (r * r))
    for px, py, pd, r in PITS:
        h -= pd * math.exp(-((x - px) ** 2 + (y - py) ** 2) / (r * r))
    if x > 2.0:  # ripples on the east side, fading in over 1 m
        h += 0.1 * min(1.0, x - 2.0) * math.sin(2 * math.pi * y / 1.1)
    return h


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "terrain_ground.stl"
    n = int(round(SIZE_M / STEP_M))
    xs = [-0.5 * SIZE_M + i * STEP_M for i in range(n + 1)]
    grid = [[(x, y, height(x, y)) for x in xs] for y in xs]
    tris = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = grid[j][i], grid[j][i + 1], grid[j + 1][i + 1], grid[j + 1][i]
            tris += [(a, b, c), (a, c, d)]  # counter-clockwise seen from above: normals up
    write_stl(out, b"vog terrain, metres, z up, mean seabed at z = 0", tris)


if __name__ == "__main__":
    main()
