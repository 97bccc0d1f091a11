"""Contact geometry of mesh prisms (a planar outline extruded along z, like the MIT pushing shapes): the outline
for what pushes the object and what it pushes, a simplified footprint for what carries it.

Why (docs/rollout.md, "Contact geometry of mesh prisms"): Drake makes a compliant `Convex` a fan of tetrahedra
from its centroid over its hull's faces, triangulating each face from one of its vertices. Against a support, every
tetrahedron that reaches the bottom face cuts one contact polygon, and each polygon is a contact constraint of the
discrete solver: an ellipse of 61 outline vertices makes ~250 polygons where a rectangle makes 11, and replays 4-5
times slower. Which vertex the fan starts from is arbitrary (the order of the file's vertices) and it changes a
push by as much as 1.4 mm and 2.6 deg; a rectangle rests on two bottom tetrahedra, and its pushes hinge on
rounding. The footprint keeps the pressure uniform over the bottom (every bottom tetrahedron ends at one vertex at
mid-height, as in Drake's own) but fans it from the centre, over a polygon of `footprint_vertices` vertices with
the outline's area and centroid (simplified from a finer outline, subdivided from a coarser one): an isotropic
quadrature. The rod and other objects still meet the exact outline (Drake's own `Convex` of the file when the
outline is convex, so that contact is unchanged). On a plane top (`geometry.plane_top`) the object rests on its
sole, the pyramid over the footprint (`sole_tetrahedra`): the same pressure on fewer contact polygons.

A non-convex outline stays non-convex: it becomes a tetrahedral mesh of its own (one fan from the area centroid
when the outline is star-shaped from there, else a fan per convex piece of it), where Drake would have used the
convex hull of a compliant `.obj` mesh.

`MODES`: "prism" (the above), "hull" (the same for the outline's convex hull: a non-convex object as a simulator
that takes every mesh as its hull has it, carried as evenly), "drake" (Drake's own `Convex` of the file, resting
on its fan: its torsional friction hinges on where a support's triangles cut the few bottom tetrahedra; a tri1
spun on the MIT sheet turned 0.14 to 2.5 times as far as on the footprint, by where it stood, docs/rollout.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..odb.geometry import mesh_data

MODES = ("prism", "hull", "drake")
TOLERANCE = 1e-7  # m: vertices this close are one, points this far off a line are on it
SAME_POINT = 1e-5  # m: a top vertex this close (x, y) to each bottom outline vertex makes the mesh a prism
Tets = list[tuple[int, int, int, int]]  # tetrahedra as four vertex indices


@dataclass(frozen=True, eq=False)
class Prism:
    """A mesh that is an outline extruded along z: `outline` (n, 2) counter-clockwise, object frame, without
    collinear vertices; bottom and top at `z0` < `z1`."""

    outline: np.ndarray
    z0: float
    z1: float

    @property
    def convex(self) -> bool:
        return is_convex(self.outline)


@lru_cache(maxsize=64)
def mesh_prism(path: Path, scale: float) -> Prism | None:
    """The prism a mesh file is, or None when it is not one: every vertex on one of two planes z = z0, z1, the
    bottom faces' outer boundary a simple loop with a top vertex over each of its vertices. Holes through the prism (the MIT shapes
    have small ones) are left out, as Drake's convex hull leaves them out."""
    vertices, faces = mesh_data(path, scale)
    z = vertices[:, 2]
    z0, z1 = float(z.min()), float(z.max())
    tol = TOLERANCE + 1e-6 * float(np.ptp(vertices, axis=0).max())
    if z1 - z0 <= tol or not np.all((np.abs(z - z0) <= tol) | (np.abs(z - z1) <= tol)):
        return None
    bottom_faces = [f for f in faces if all(abs(z[i] - z0) <= tol for i in f)]
    bottom = _boundary_loop(vertices[:, :2], bottom_faces, tol)
    if bottom is None or len(bottom) < 3 or not is_simple(bottom):
        return None
    top = vertices[np.abs(z - z1) <= tol, :2]
    gap = max(float(np.min(np.linalg.norm(top - p, axis=1))) for p in bottom)
    if gap > SAME_POINT:
        return None  # the top is not the bottom's outline raised (a frustum, a bevel)
    return Prism(bottom, z0, z1)


