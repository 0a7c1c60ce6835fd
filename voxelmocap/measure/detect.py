"""Body extremities from the voxels alone: the geodesic extrema of the occupied-voxel graph.

Head, hands and feet are the points of a standing body farthest from its trunk *along* the body.
:func:`find_extremities` finds them without any pose or body model, so they can start a track and
feed the proposals of a lost one (automatic initialisation and recovery):

1. keep the largest 26-connected component of ``V^R`` and the pieces near it (the person; a limb
   cut off by a segmentation hole stays attached by one bridging edge; specks and far blobs go);
2. take its *centre*: the voxel deepest inside it (largest Euclidean distance to the outside,
   :func:`scipy.ndimage.distance_transform_edt`), which on a human is in the trunk;
3. measure the geodesic distance of every voxel from the centre
   (:func:`scipy.sparse.csgraph.dijkstra` over the voxel graph, 26-neighbour edges of length 1,
   √2, √3 voxels); an extremity is a voxel that is the farthest from the centre within its own
   geodesic ball of ``tip_radius_mm`` — the tip of a limb, where the distance stops growing.
   Tips nearer than ``min_geodesic_mm`` (a shoulder, a bump) are not extremities; at most
   ``max_extremities``, farthest first.

Accumulating geodesic extrema instead (AGEX, Plagemann et al., ICRA 2010: each next extremity
is the voxel farthest from the centre *and* the extremities found so far) was tried first: on
the cone body it picks the middle of a long leg (≈ 700 mm from both ends) before the head
(≈ 500 mm from the trunk), so the head came 6th or 7th.

The order of the extremities is the order found (the farthest first); which is the head, a hand
or a foot is left to the caller, who can score the hypotheses with the likelihood.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from ..errors import InputError
from ..grid import VoxelGrid

__all__ = ["CROWN_MM", "HEAD_SECTION_MM2", "Extremities", "find_extremities"]

#: A horizontal section of a head (mm²), π·(60 mm)²: the top of the trunk's axis is the highest
#: section at least this large; a raised hand or forearm above the head is thinner.
HEAD_SECTION_MM2 = float(np.pi * 60.0 ** 2)
#: How far the crown rises above that section (mm; the carving's rounded top included): thinner
#: sections right above it count up to this height, a hand held higher does not.
CROWN_MM = 60.0

#: The 13 neighbour offsets of a 26-neighbourhood that point "forward" (each edge once).
_OFFSETS = np.array([(di, dj, dk) for di in (-1, 0, 1) for dj in (-1, 0, 1) for dk in (-1, 0, 1)
                     if (di, dj, dk) > (0, 0, 0)], dtype=np.int64)


@dataclass(frozen=True)
class Extremities:
    """What :func:`find_extremities` found in one frame.

    Attributes
    ----------
    centre : (3,) float ndarray
        The trunk point (mm): the voxel deepest inside the body.
    points : (K, 3) float ndarray
        Extremity positions (mm), farthest first; K may be 0.
    geodesic_mm : (K,) float ndarray
        Geodesic distance of each extremity from the centre along the voxels (mm).
    n_voxels : int
        Voxels of the largest component (the person).
    low, high : (3,) float ndarray
        Corners (mm) of the component's bounding box, voxel faces included.
    """

    centre: np.ndarray
    points: np.ndarray
    geodesic_mm: np.ndarray
    n_voxels: int
    low: np.ndarray
    high: np.ndarray

    #: Top (mm) of the head on the vertical through the centre (the voxels within
    #: ``axis_radius_mm`` of it; a hand held above the head left out: :func:`_axis_top`).
    axis_top: float = float("nan")

    @property
    def extent_mm(self) -> float:
        """Vertical extent of the component (mm), raised hands included."""
        return float(self.high[2] - self.low[2])

    @property
    def height_mm(self) -> float:
        """A standing person's height (mm): from the lowest voxel to the top of the trunk's axis.

        The axis top is the head when it is above the trunk; a hand raised beside the head is
        off that axis and does not count (the vertical extent would: +260 mm on a waving clip),
        nor does one held right above it (thinner than a head: +240 mm on the same clip).
        """
        top = self.axis_top if np.isfinite(self.axis_top) else float(self.high[2])
        return float(top - self.low[2])


def _axis_top(k: np.ndarray, grid: VoxelGrid) -> float:
    """Top (mm) of the head on the trunk's axis, from the axis's voxels' z indices ``k``.

    A hand raised right above the head is on the axis too: the top is that of the highest
    section of at least :data:`HEAD_SECTION_MM2`, with the occupied slices right above it up to
    :data:`CROWN_MM` (a gap, or anything higher, is not the head); without such a section, the
    axis's highest voxel.
    """
    vs = float(grid.voxel_size)
    base = int(k.min())
    per_slice = np.bincount(k - base)
    wide = np.flatnonzero(per_slice * vs * vs >= HEAD_SECTION_MM2)
    if wide.size == 0:
        top = int(k.max())
    else:
        top = int(wide.max())
        above = per_slice[top + 1:] > 0
        run = len(above) if above.all() else int(np.argmin(above))
        top += min(run, int(CROWN_MM // vs))
    return float(grid.centre_of(np.array([0, 0, base + top]))[2] + vs / 2)


def _person(occ: np.ndarray, bridge_vox: float, min_voxels: int):
    """The largest component plus every component within ``bridge_vox`` of it, and the bridges.

    A limb can be cut off its body by a segmentation hole (or, on the cone model, by the gap
    between the trunk and an abducted thigh): such pieces stay part of the person, joined by one
    edge from each of their voxels facing it.

    Returns
    -------
    mask : bool ndarray, shape of ``occ``
    bridges : list of ((3,) int, (3,) int, float)
        Voxel index pairs and their Euclidean distance (voxels).
    """
    from scipy.spatial import cKDTree

    labels, n = ndimage.label(occ, structure=np.ones((3, 3, 3), dtype=bool))
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    sizes[0] = 0
    order = [int(i) for i in np.argsort(sizes, kind="stable")[::-1] if sizes[i] >= min_voxels]
    if not order:
        order = [int(np.argmax(sizes))]
    coords = {i: np.argwhere(labels == i) for i in order}
    merged, rest, bridges = [order[0]], order[1:], []
    changed = True
    while changed and rest:
        changed = False
        tree = cKDTree(np.concatenate([coords[i] for i in merged]))
        body = np.concatenate([coords[i] for i in merged])
        for i in list(rest):
            dist, near = tree.query(coords[i], distance_upper_bound=bridge_vox)
            if np.isfinite(dist).any():
                # Bridge the whole facing side (within a voxel of the closest gap), not one
                # point: a single edge would make the far side of the piece a false far end.
                for k in np.flatnonzero(dist <= dist.min() + 1.0):
                    bridges.append((coords[i][k], body[near[k]], float(dist[k])))
                merged.append(i)
                rest.remove(i)
                changed = True
                break  # rebuild the tree with the new piece
    return np.isin(labels, merged), bridges


def _voxel_graph(component: np.ndarray, bridges=()):
    """Sparse symmetric graph over the voxels (edge length in voxels).

    Returns
    -------
    graph : (n, n) scipy.sparse.csr_matrix
    idx : (n, 3) int ndarray
        The voxel of each node.
    ids : int ndarray, shape of ``component``
        The node of each voxel (−1 outside).
    """
    idx = np.argwhere(component)
    ids = np.full(component.shape, -1, dtype=np.int64)
    ids[tuple(idx.T)] = np.arange(len(idx))
    shape = np.asarray(component.shape)
    rows, cols, lengths = [], [], []
    for off in _OFFSETS:
        nb = idx + off
        inside = np.all((nb >= 0) & (nb < shape), axis=1)
        src = np.flatnonzero(inside)
        dst = ids[tuple(nb[inside].T)]
        keep = dst >= 0
        rows.append(src[keep])
        cols.append(dst[keep])
        lengths.append(np.full(int(keep.sum()), float(np.sqrt((off * off).sum()))))
    for a, b, length in bridges:
        rows.append(np.array([ids[tuple(a)]]))
        cols.append(np.array([ids[tuple(b)]]))
        lengths.append(np.array([length]))
    r, c, w = np.concatenate(rows), np.concatenate(cols), np.concatenate(lengths)
    graph = sparse.csr_matrix((w, (r, c)), shape=(len(idx), len(idx)))
    return graph, idx, ids


def _tips(graph, idx, shape, dist, radius, min_dist, limit) -> list[int]:
    """Voxels whose geodesic distance is the largest within their geodesic ball of ``radius``.

    Candidates are the voxels no 26-neighbour of which is farther; each is checked against its
    whole ball (one bounded Dijkstra for all candidates) and, farthest first, kept unless an
    extremity already kept lies in its ball (one tip per end cap).
    """
    d = np.full(shape, -np.inf)
    d[tuple(idx.T)] = dist
    local = dist >= ndimage.maximum_filter(d, size=3, mode="constant", cval=-np.inf)[tuple(idx.T)]
    if limit <= 0:
        return []
    cands = np.flatnonzero(local & (dist >= min_dist))
    cands = cands[np.argsort(-dist[cands], kind="stable")][:_MAX_CANDIDATES]
    if len(cands) == 0:
        return []
    balls = csgraph.dijkstra(graph, directed=False, indices=cands, limit=radius)
    kept: list[int] = []
    for row, v in enumerate(cands):
        inside = np.isfinite(balls[row])
        if dist[inside].max() > dist[v] + 1e-9:
            continue  # something farther along the body is nearby: a bump, not an end
        if any(inside[k] for k in kept):
            continue
        kept.append(int(v))
        if len(kept) == limit:
            break
    return kept


#: Local maxima examined, farthest first (noisy real voxels have many small bumps).
_MAX_CANDIDATES = 400


def find_extremities(occupancy, grid: VoxelGrid, *, max_extremities: int = 7,
                     min_geodesic_mm: float = 250.0, tip_radius_mm: float = 150.0,
                     bridge_mm: float = 150.0, min_piece_voxels: int = 8,
                     axis_radius_mm: float = 150.0) -> Extremities | None:
    """Head, hands and feet candidates: the accumulated geodesic extrema of the voxels.

    Parameters
    ----------
    occupancy : (nx, ny, nz) array_like of bool
        ``V^R`` on ``grid``.
    grid : VoxelGrid
        Its grid.
    max_extremities : int
        At most this many (head, two hands, two feet, and room for a bent knee or elbow that
        sticks out: the caller picks among them).
    min_geodesic_mm : float
        An extremity is at least this far (mm) along the voxels from the centre.
    tip_radius_mm : float
        An extremity is the farthest voxel from the centre within this geodesic radius (mm) of
        itself; it separates ends and rejects surface bumps.
    bridge_mm : float
        Pieces of at least ``min_piece_voxels`` voxels within this distance (mm) of the body
        belong to it (a limb cut off by a segmentation hole).
    min_piece_voxels : int
        Smaller pieces are noise and ignored.
    axis_radius_mm : float
        Radius of the vertical cylinder around the centre whose top gives
        :attr:`Extremities.height_mm`.

    Returns
    -------
    Extremities or None
        None when nothing is occupied.
    """
    occ = np.asarray(occupancy)
    if occ.shape != grid.shape:
        raise InputError("occupancy", f"shape {occ.shape} does not match the grid {grid.shape}")
    if max_extremities < 0 or not np.isfinite(min_geodesic_mm) or min_geodesic_mm < 0:
        raise InputError("find_extremities", "max_extremities and min_geodesic_mm must be >= 0")
    occupied = np.argwhere(occ)
    if len(occupied) == 0:
        return None
    # Work on the occupied bounding box only: the grid is mostly empty. The one-voxel padding
    # makes the box's border count as outside for the depth.
    box_lo = occupied.min(axis=0)
    box = occ[tuple(slice(a, b + 1) for a, b in zip(box_lo, occupied.max(axis=0), strict=True))]
    component, bridges = _person(box, bridge_mm / float(grid.voxel_size), min_piece_voxels)
    n = int(component.sum())
    depth = ndimage.distance_transform_edt(np.pad(component, 1))[1:-1, 1:-1, 1:-1]
    graph, idx, ids = _voxel_graph(component, bridges)
    centre_id = int(ids[np.unravel_index(int(np.argmax(depth)), depth.shape)])
    vs = float(grid.voxel_size)
    from_centre = csgraph.dijkstra(graph, directed=False, indices=centre_id)
    found = _tips(graph, idx, component.shape, from_centre, tip_radius_mm / vs,
                  min_geodesic_mm / vs, max_extremities)
    idx = idx + box_lo  # back to grid indices
    lo_idx, hi_idx = idx.min(axis=0), idx.max(axis=0) + 1
    centre = grid.centre_of(idx[centre_id])
    heights = grid.centre_of(idx)
    on_axis = np.hypot(heights[:, 0] - centre[0], heights[:, 1] - centre[1]) <= axis_radius_mm
    axis_top = _axis_top(idx[on_axis, 2], grid)  # the centre itself is on the axis
    return Extremities(
        centre=centre,
        points=grid.centre_of(idx[found]).reshape(-1, 3),
        geodesic_mm=from_centre[found] * vs,
        n_voxels=n,
        low=grid.low + lo_idx * vs,
        high=grid.low + hi_idx * vs,
        axis_top=axis_top,
    )
