"""Meshes on the unit sphere: the subdivided icosahedron and its nearest-neighbour spacing.

Input: a subdivision level, or points. Output: vertices (unit vectors) and outward faces; the
mean nearest-neighbour distance (scipy's k-d tree, imported only when it is needed).

Example:
    >>> v, f = icosphere(1)
    >>> v.shape, f.shape
    ((42, 3), (80, 3))
"""

from __future__ import annotations

import functools
import math

import numpy as np

from s2gen.system import MAX_BODIES

__all__ = [
    "BRUTE_FORCE_POINTS",
    "MAX_SUBDIVISIONS",
    "icosphere",
    "icosphere_vertices",
    "nearest_neighbour_distance",
]


def icosphere_vertices(subdivisions: int) -> int:
    """Vertices of the icosahedron subdivided `subdivisions` times: 10 * 4^s + 2.

    Example:
        >>> icosphere_vertices(3), icosphere_vertices(12)
        (642, 167772162)
    """
    return 10 * 4**subdivisions + 2


#: Most subdivisions of an icosphere: the largest whose vertices, one body each, stay within
#: the limit on bodies (`s2gen.system.MAX_BODIES`): 8, 655,362 vertices.
MAX_SUBDIVISIONS = max(s for s in range(32) if icosphere_vertices(s) <= MAX_BODIES)


def _icosahedron() -> tuple[np.ndarray, list[tuple[int, int, int]]]:
    """The regular icosahedron: 12 unit vertices (±1, ±phi, 0) cyclically, 20 outward faces."""
    phi = (1 + math.sqrt(5)) / 2
    base = [(-1.0, phi), (1.0, phi), (-1.0, -phi), (1.0, -phi)]
    verts = [(a, b, 0.0) for a, b in base]
    verts += [(0.0, a, b) for a, b in base]
    verts += [(b, 0.0, a) for a, b in base]
    v = np.array(verts, dtype=float)
    v /= np.linalg.norm(v, axis=1)[:, None]
    faces: list[tuple[int, int, int]] = []
    for i in range(12):
        for j in range(i + 1, 12):
            for k in range(j + 1, 12):
                if all(_is_edge(v, a, b) for a, b in ((i, j), (j, k), (i, k))):
                    faces.append(_outward(v, (i, j, k)))
    return v, faces


def _is_edge(v: np.ndarray, a: int, b: int) -> bool:
    """Adjacent icosahedron vertices are 1.0515 apart (edge of the unit icosahedron)."""
    return bool(np.linalg.norm(v[a] - v[b]) < 1.2)


def _outward(v: np.ndarray, face: tuple[int, int, int]) -> tuple[int, int, int]:
    """The face with counter-clockwise orientation seen from outside."""
    i, j, k = face
    normal = np.cross(v[j] - v[i], v[k] - v[i])
    return face if float(normal @ (v[i] + v[j] + v[k])) > 0 else (i, k, j)


def _subdivide(
    verts: list[np.ndarray], faces: list[tuple[int, int, int]]
) -> list[tuple[int, int, int]]:
    """Split every face in four at its edge midpoints (pushed to the sphere); extends verts."""
    midpoint: dict[tuple[int, int], int] = {}

    def mid(a: int, b: int) -> int:
        key = (min(a, b), max(a, b))
        if key not in midpoint:
            p = verts[a] + verts[b]
            verts.append(p / np.linalg.norm(p))
            midpoint[key] = len(verts) - 1
        return midpoint[key]

    out: list[tuple[int, int, int]] = []
    for a, b, c in faces:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        out += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    return out


@functools.cache
def _icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    v0, faces = _icosahedron()
    verts = list(v0)
    for _ in range(subdivisions):
        faces = _subdivide(verts, faces)
    return np.array(verts), np.array(faces, dtype=np.intp)


def icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) on the unit sphere and outward faces (F, 3) of a subdivided icosahedron.

    Each subdivision splits every triangle in four at its edge midpoints, projected onto the
    sphere: 10 * 4^s + 2 vertices and 20 * 4^s faces.

    Example:
        >>> v, f = icosphere(3)
        >>> v.shape, f.shape
        ((642, 3), (1280, 3))
        >>> icosphere(4)[1].shape
        (5120, 3)
    """
    if subdivisions < 0:
        raise ValueError(f"subdivisions must be >= 0, got {subdivisions}")
    if subdivisions > MAX_SUBDIVISIONS:  # checked before any vertex is made
        raise ValueError(
            f"subdivisions={subdivisions} gives {icosphere_vertices(subdivisions)} vertices, "
            f"more than the limit of {MAX_BODIES} bodies (subdivisions at most "
            f"{MAX_SUBDIVISIONS})"
        )
    v, f = _icosphere(int(subdivisions))
    return v.copy(), f.copy()


#: Up to this many points the nearest-neighbour distance is found by comparing all pairs.
BRUTE_FORCE_POINTS = 1500


def nearest_neighbour_distance(points: np.ndarray, faces: np.ndarray | None = None) -> float:
    """Mean distance from each point to its closest other point; with `faces` (F, 3), the
    mean length of the mesh edges instead.

    Example:
        >>> v, f = icosphere(3)
        >>> round(nearest_neighbour_distance(v), 4), round(nearest_neighbour_distance(v, f), 4)
        (0.1412, 0.1507)
    """
    if faces is not None:
        pairs = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        edges = np.unique(np.sort(pairs, axis=1), axis=0)
        return float(np.mean(np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1)))
    n = len(points)
    if n <= BRUTE_FORCE_POINTS:
        # all distances, a block of rows at a time: for a few hundred points this is faster than
        # importing scipy's k-d tree (about 0.5 s), and the distances are the same doubles
        nearest = np.empty(n)
        for a in range(0, n, 256):
            d = np.linalg.norm(points[a : a + 256, None, :] - points[None, :, :], axis=2)
            rows = np.arange(a, min(a + 256, n))
            d[rows - a, rows] = np.inf
            nearest[a : a + 256] = d.min(axis=1)
        return float(np.mean(nearest))
    from scipy.spatial import cKDTree  # imported here: only large meshes need it

    distances, _ = cKDTree(points).query(points, k=2)  # column 0: the point itself
    return float(np.mean(distances[:, 1]))