def outline_of(geometry) -> np.ndarray | None:
    """The outline (n, 2, counter-clockwise, object frame) of an object that is a prism (`Geometry` of the object
    database): what a planar pusher meets, for start clearances and frame checks. A box's rectangle, a
    cylinder's 64-gon, a mesh's bottom loop (`mesh_prism`; the dataset's own ``<mesh>_ext.npy`` beside it when
    there is one), as it is: a non-convex outline stays non-convex. None for a shape that is no prism."""
    if geometry.shape == "box":
        hx, hy = geometry.size[0] / 2, geometry.size[1] / 2
        return np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
    if geometry.shape == "cylinder":
        angles = np.linspace(0.0, 2 * math.pi, 64, endpoint=False)
        return geometry.size[0] * np.column_stack([np.cos(angles), np.sin(angles)])
    if geometry.shape != "mesh" or geometry.mesh is None:
        return None
    own = geometry.mesh.with_name(geometry.mesh.stem + "_ext.npy")
    if own.is_file():
        from ..recording.mitpush import load_outline

        return np.asarray(load_outline(geometry.mesh.stem, geometry.mesh.parent.parent)) * geometry.scale
    prism = mesh_prism(geometry.mesh, geometry.scale)
    return None if prism is None else np.array(prism.outline)


