"""Voxel likelihood of body poses: Out, DO, Empty and Surf scores per part (paper 002 §2.2).

The body model's voxel set is the union *with addition* of its parts (eq 2): a voxel's value is
the number of parts containing it (:func:`rasterise`). For every part Y and pose:

- ρ_Out (eq 3): share of Y's voxels outside the analysed scene (outside the grid, or outside the
  scene mask when one is given);
- ρ_DO (eq 4): share of Y's voxels that another part contains too;
- ρ_Empty = 1 − ρ_Occ (eqs 5, 9): share of Y's voxels not occupied in ``V^R``;
- ρ_Surf (eq 6): mean of ``1 − Ṽ^S`` over Y's surface voxels (voxels of Y with a 6-neighbour
  outside Y).

and ``log_likelihood = −½ Σ_Y dᵀ Σ⁻¹ d`` with ``d = (ρ_Out, ρ_DO, ρ_Empty, ρ_Surf)`` and
``Σ = diag(0.01, 0.01, 0.1, 0.1)`` (eqs 7–9).

Voxels and membership. Voxels are the grid's lattice extended without bound, so a part that
leaves the grid keeps all its voxels and the ones outside count as Out. A voxel belongs to a part
when its centre is inside the cone (see :mod:`voxelmocap.body.shapes`), decided by
:func:`_inside_reference` / ``_raster_kernels._inside`` with the same floating-point operations.
The frame is a :class:`~voxelmocap.measure.observation.VoxelObservation` (``V^R``, ``V^S``, ``Ṽ^S`` and
their prefix sums, built once by the measurement stage); ``Ṽ^S`` is quantised to integers
``round(Ṽ^S · 65535)`` there, so that every sum is an exact integer and the two implementations
agree bit for bit.

Two implementations: :func:`part_counts` (numba, per-column runs with prefix sums, parallel over
particles; ``DESIGN.md`` §4) and :func:`part_counts_reference` (numpy, per voxel). Both return
the same integer counts; :func:`scores_from_counts` turns counts into scores for both.

Illegal input. States with NaN or infinite values always raise :class:`InputError`; states
outside the model's legal ranges raise too unless ``clip=True`` (then they are clipped first).
A part that contains no voxel centre at all (only possible with voxels larger than a limb) has
``Out = DO = 0`` and ``Empty = Surf = 1``.

Overlap at the joints. Parts meet at joints without blending, so neighbouring cones overlap a
little even in natural poses: standing with the arms hanging straight at 20 mm voxels, ρ_DO is
19 % for the upper arms (their inner side enters the chest), 9 % for the forearms (they brush the
hips), 3 % for the torso and 0 for the head and legs; walking with the arms slightly abducted it
is 6 %, 2–4 %, 1 % and below 1 %. See ``docs/body_model.md``.

>>> from voxelmocap.body import BodyModel
>>> from voxelmocap.grid import VoxelGrid
>>> model = BodyModel()
>>> grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
>>> x = model.default_state()[None]
>>> m = VoxelObservation(rasterise(model, x, grid) > 0, grid)
>>> float(part_scores(m, model, x)[0, :, 2].max())   # every part fully occupied
0.0
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..grid import VoxelGrid
from ..measure.observation import QMAX, VoxelObservation
from . import _raster_kernels as _k
from . import _score_kernels as _sk

__all__ = [
    "DEFAULT_VARIANCES",
    "QMAX",
    "SCORE_NAMES",
    "Measurement",
    "VoxelObservation",
    "coverage_log_likelihood",
    "log_likelihood",
    "log_likelihood_from_counts",
    "log_likelihood_from_scores",
    "part_counts",
    "part_counts_reference",
    "part_scores",
    "part_scores_reference",
    "rasterise",
    "rasterise_reference",
    "scores_from_counts",
]

#: Order of the four scores on the last axis of :func:`part_scores`.
SCORE_NAMES: tuple[str, ...] = ("out", "do", "empty", "surf")
#: Paper 002's variances (σ²_Out, σ²_DO, σ²_Empty, σ²_Surf).
DEFAULT_VARIANCES: tuple[float, float, float, float] = (0.01, 0.01, 0.1, 0.1)
#: Names of the integer counts of :func:`part_counts`, last axis.
COUNT_NAMES: tuple[str, ...] = ("voxels", "out", "do", "occ", "surface_voxels", "surf_sum")


#: The measured frame the likelihood scores poses against (the name before the observation type
#: had its own module; kept because scripts and tests use it).
Measurement = VoxelObservation


# --------------------------------------------------------------------------------- fast route
def _geometry(model, states, clip):
    return model.geometry(states, legal=True, clip=clip)


def part_counts(observation: VoxelObservation, model, states, *, clip: bool = False) -> np.ndarray:
    """Integer counts per particle and part (fast numba kernel).

    Parameters
    ----------
    observation : VoxelObservation
    model : BodyModel
    states : (P, 27) array_like
        Legal states (mm, rad).
    clip : bool
        Clip out-of-range states instead of raising.

    Returns
    -------
    (P, n_parts, 6) int64 ndarray
        ``|Y|``, Out, DO, Occ, ``|Y^S|`` and ``Σ_{Y^S} (QMAX − Ṽq)`` (see :data:`COUNT_NAMES`).
    """
    return counts_of(observation, _geometry(model, states, clip))


def counts_of(observation: VoxelObservation, geometry) -> np.ndarray:
    """:func:`part_counts` of cones whose geometry is already computed (e.g. from the forward
    kinematics that also gave a record's landmarks).

    Parameters
    ----------
    observation : VoxelObservation
    geometry : voxelmocap.body.model.PartGeometry
        Of legal states.

    Returns
    -------
    (P, n_parts, 6) int64 ndarray
    """
    if not isinstance(observation, VoxelObservation):
        raise InputError("observation",
                         f"expected a VoxelObservation, got {type(observation).__name__}")
    geo, g = geometry, observation.grid
    counts = np.zeros((geo.n_particles, len(geo.shape), _k.N_COUNTS), dtype=np.int64)
    _k.part_counts(geo.base, geo.axis, geo.u1, geo.u2, geo.shape, *g.origin, g.voxel_size,
                   observation.prefix, observation.prefix_lattice, QMAX, _k.default_chunks(),
                   counts)
    return counts


def part_scores_of(observation: VoxelObservation, geometry) -> np.ndarray:
    """:func:`part_scores` of cones whose geometry is already computed: ``(P, n_parts, 4)``."""
    return scores_from_counts(counts_of(observation, geometry))


def scores_from_counts(counts) -> np.ndarray:
    """(…, n_parts, 4) scores Out, DO, Empty, Surf from (…, n_parts, 6) integer counts:
    ``Out/|Y|``, ``DO/|Y|``, ``(|Y| − Occ)/|Y|``, ``Σ(Q − Ṽq) / (|Y^S| · Q)``; a part with no
    voxel scores ``(0, 0, 1, 1)``."""
    counts = np.ascontiguousarray(counts, dtype=np.int64)
    flat = counts.reshape(-1, *counts.shape[-2:])
    scores = np.empty(flat.shape[:-1] + (4,))
    _sk.scores_from_counts(flat, QMAX, scores)
    return scores.reshape(counts.shape[:-1] + (4,))


def part_scores(observation: VoxelObservation, model, states, *, clip: bool = False) -> np.ndarray:
    """Scores of every part of every particle (fast kernel).

    Parameters
    ----------
    observation : VoxelObservation
    model : BodyModel
    states : (P, 27) array_like
        Legal states (mm, rad); NaN and out-of-range raise :class:`InputError` (or ``clip``).
    clip : bool
        Clip out-of-range states into the legal ranges instead of raising.

    Returns
    -------
    (P, n_parts, 4) float64 ndarray
        ρ_Out, ρ_DO, ρ_Empty, ρ_Surf (:data:`SCORE_NAMES`) per part in ``model.part_names`` order.
    """
    return scores_from_counts(part_counts(observation, model, states, clip=clip))


def log_likelihood_from_scores(scores, *, variances=DEFAULT_VARIANCES) -> np.ndarray:
    """``−½ Σ_parts Σ_terms d² / σ²`` over the last two axes of ``scores (…, n_parts, 4)``."""
    var = np.asarray(variances, dtype=float)
    if var.shape != (4,) or not np.all(np.isfinite(var)) or np.any(var <= 0):
        raise InputError("variances", f"expected 4 positive numbers, got {variances!r}")
    scores = np.asarray(scores, dtype=float)
    return -0.5 * np.einsum("...pt,t->...", scores * scores, 1.0 / var)


def coverage_log_likelihood(observation: VoxelObservation, counts, weight: float) -> np.ndarray:
    """``−½ w u² / 0.1`` per particle, ``u`` the share of occupied voxels that no part contains.

    Paper 002's scores judge each part against the voxels it contains; none sees occupied voxels
    that the body leaves out, so a limb folded into its neighbour's voxels (or shrunk into the
    visual hull) loses nothing for the voxels of the real limb it abandons. This term charges
    them. ``counts`` are :func:`part_counts` ``(P, parts, 6)``; the occupied voxels inside parts
    are ``Σ Occ − ½ Σ DO`` (exact where at most two parts share a voxel: a shared voxel is
    counted once).

    Parameters
    ----------
    observation : VoxelObservation
    counts : (P, n_parts, 6) int array_like
    weight : float
        ``w`` (0: no term; the result is then 0 for every particle).

    Returns
    -------
    (P,) float64 ndarray
    """
    counts = np.ascontiguousarray(counts, dtype=np.int64)
    out = np.zeros(counts.shape[0])
    if weight:
        _sk.coverage(counts, observation.n_occupied, float(weight), out)
    return out


def log_likelihood_from_counts(observation: VoxelObservation, counts, *,
                               variances=DEFAULT_VARIANCES, coverage: float = 0.0) -> np.ndarray:
    """(P,) :func:`log_likelihood` from :func:`part_counts` ``(P, n_parts, 6)`` (whichever kernel
    counted them: the full one or the partial re-scoring)."""
    ll = log_likelihood_from_scores(scores_from_counts(counts), variances=variances)
    if coverage:
        ll = ll + coverage_log_likelihood(observation, counts, coverage)
    return ll


def log_likelihood(observation: VoxelObservation, model, states, *, variances=DEFAULT_VARIANCES,
                   coverage: float = 0.0, clip: bool = False) -> np.ndarray:
    """Log-likelihood (up to a constant) of each particle, paper 002 eqs 7–9.

    Parameters
    ----------
    observation : VoxelObservation
    model : BodyModel
    states : (P, 27) array_like
        Legal states (mm, rad).
    variances : (4,) sequence of float
        ``(σ²_Out, σ²_DO, σ²_Empty, σ²_Surf)``; default the paper's (0.01, 0.01, 0.1, 0.1).
    coverage : float
        Weight of :func:`coverage_log_likelihood`, added (0: paper 002's likelihood alone).
    clip : bool
        Clip out-of-range states instead of raising.

    Returns
    -------
    (P,) float64 ndarray
        ``−½ Σ_Y dᵀ Σ⁻¹ d`` (≤ 0; 0 is a perfect fit), plus the coverage term.
    """
    return log_likelihood_from_counts(observation, part_counts(observation, model, states,
                                                               clip=clip),
                                      variances=variances, coverage=coverage)


def rasterise(model, state, grid: VoxelGrid) -> np.ndarray:
    """Number of parts containing each voxel of ``grid`` (eq 2), for inspection and dumps.

    Parameters
    ----------
    model : BodyModel
    state : (27,) or (1, 27) array_like
        One finite state (range not checked: any finite pose has a geometry).
    grid : VoxelGrid

    Returns
    -------
    (nx, ny, nz) uint8 ndarray
    """
    if not isinstance(grid, VoxelGrid):
        raise InputError("grid", f"expected a VoxelGrid, got {type(grid).__name__}")
    geo = model.geometry(_single(state), legal=False)
    volume = np.zeros(grid.shape, dtype=np.uint8)
    _k.rasterise_counts(geo.base, geo.axis, geo.u1, geo.u2, geo.shape, *grid.origin,
                        grid.voxel_size, volume)
    return volume


def _single(state):
    arr = np.asarray(state, dtype=float)
    if arr.ndim == 2 and arr.shape[0] != 1:
        raise InputError("state", f"expected one state, got shape {arr.shape}")
    return arr.reshape(1, -1) if arr.ndim == 1 else arr


# --------------------------------------------------------------------------------- reference
def _inside_reference(dx, dy, dz, axis, u1, u2, shp):
    """Membership of voxel centres at offsets ``dx (ni,1,1)``, ``dy (1,nj,1)``, ``dz (1,1,nk)``
    from the base centre; same operations, same order as ``_raster_kernels._inside``."""
    inv_h, inv_w, length, k_r = shp[0], shp[1], shp[2], shp[3]
    t = dx * axis[0] + dy * axis[1] + dz * axis[2]
    a = dx * u1[0] + dy * u1[1] + dz * u1[2]
    b = dx * u2[0] + dy * u2[1] + dz * u2[2]
    s = 1.0 + k_r * t
    ah = a * inv_h
    bw = b * inv_w
    return (t >= 0.0) & (t <= length) & (ah * ah + bw * bw <= s * s)


def _reference_masks(geo, p, grid):
    """Per part: (lattice box lows (3,), bool mask over the box) of particle p, brute force."""
    origin = np.asarray(grid.origin)
    vs = grid.voxel_size
    masks = []
    for q in range(geo.shape.shape[0]):
        shp = geo.shape[q]
        base, axis = geo.base[p, q], geo.axis[p, q]
        length, h, w, r = shp[2], shp[4], shp[5], shp[6]
        # a loose box from the bounding sphere (independent of the kernel's tight box)
        mid = base + 0.5 * length * axis
        rad = np.sqrt((0.5 * length) ** 2 + (max(h, w) * max(1.0, r)) ** 2)
        lo = np.floor((mid - rad - origin) / vs - 0.5).astype(int) - 1
        hi = np.ceil((mid + rad - origin) / vs - 0.5).astype(int) + 1
        cen = [origin[e] + (np.arange(lo[e], hi[e] + 1) + 0.5) * vs - base[e] for e in range(3)]
        mask = _inside_reference(cen[0][:, None, None], cen[1][None, :, None],
                                 cen[2][None, None, :], axis, geo.u1[p, q], geo.u2[p, q], shp)
        masks.append((lo, mask))
    return masks


def _gather(volume, lo, shape, fill):
    """``volume`` over the lattice box at ``lo`` of ``shape``, ``fill`` outside the grid."""
    out = np.full(shape, fill, dtype=volume.dtype)
    src_lo = np.maximum(lo, 0)
    src_hi = np.minimum(lo + np.asarray(shape), volume.shape)
    if np.all(src_hi > src_lo):
        dst_lo = src_lo - lo
        dst_hi = src_hi - lo
        out[dst_lo[0]:dst_hi[0], dst_lo[1]:dst_hi[1], dst_lo[2]:dst_hi[2]] = \
            volume[src_lo[0]:src_hi[0], src_lo[1]:src_hi[1], src_lo[2]:src_hi[2]]
    return out


def part_counts_reference(observation: VoxelObservation, model, states, *,
                          clip: bool = False) -> np.ndarray:
    """Plain per-voxel reference of :func:`part_counts` (numpy; slow, for tests)."""
    geo = _geometry(model, states, clip)
    grid = observation.grid
    n_parts = len(model.parts)
    counts = np.zeros((geo.n_particles, n_parts, _k.N_COUNTS), dtype=np.int64)
    for p in range(geo.n_particles):
        masks = _reference_masks(geo, p, grid)
        ulo = np.min([lo for lo, _ in masks], axis=0)
        uhi = np.max([lo + np.asarray(m.shape) for lo, m in masks], axis=0)
        union = np.zeros(tuple(uhi - ulo), dtype=np.int16)
        for lo, m in masks:
            a = lo - ulo
            union[a[0]:a[0] + m.shape[0], a[1]:a[1] + m.shape[1], a[2]:a[2] + m.shape[2]] += m
        for q, (lo, m) in enumerate(masks):
            a = lo - ulo
            cnt = union[a[0]:a[0] + m.shape[0], a[1]:a[1] + m.shape[1], a[2]:a[2] + m.shape[2]]
            scene = _gather(observation.scene, lo, m.shape, False)
            occ = _gather(observation.occupancy, lo, m.shape, False)
            vq = _gather(observation.smoothed_q, lo, m.shape, 0).astype(np.int64)
            pad = np.pad(m, 1)
            interior = (m & pad[:-2, 1:-1, 1:-1] & pad[2:, 1:-1, 1:-1] & pad[1:-1, :-2, 1:-1]
                        & pad[1:-1, 2:, 1:-1] & pad[1:-1, 1:-1, :-2] & pad[1:-1, 1:-1, 2:])
            surf = m & ~interior
            counts[p, q] = (m.sum(), (m & ~scene).sum(), (m & (cnt > 1)).sum(), (m & occ).sum(),
                            surf.sum(), (QMAX - vq[surf]).sum())
    return counts


def part_scores_reference(observation: VoxelObservation, model, states, *,
                          clip: bool = False) -> np.ndarray:
    """Plain per-voxel reference of :func:`part_scores` (numpy; slow, for tests)."""
    return scores_from_counts(part_counts_reference(observation, model, states, clip=clip))


def rasterise_reference(model, state, grid: VoxelGrid) -> np.ndarray:
    """Plain per-voxel reference of :func:`rasterise`: every grid voxel tested against every part."""
    geo = model.geometry(_single(state), legal=False)
    xs, ys, zs = (grid.axis_centres(a) for a in range(3))
    volume = np.zeros(grid.shape, dtype=np.uint8)
    for q in range(geo.shape.shape[0]):
        base = geo.base[0, q]
        volume += _inside_reference((xs - base[0])[:, None, None], (ys - base[1])[None, :, None],
                                    (zs - base[2])[None, None, :], geo.axis[0, q], geo.u1[0, q],
                                    geo.u2[0, q], geo.shape[q])
    return volume
