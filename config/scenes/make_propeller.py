#!/usr/bin/env python3
"""Generates propeller_blades.stl: four blades of a ship propeller (thesis 4.4.2, the SS Curtiss
propeller, about 7 x 4 x 6 m with its shaft) as a binary STL, in metres.

Object frame: x = shaft axis (aft), blade disc in the y-z plane, hub centre at the origin. The hub and
the shaft are scene primitives (cylinders) in propeller.yaml; this file holds only the blades.

Each blade is a closed thin shell over (radius rho, chord position s):
  chord(rho)     elliptic outline, widest at mid-span;
  pitch angle    atan(P / (2 pi rho)) with pitch P = 4 m (a constant-pitch screw);
  thickness      tapering from root to tip.
A chord point at (rho, s) sits at angle phi_blade + s cos(theta) / rho around the axis and at
x = s sin(theta); the two faces are offset by +-thickness/2 along the face normal direction
(approximated by the axial direction rotated by the pitch angle).

Usage: python3 make_propeller.py [out.stl]   (deterministic: same file every run)
"""
import math
import sys

from stl import write_stl

PITCH_M = 4.0
HUB_RADIUS_M = 0.5
TIP_RADIUS_M = 3.0
MAX_CHORD_M = 1.4
BLADE_ANGLES_DEG = [55.0, 125.0, 235.0, 305.0]  # from +y toward +z: 6 m tall, about 4 m wide
N_RHO = 24
N_S = 16


def chord(rho):
    # Elliptic outline, root chord 55 % of the maximum, closing to 15 % at the tip.
    u = (rho - HUB_RADIUS_M) / (TIP_RADIUS_M - HUB_RADIUS_M)
    return MAX_CHORD_M * max(0.15, math.sqrt(max(0.0, 1.0 - (u - 0.35) ** 2 / 0.65 ** 2)))


def thickness(rho):
    u = (rho - HUB_RADIUS_M) / (TIP_RADIUS_M - HUB_RADIUS_M)
    return 0.16 * (1.0 - u) + 0.03 * u


def point(phi0, rho, s, side):
    theta = math.atan(PITCH_M / (2.0 * math.pi * rho))
    t = 0.5 * thickness(rho) * side
    # Face offset: along the blade-section normal (cos theta axially, -sin theta tangentially).
    x = s * math.sin(theta) + t * math.cos(theta)
    phi = phi0 + (s * math.cos(theta) - t * math.sin(theta)) / rho
    return (x, rho * math.cos(phi), rho * math.sin(phi))


def blade(phi0):
    rhos = [HUB_RADIUS_M - 0.05 + (TIP_RADIUS_M - HUB_RADIUS_M + 0.05) * i / N_RHO for i in range(N_RHO + 1)]
    grid = {}
    for side in (-1, 1):
        for i, rho in enumerate(rhos):
            c = chord(rho)
            for j in range(N_S + 1):
                s = -0.5 * c + c * j / N_S
                grid[(side, i, j)] = point(phi0, rho, s, side)
    tris = []
    for i in range(N_RHO):
        for j in range(N_S):
            for side in (-1, 1):
                a, b = grid[(side, i, j)], grid[(side, i + 1, j)]
                c, d = grid[(side, i + 1, j + 1)], grid[(side, i, j + 1)]
                if side > 0:
                    tris += [(a, b, c), (a, c, d)]
                else:
                    tris += [(a, c, b), (a, d, c)]
    # Leading and trailing edges.
    for i in range(N_RHO):
        for j in (0, N_S):
            a, b = grid[(-1, i, j)], grid[(-1, i + 1, j)]
            c, d = grid[(1, i + 1, j)], grid[(1, i, j)]
            tris += [(a, b, c), (a, c, d)]
    # Tip (the root is buried in the hub).
    for j in range(N_S):
        a, b = grid[(-1, N_RHO, j)], grid[(-1, N_RHO, j + 1)]
        c, d = grid[(1, N_RHO, j + 1)], grid[(1, N_RHO, j)]
        tris += [(a, b, c), (a, c, d)]
    return tris


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "propeller_blades.stl"
    tris = []
    for deg in BLADE_ANGLES_DEG:
        tris += blade(math.radians(deg))
    write_stl(out, b"vog propeller blades, metres, x = shaft axis", tris)


if __name__ == "__main__":
    main()