@lru_cache(maxsize=64)
def contact_outlines(path: Path, scale: float, hull: bool, vertices: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(the outline that needs a mesh of its own, the footprint) of a mesh prism: the outline when it is not convex
    and the type does not ask for the hull (`hull` False; else Drake's `Convex` serves and this is None), the
    footprint of the outline (or its hull) with `vertices` vertices (`footprint_polygon`; None: one geometry)."""
    prism = mesh_prism(path, scale)
    outline = prism.outline
    if hull and not prism.convex:
        outline = convex_hull(outline)
    own = None if (hull or prism.convex) else outline
    return own, footprint_polygon(outline, vertices)


def convex_hull(poly: np.ndarray) -> np.ndarray:
    """The convex hull of a polygon's vertices, counter-clockwise (as scipy lists 2-D hulls): what Drake's `Convex`
    of a non-convex prism is in the plane."""
    from scipy.spatial import ConvexHull

    return np.asarray(poly)[ConvexHull(poly).vertices]


def footprint_polygon(outline: np.ndarray, n: int) -> np.ndarray | None:
    """What a prism rests on, fanned from its centre: the outline simplified to `n` vertices when it has more,
    with its edges subdivided to `n` vertices when it has fewer and is convex (the same polygon, `subdivide`),
    None for a non-convex outline of at most `n` (its own mesh is fanned from its centre already).

    Why subdivide: Drake's `Convex` of a rectangle rests on two bottom tetrahedra, two contact points for the whole
    friction moment; the push it gives hinges on where a rigid support's triangles run under it (the MIT sheet
    moved by centimetres moved a tri1 push's end by 3.8 mm and 2 deg) and on rounding. Sixteen fan triangles spread
    the quadrature round the centre as the ellipses' footprints do: 0.1 mm and 0.4 deg (docs/rollout.md)."""
    if len(outline) > n:
        return simplify(outline, n)
    return subdivide(outline, n) if is_convex(outline) else None


def subdivide(poly: np.ndarray, n: int) -> np.ndarray:
    """The polygon with vertices added along its edges, shared out by edge length, up to `n` vertices."""
    poly = np.asarray(poly, dtype=float)
    k = len(poly)
    if k >= n:
        return poly
    edges = np.roll(poly, -1, axis=0) - poly
    share = np.linalg.norm(edges, axis=1) / np.linalg.norm(edges, axis=1).sum() * (n - k)
    cuts = np.floor(share).astype(int)
    cuts[np.argsort(cuts - share, kind="stable")[: n - k - int(cuts.sum())]] += 1  # largest remainders first
    return np.array([poly[i] + edges[i] * j / (cuts[i] + 1) for i in range(k) for j in range(cuts[i] + 1)])


def _boundary_loop(xy: np.ndarray, faces: list[tuple[int, ...]], tol: float) -> np.ndarray | None:
    """The outer boundary loop of a planar patch of faces (edges used by one face; the other loops are holes),
    counter-clockwise, collinear vertices removed; None for no patch or a branching boundary."""
    if not faces:
        return None
    keys = {i: tuple(np.round(xy[i] / tol).astype(np.int64)) for f in faces for i in f}  # merge coincident vertices
    point = {k: xy[i] for i, k in keys.items()}
    names = list(point)
    coords = np.array([point[k] for k in names])
    count: dict[tuple, int] = {}
    for f in faces:
        for a, b in zip(f, f[1:] + f[:1]):
            # an edge with other vertices on it (a T-junction of the triangulation) counts as its pieces
            pa, pb = point[keys[a]], point[keys[b]]
            d = pb - pa
            length2 = float(d @ d)
            if length2 == 0:
                continue
            t = (coords - pa) @ d / length2
            off = np.abs((coords[:, 0] - pa[0]) * d[1] - (coords[:, 1] - pa[1]) * d[0]) / math.sqrt(length2)
            inner = np.flatnonzero((t > 1e-9) & (t < 1 - 1e-9) & (off <= tol))
            chain = [keys[a]] + [names[i] for i in inner[np.argsort(t[inner])]] + [keys[b]]
            for u, v in zip(chain, chain[1:]):
                e = tuple(sorted((u, v)))
                if e[0] != e[1]:
                    count[e] = count.get(e, 0) + 1
    edges = [e for e, c in count.items() if c == 1]
    neighbours: dict[tuple, list] = {}
    for a, b in edges:
        neighbours.setdefault(a, []).append(b)
        neighbours.setdefault(b, []).append(a)
    if not neighbours or any(len(v) != 2 for v in neighbours.values()):
        return None
    loops, left = [], set(neighbours)
    while left:
        start = left.pop()
        loop, previous, current = [start], None, start
        while True:
            a, b = neighbours[current]
            nxt = b if a == previous else a
            if nxt == start:
                break
            loop.append(nxt)
            left.discard(nxt)
            previous, current = current, nxt
            if len(loop) > len(neighbours):
                return None
        loops.append(np.array([point[k] for k in loop]))
    outer = max(loops, key=lambda p: abs(signed_area(p)))  # the others are holes (ignored, as the hull does)
    if signed_area(outer) < 0:
        outer = outer[::-1]
    return _drop_collinear(outer, tol)


def _drop_collinear(poly: np.ndarray, tol: float) -> np.ndarray:
    keep = []
    n = len(poly)
    for i in range(n):
        a, b, c = poly[i - 1], poly[i], poly[(i + 1) % n]
        # distance of b from the line a-c
        ac = c - a
        length = float(np.hypot(*ac))
        if length > 0 and abs(_cross(ac, b - a)) / length <= tol:
            continue
        keep.append(b)
    return np.array(keep)


# --- planar polygons -----------------------------------------------------------------------------------------
def _cross(u: np.ndarray, v: np.ndarray) -> float:
    return float(u[0] * v[1] - u[1] * v[0])


def signed_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def centroid(poly: np.ndarray) -> np.ndarray:
    """The area centroid."""
    x, y = poly[:, 0], poly[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    a = cross.sum() / 2.0
    return np.array([np.sum((x + np.roll(x, -1)) * cross), np.sum((y + np.roll(y, -1)) * cross)]) / (6.0 * a)


def is_convex(poly: np.ndarray) -> bool:
    """Counter-clockwise and every turn a left turn."""
    n = len(poly)
    return all(_cross(poly[i] - poly[i - 1], poly[(i + 1) % n] - poly[i]) > 0 for i in range(n))


def is_star(poly: np.ndarray, centre: np.ndarray) -> bool:
    """Every edge seen from `centre` turning counter-clockwise: the fan from `centre` covers the polygon once."""
    n = len(poly)
    return all(_cross(poly[i] - centre, poly[(i + 1) % n] - centre) > 0 for i in range(n))


def is_simple(poly: np.ndarray) -> bool:
    """No two non-adjacent edges meet."""
    poly = np.asarray(poly, dtype=float)
    n = len(poly)
    if n < 3:
        return False
    p, q = poly, np.roll(poly, -1, axis=0)

    def cross(u, v):
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    for i in range(n - 2):
        j = np.arange(i + 2, n if i > 0 else n - 1)  # not the edge itself, its successor or (for edge 0) predecessor
        if j.size == 0:
            continue
        a, b, r, t = p[i], q[i], p[j], q[j]
        d1, d2 = cross(b - a, r - a), cross(b - a, t - a)
        d3, d4 = cross(t - r, a - r), cross(t - r, b - r)
        if np.any((d1 * d2 <= 0) & (d3 * d4 <= 0) & ~((d1 == 0) & (d2 == 0))):
            return False
    return True


def _segments_meet(p, q, r, s) -> bool:
    d1, d2 = _cross(q - p, r - p), _cross(q - p, s - p)
    d3, d4 = _cross(s - r, p - r), _cross(s - r, q - r)
    return (d1 * d2 <= 0) and (d3 * d4 <= 0) and not (d1 == d2 == 0)


def simplify(poly: np.ndarray, n: int) -> np.ndarray:
    """At most `n` of the outline's vertices (Visvalingam: repeatedly drop the vertex whose triangle with its
    neighbours has the least area, never one whose removal would make the polygon cross itself), then moved and
    scaled about the area centroid so the area and the centroid are the outline's (what a uniform pressure over the
    footprint depends on first)."""
    pts = np.asarray(poly, dtype=float)
    convex = is_convex(pts)  # any subset of a convex polygon's vertices is convex too: no check needed
    while len(pts) > max(3, n):
        prev, nxt = np.roll(pts, 1, axis=0), np.roll(pts, -1, axis=0)
        d1, d2 = pts - prev, nxt - prev
        areas = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
        for i in np.argsort(areas, kind="stable"):
            if convex or _can_drop(pts, int(i)):
                pts = np.delete(pts, int(i), axis=0)
                break
        else:
            break  # nothing can go without breaking the polygon
    c0, c1 = centroid(poly), centroid(pts)
    return c0 + (pts - c1) * math.sqrt(signed_area(poly) / signed_area(pts))


def _can_drop(pts: np.ndarray, i: int) -> bool:
    """Whether the polygon without vertex i stays simple and counter-clockwise: the new edge between i's neighbours
    crosses no other edge, and no other vertex lies in the triangle the removal cuts off (or adds)."""
    m = len(pts)
    a, c, b = pts[i - 1], pts[i], pts[(i + 1) % m]
    others = np.array([k for k in range(m) if k not in ((i - 2) % m, (i - 1) % m, i, (i + 1) % m)], dtype=int)
    if others.size:
        p, q = pts[others], pts[(others + 1) % m]
        ab = b - a

        def cross(u, v):
            return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

        d1, d2 = cross(ab, p - a), cross(ab, q - a)
        d3, d4 = cross(q - p, a - p), cross(q - p, b - p)
        if np.any((d1 * d2 <= 0) & (d3 * d4 <= 0) & ~((d1 == 0) & (d2 == 0))):
            return False
        tri = (a, c, b) if _cross(c - a, b - a) > 0 else (a, b, c)
        v = pts[[k for k in range(m) if k not in ((i - 1) % m, i, (i + 1) % m)]]
        inside = np.ones(len(v), dtype=bool)
        for u, w in zip(tri, tri[1:] + tri[:1]):
            inside &= cross(w - u, v - u) >= 0
        if np.any(inside):
            return False
    return signed_area(np.delete(pts, i, axis=0)) > 0


def convex_pieces(poly: np.ndarray) -> list[list[int]]:
    """Convex pieces of a simple counter-clockwise polygon, as lists of its vertex indices: ear-clipping
    triangles merged across their diagonals while the union stays convex (Hertel-Mehlhorn)."""
    n = len(poly)
    remaining = list(range(n))
    triangles = []
    guard = 0
    while len(remaining) > 3 and guard < 10 * n * n:
        guard += 1
        m = len(remaining)
        for k in range(m):
            i, j, l = remaining[k - 1], remaining[k], remaining[(k + 1) % m]
            a, b, c = poly[i], poly[j], poly[l]
            if _cross(b - a, c - b) <= 0:
                continue  # a reflex (or straight) corner is no ear
            if any(_inside_triangle(poly[v], a, b, c) for v in remaining if v not in (i, j, l)):
                continue
            triangles.append([i, j, l])
            remaining.pop(k)
            break
        else:
            raise ValueError("the outline cannot be triangulated (is it simple?)")
    triangles.append(list(remaining))
    pieces = [t[:] for t in triangles]
    merged = True
    while merged:
        merged = False
        for x in range(len(pieces)):
            for y in range(x + 1, len(pieces)):
                union = _merge(pieces[x], pieces[y])
                if union is not None and is_convex(poly[union]):
                    pieces[x] = union
                    del pieces[y]
                    merged = True
                    break
            if merged:
                break
    return pieces


def _inside_triangle(p, a, b, c) -> bool:
    return _cross(b - a, p - a) >= 0 and _cross(c - b, p - b) >= 0 and _cross(a - c, p - c) >= 0


def _merge(p: list[int], q: list[int]) -> list[int] | None:
    """Two counter-clockwise pieces sharing one edge, joined across it; None when they share none."""
    for i in range(len(p)):
        a, b = p[i], p[(i + 1) % len(p)]
        for j in range(len(q)):
            if q[j] == b and q[(j + 1) % len(q)] == a:
                # p from b round to a, then q from a round to b (excluding the shared ends)
                rest_p = [p[(i + 1 + k) % len(p)] for k in range(len(p))]  # starts at b, ends at a
                rest_q = [q[(j + 1 + k) % len(q)] for k in range(len(q))]  # starts at a, ends at b
                return rest_p[:-1] + rest_q[:-1]
    return None


# --- tetrahedral meshes --------------------------------------------------------------------------------------
def prism_tetrahedra(poly: np.ndarray, z0: float, z1: float) -> tuple[np.ndarray, Tets]:
    """A tetrahedral mesh of the prism over `poly` (counter-clockwise, simple): one piece when the polygon is
    star-shaped from its area centroid, else its convex pieces; each piece a fan of tetrahedra ending at one
    vertex at the piece's centroid, mid-height (bottom and top fanned from the piece's centre, side quads split
    along the same diagonal from both pieces that share them, so the mesh conforms). Drake's pressure field on it
    is zero on the boundary and rises linearly to that vertex: uniform over the bottom, as on Drake's `Convex`."""
    n = len(poly)
    c = centroid(poly)
    pieces = [list(range(n))] if is_star(poly, c) else convex_pieces(poly)
    points = [(x, y, z0) for x, y in poly] + [(x, y, z1) for x, y in poly]
    tets: Tets = []
    zm = 0.5 * (z0 + z1)
    for piece in pieces:
        pc = centroid(poly[piece]) if len(pieces) > 1 else c
        cb, ct, m = len(points), len(points) + 1, len(points) + 2
        points += [(pc[0], pc[1], z0), (pc[0], pc[1], z1), (pc[0], pc[1], zm)]
        for k, i in enumerate(piece):
            j = piece[(k + 1) % len(piece)]
            lo, hi = min(i, j), max(i, j)
            tets += [(cb, i, j, m), (ct, n + i, n + j, m),
                     (lo, hi, n + hi, m), (lo, n + hi, n + lo, m)]  # the side quad split along lo-bottom to hi-top
    return _oriented(np.array(points, dtype=float), tets)


def sole_tetrahedra(poly: np.ndarray, z0: float, z1: float) -> tuple[np.ndarray, Tets]:
    """A pyramid over `poly` (star-shaped from its area centroid): the bottom fan and the vertex at mid-height of
    `prism_tetrahedra`, so on a plane it presses exactly as the prism does, with sides rising to one apex over the
    centroid. What rests on a plane is every tetrahedron that reaches the bottom, and every side tetrahedron of a
    closed mesh does (a sliver of a few square micrometres): the prism's two per side quad make 48 contact
    polygons for 16 edges, the pyramid's one 32, and each polygon is a constraint of the discrete solver."""
    n = len(poly)
    c = centroid(poly)
    points = [(x, y, z0) for x, y in poly] + [(c[0], c[1], z0), (c[0], c[1], z1), (c[0], c[1], 0.5 * (z0 + z1))]
    cb, apex, m = n, n + 1, n + 2
    tets = [t for i in range(n) for t in ((cb, i, (i + 1) % n, m), (i, (i + 1) % n, apex, m))]
    return _oriented(np.array(points, dtype=float), tets)


def _oriented(P: np.ndarray, tets: Tets) -> tuple[np.ndarray, Tets]:
    """The tetrahedra with positive volume (the fourth vertex on the positive side of the first three's face)."""
    oriented = []
    for t in tets:
        a, b, cc, d = (P[k] for k in t)
        oriented.append(t if np.dot(np.cross(b - a, cc - a), d - a) > 0 else (t[0], t[2], t[1], t[3]))
    return P, oriented


def vtk_text(points: np.ndarray, tets: Tets, title: str = "bridge prism") -> str:
    """A legacy ASCII VTK unstructured grid of tetrahedra (what Drake reads for a compliant `Mesh`)."""
    lines = ["# vtk DataFile Version 3.0", title[:200], "ASCII", "DATASET UNSTRUCTURED_GRID",
             f"POINTS {len(points)} double"]
    lines += [f"{x:.10g} {y:.10g} {z:.10g}" for x, y, z in points]
    lines.append(f"CELLS {len(tets)} {5 * len(tets)}")
    lines += [f"4 {a} {b} {c} {d}" for a, b, c, d in tets]
    lines.append(f"CELL_TYPES {len(tets)}")
    lines += ["10"] * len(tets)
    return "\n".join(lines) + "\n"


def prism_mesh(poly: np.ndarray, z0: float, z1: float, name: str, sole: bool = False):
    """A Drake `Mesh` (in memory, VTK) of the prism over `poly`, or of the pyramid over it (`sole_tetrahedra`)."""
    from pydrake.common import MemoryFile
    from pydrake.geometry import InMemoryMesh, Mesh

    points, tets = (sole_tetrahedra if sole else prism_tetrahedra)(poly, z0, z1)
    data = vtk_text(points, tets, name).encode()
    return Mesh(InMemoryMesh(mesh_file=MemoryFile(data, ".vtk", f"{name}.vtk")), 1.0)
