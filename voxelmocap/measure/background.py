"""A background plate learnt from the sequence itself, when no empty background video exists.

A real recording rarely comes with an empty plate. The temporal median of the sequence is the
usual stand-in, but a person who stays in one place for a while is *in* the median: the
silhouettes then lose the person there (absorbed) and show a "ghost" where the person stood once
they move. :func:`learn_plates` removes the person from the plate with the cameras' geometry:

1. start from the temporal median of each camera (frames normalised for exposure changes);
2. segment every sampled frame against the current plates (:class:`PlateBackground`), drop 2D
   *ghosts* (a blob whose outline is an edge of the plate but not of the frame: the frame shows
   the background the plate lacks), carve the silhouettes on a coarse grid, keep the person
   (the largest 3D component, fragments within a few voxels merged), and project it back into
   each view: the convex hull of its voxels' pixels, dilated, is *covered* in that frame;
3. a frame in which the person vanished (its volume far below the sequence's typical volume:
   the person is in the plate, but where is unknown) covers its whole image; when the typical
   person itself is too small to be a person (:data:`MIN_PERSON_MM3`: someone who barely moves
   is in the median and only the moving parts carve), every frame covers a person-sized
   column (:func:`person_column`) around what the frames' silhouettes carve together above
   the floor, so the body is left unknown rather than learnt as background;
4. re-estimate each pixel's plate as the median of the frames where it is not covered, and
   repeat from 2 until the plates stop changing.

Pixels covered in every frame have no learnt background: the person was there throughout, so
:class:`PlateBackground` reports them as foreground (a camera cannot veto what it never saw
empty). Too many such pixels (``max_unknown`` of the image) and the plate cannot be learnt: an
:class:`~voxelmocap.errors.InputError` names the camera and asks for an empty background video.

The noise of each camera is measured from the plate's own frames (the per-pixel inter-quartile
range of the uncovered samples, ÷ 1.349 = σ for Gaussian noise), floored by the camera's median
σ; a pixel is foreground when ``Σ_c (I_c − g·P_c)² / σ²`` exceeds the χ² quantile with ``C``
degrees of freedom at ``false_alarm`` (``g`` is the frame's exposure gain against the plate).
Cast shadows (darker, same chromaticity: Horprasert) are background.

The plate itself and the segmentation against it are :mod:`.plate`'s. This module reads no
file: :mod:`voxelmocap.run.measurement` hands over the decoded frames.

>>> plates = learn_plates(frames, rig, coarse_grid, SilhouetteConfig())  # doctest: +SKIP
>>> mask = segment(image, plates["cam01"], config, camera="cam01")        # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import cv2
import numpy as np
from scipy import ndimage

from ..config import SilhouetteConfig
from ..errors import InputError
from ..portable import matmul
from .carving import Carver
from .plate import PlateBackground, _channels, camera_at_most, plate_from_frames
from .threads import each

__all__ = ["MIN_PERSON_MM3", "carve_person", "learn_plates", "moving_parts", "person_column",
           "person_component", "plates_from_covers", "watched_voxels"]

_DEFAULT = SilhouetteConfig()
#: Smallest visual-hull volume of a person (mm³): 30 litres, below a small adult's body volume
#: (≈ 60 litres) let alone its visual hull; a person carving into less is (partly) in the plate.
MIN_PERSON_MM3 = 30e6
#: The column around the carved parts of a person who barely moves (mm): the reach around each
#: carved voxel and the height above the floor. Such a person is in the temporal median and only
#: the moving parts (a hand, a swinging leg) carve; over the sampled frames their union sweeps
#: the limbs' reach, and the torso they hang from is within 0.4 m of it horizontally and below
#: 2 m, so that column is covered.
PERSON_COLUMN_RADIUS_MM = 400.0
PERSON_COLUMN_HEIGHT_MM = 2000.0
#: Height (mm) below which a carve may be a cast shadow on the floor rather than a body part.
SHADOW_HEIGHT_MM = 150.0
#: Closing radius of the projected person (share of its height in the image) that covers a torso
#: the plate absorbed between carved limbs.
COVER_CLOSING = 0.12


# ---------------------------------------------------------------------- person in 3D
def person_component(occupancy: np.ndarray, *, merge: int = 1) -> np.ndarray:
    """The person: the largest 26-connected component of ``occupancy`` (bool, same shape).

    Fragments closer than ``merge`` voxels are joined first (a segmentation hole can split an arm
    from the body); the result keeps only the original voxels of the chosen component.
    """
    occ = np.asarray(occupancy, bool)
    if not occ.any():
        return occ.copy()
    grown = ndimage.binary_dilation(occ, iterations=merge) if merge > 0 else occ
    labels, n = ndimage.label(grown, structure=np.ones((3, 3, 3), bool))
    if n <= 1:
        return occ.copy()
    sizes = np.bincount(labels[occ], minlength=n + 1)
    sizes[0] = 0
    return occ & (labels == int(np.argmax(sizes)))


def watched_voxels(carver: Carver, holes: int) -> np.ndarray:
    """(nx, ny, nz) bool: the voxels at least half the rig's cameras see (and never fewer than
    the ``holes + 2`` the carving needs).

    At the edge of a large rig's common view three cameras see a voxel, and two agreeing blobs
    there (a ghost, noise) carve a phantom that wins as "the person" while the real one is
    still in the temporal median (a rendered walker, seven cameras). With up to four cameras
    this is the carving's own rule.
    """
    need = max(int(holes) + 2, -(-len(carver.cameras) // 2))
    return carver.coverage() >= need


def carve_person(carver: Carver, masks, holes: int, *,
                 watched: np.ndarray | None = None) -> np.ndarray:
    """The person of one frame's silhouettes: the carve tolerating ``holes``, kept where
    :func:`watched_voxels` (given, or computed), its :func:`person_component`."""
    if watched is None:
        watched = watched_voxels(carver, holes)
    return person_component(carver.carve_with_holes(masks, holes) & watched)


def moving_parts(carver: Carver, swept, holes: int, *,
                 watched: np.ndarray | None = None) -> np.ndarray:
    """The person's moving parts: :func:`carve_person` of ``swept`` (per camera, the union of
    the sampled frames' silhouettes) at least :data:`SHADOW_HEIGHT_MM` above the grid's floor.

    A moving cast shadow is on the floor in every view, so it carves too (a slab a voxel
    high); while the body is in the plate it would be the largest thing found.
    """
    grid = carver.grid
    if watched is None:
        watched = watched_voxels(carver, holes)
    above = grid.axis_centres(2) >= grid.low[2] + SHADOW_HEIGHT_MM
    return carve_person(carver, swept, holes, watched=watched & above[None, None, :])


def _ghost_blobs(mask: np.ndarray, image: np.ndarray, plate: np.ndarray, ratio: float,
                 min_area: int) -> np.ndarray:
    """Blobs of ``mask`` whose outline is an edge of the plate rather than of the image."""
    n, labels, st, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    ghosts = np.zeros_like(mask)
    if n <= 1:
        return ghosts

    def grad(img):
        img = _channels(img)
        g = cv2.cvtColor(np.ascontiguousarray(img.astype(np.uint8)), cv2.COLOR_BGR2GRAY) \
            if img.shape[2] == 3 else img[:, :, 0].astype(np.uint8)
        g = g.astype(np.float32)
        return cv2.magnitude(cv2.Sobel(g, cv2.CV_32F, 1, 0), cv2.Sobel(g, cv2.CV_32F, 0, 1))

    gi, gp = grad(image), grad(plate)
    kernel = np.ones((3, 3), np.uint8)
    for k in range(1, n):
        if st[k, cv2.CC_STAT_AREA] < min_area:
            continue
        x, y, w, h = (int(st[k, i]) for i in (0, 1, 2, 3))
        box = (slice(max(y - 2, 0), y + h + 2), slice(max(x - 2, 0), x + w + 2))
        blob = (labels[box] == k).astype(np.uint8)
        ring = (cv2.dilate(blob, kernel) - cv2.erode(blob, kernel)).astype(bool)
        if ring.sum() < 8:
            continue
        if gp[box][ring].mean() > ratio * max(gi[box][ring].mean(), 1e-3):
            ghosts[box] |= blob.astype(bool)
    return ghosts


# ---------------------------------------------------------------------- learning
def learn_plates(frames: Mapping[str, np.ndarray], cameras, grid,
                 config: SilhouetteConfig | None = None, *, holes: int | None = None,
                 max_side: int = 480, log: Callable[[str], None] | None = None,
                 progress: Callable[[int, int], None] | None = None,
                 observer: Callable[[int, dict, dict], None] | None = None
                 ) -> dict[str, PlateBackground]:
    """Learn one background plate per camera from frames of the sequence (person included).

    Parameters
    ----------
    frames : mapping of str to (F, H, W, C) uint8 ndarray
        The same ``F`` sampled frames of every camera (spread over the sequence). Each camera's
        are taken twice, one camera at a time: a mapping that decodes them on access keeps one
        camera's full frames in memory, not the rig's.
    cameras : sequence of Camera
        The rig (names key ``frames``).
    grid : VoxelGrid
        A coarse grid over the capture area (40–60 mm voxels) for the carving.
    config : SilhouetteConfig, optional
        ``false_alarm``, shadows, ``plate_iterations``, ``plate_ghost_ratio``,
        ``plate_max_unknown``, ``plate_min_seen``.
    holes : int, optional
        Silhouettes that may miss an occupied voxel (default: 1 with four or more cameras).
    max_side : int
        The iterations run on images downscaled to at most this many pixels on a side.
    log : callable, optional
        Receives one line per iteration.
    progress : callable, optional
        Called with ``(iteration, iterations)``.
    observer : callable, optional
        Called after each pass with ``(pass, plates, covered)`` (the downscaled plates and the
        (F, H', W') covered masks per camera), for studies.

    Returns
    -------
    dict of str to PlateBackground

    Raises
    ------
    InputError
        Frames missing or of different counts; no person found in any frame; a camera whose
        background was never seen over more than ``plate_max_unknown`` of its image.
    """
    config = config or _DEFAULT
    cameras = list(cameras)
    names = [c.name for c in cameras]
    missing = [n for n in names if n not in frames]
    if missing:
        raise InputError("background", f"no frames for camera(s) {', '.join(missing)}")
    if holes is None:
        holes = 1 if len(cameras) >= 4 else 0
    # One camera's full frames at a time (``frames`` may decode on access): the iterations run
    # on the downscaled copies, the full frames come back only for the final medians.
    small, small_cams = {}, []
    for cam in cameras:
        small_cams.append(camera_at_most(cam, max_side))
        full = frames[cam.name]
        small[cam.name] = [_channels(cv2.resize(f, small_cams[-1].size,
                                                interpolation=cv2.INTER_AREA)) for f in full]
        del full
    counts = {len(f) for f in small.values()}
    if len(counts) != 1 or 0 in counts:
        raise InputError("background", "every camera needs the same, non-zero number of frames")
    n_frames = counts.pop()
    small = {n: np.stack(f) for n, f in small.items()}
    carver = Carver(small_cams, grid)
    watched = watched_voxels(carver, holes)

    plates = {n: plate_from_frames(small[n], config, unstable=False) for n in names}
    covered = {n: np.zeros(small[n].shape[:3], bool) for n in names}
    iterations = max(1, int(config.plate_iterations))
    volumes = np.zeros(n_frames)
    for it in range(iterations):
        person_frames = []
        for f in range(n_frames):
            masks = each(lambda cam, f=f: _plate_mask(small[cam.name][f], plates[cam.name],
                                                      config), small_cams)
            person = carve_person(carver, masks, holes, watched=watched)
            person_frames.append((person, masks))
            volumes[f] = person.sum()
        # the typical person: the median over the frames where one was found (a few frames
        # with a background person or a ghost glued on must not set the scale)
        typical = float(np.median(volumes[volumes > 0])) if volumes.any() else 0.0
        if typical == 0:
            raise InputError("background", "no person found in any frame against the temporal "
                                           "median of the sequence: cannot learn a background "
                                           "plate; give empty background videos")
        vanished = volumes < config.plate_vanish_share * typical

        def relearn(c, it_frames=person_frames, vanished=vanished):
            cam = small_cams[c]
            cov = covered[cam.name]
            for f in range(n_frames):
                person, masks = it_frames[f]
                cov[f] = True if vanished[f] else _cover(
                    person, carver, c, masks[c], support=person if config.plate_support else None)
            old = plates[cam.name]
            new = plate_from_frames(small[cam.name], config, keep=~cov, unstable=False)
            # A pixel covered in every frame keeps its previous estimate while learning (the
            # final plate marks it unknown): the next pass may uncover it.
            fill = keep_count(cov) == 0
            new = PlateBackground(np.where(fill[..., None], old.plate, new.plate),
                                  np.where(fill, old.sigma, new.sigma),
                                  np.where(fill, old.known, new.known),
                                  false_alarm=config.false_alarm, shadows=config.shadows,
                                  shadow_brightness=config.shadow_brightness,
                                  shadow_chromaticity=config.shadow_chromaticity)
            moved = np.sqrt(((new.plate - old.plate) ** 2).sum(axis=2)) > 3 * new.camera_sigma
            return new, float(moved.mean())

        # each camera's covers and plate depend on this pass's carvings only: side by side
        relearnt = each(relearn, range(len(small_cams)))
        change = max(share for _, share in relearnt)
        for cam, (new, _) in zip(small_cams, relearnt, strict=True):
            plates[cam.name] = new
        if log is not None:
            log(f"background plate, pass {it + 1}: person in {int((~vanished).sum())} of "
                f"{n_frames} frames (typical {typical * grid.voxel_size ** 3 / 1e9:.3f} m³), "
                f"{100 * change:.2f} % of the pixels changed")
        if progress is not None:
            progress(it + 1, iterations)
        if observer is not None:
            observer(it + 1, plates, covered)
        if change < 0.002:
            break

    barely_moves = typical * grid.voxel_size ** 3 < MIN_PERSON_MM3
    if barely_moves:
        # The median still holds the body: what carves are the parts that moved. Where the
        # body is cannot be seen, but it is near them: the person-sized column around what
        # the silhouettes of all frames together carve (one frame's parts may be a foot alone)
        # is covered in every frame (a pixel uncovered once would be taken as seen), so its
        # pixels stay unknown and each frame's silhouette decides them (``plate_unknown``).
        swept = [np.any([person_frames[f][1][c] for f in range(n_frames)], axis=0)
                 for c in range(len(small_cams))]
        column = person_column(moving_parts(carver, swept, holes, watched=watched), grid)
        for c, cam in enumerate(small_cams):
            covered[cam.name] |= _cover(column, carver, c)[None]
        if log is not None:
            log(f"warning: the person carves into {typical * grid.voxel_size ** 3 / 1e6:.0f} "
                "litres only: the learnt plate may still hold the person (who moved too little "
                "in the sampled frames); its background is left unknown within "
                f"{PERSON_COLUMN_RADIUS_MM / 1000:g} m of the carved parts and "
                f"{PERSON_COLUMN_HEIGHT_MM / 1000:g} m of the floor; empty background videos would "
                "be better")
    return plates_from_covers(frames, cameras, covered, config, unknown_margin=barely_moves)


def _plate_mask(image: np.ndarray, plate: PlateBackground, config: SilhouetteConfig
                ) -> np.ndarray:
    """One camera's cleaned foreground of a downscaled frame against this pass's plate."""
    raw = _clean(plate.foreground(image), config)
    if config.plate_ghost_ratio > 0:
        raw &= ~_ghost_blobs(raw, image, plate.plate, config.plate_ghost_ratio,
                             max(config.min_area // 4, 8))
    return raw


def person_column(person: np.ndarray, grid) -> np.ndarray:
    """The voxels of a person-sized column around the carved voxels (same shape as ``person``).

    Voxels within :data:`PERSON_COLUMN_RADIUS_MM` horizontally of a carved voxel (the floor
    plan of the carved voxels grown by that radius: an exact Euclidean distance) and at most
    :data:`PERSON_COLUMN_HEIGHT_MM` above the grid's floor; empty when nothing is carved.
    """
    person = np.asarray(person, bool)
    if not person.any():
        return np.zeros_like(person)
    plan = person.any(axis=2)
    near = ndimage.distance_transform_edt(~plan) * grid.voxel_size <= PERSON_COLUMN_RADIUS_MM
    low = grid.axis_centres(2) <= grid.low[2] + PERSON_COLUMN_HEIGHT_MM
    return near[:, :, None] & low[None, None, :]


def plates_from_covers(frames: Mapping[str, np.ndarray], cameras,
                       covers: Mapping[str, np.ndarray], config: SilhouetteConfig | None = None,
                       *, unknown_margin: bool = False) -> dict[str, PlateBackground]:
    """One plate per camera from frames of the sequence and where the person is in each.

    Each pixel's background is estimated from the frames that do not cover it
    (:func:`plate_from_frames`); a pixel covered in every frame is never seen (``known`` False).
    :func:`learn_plates` finds the covers itself; a tracked body's image
    (:func:`voxelmocap.score.cues.contours.body_mask`) is another source.

    Parameters
    ----------
    frames : mapping of str to (F, H, W, C) or (F, H, W) uint8 ndarray
        The same ``F`` frames of every camera, taken one camera at a time.
    cameras : sequence of Camera
        The rig (names key ``frames`` and ``covers``).
    covers : mapping of str to (F, h, w) bool ndarray
        The person's pixels per frame, at any resolution (resized to the frames').
    config : SilhouetteConfig, optional
    unknown_margin : bool
        The covers are a margin wider than the person (a column around where they may be), not
        the person's own image: see :class:`~voxelmocap.measure.plate.PlateBackground`.

    Returns
    -------
    dict of str to PlateBackground

    Raises
    ------
    InputError
        A camera whose background was never seen over more than ``plate_max_unknown`` of its
        image, or covers that do not match the frames.
    """
    config = config or _DEFAULT
    out = {}
    for cam in cameras:
        frames_c = None                          # the previous camera's frames go first
        frames_c = np.asarray(frames[cam.name])
        frames_c = frames_c[..., None] if frames_c.ndim == 3 else frames_c
        cover = np.asarray(covers[cam.name], bool)
        if len(cover) != len(frames_c):
            raise InputError(f"background of {cam.name}",
                             f"{len(cover)} covers for {len(frames_c)} frames")
        h, w = frames_c.shape[1:3]
        keep = ~np.stack([cv2.resize(c.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST)
                          .astype(bool) for c in cover])
        plate = plate_from_frames(frames_c, config, keep=keep, unknown_margin=unknown_margin)
        unknown = 1.0 - float(plate.known.mean())
        if unknown > config.plate_max_unknown:
            raise InputError(f"background of {cam.name}",
                             f"the person covers {100 * unknown:.0f} % of the image in every "
                             "sampled frame: its background cannot be learnt from the sequence; "
                             "give an empty background video")
        out[cam.name] = plate
    return out


def keep_count(covered: np.ndarray) -> np.ndarray:
    """(H, W) number of frames in which each pixel is not covered."""
    return (~covered).sum(axis=0)


def _clean(mask: np.ndarray, config: SilhouetteConfig) -> np.ndarray:
    from .silhouette import clean_mask

    return clean_mask(mask, open_radius=1, close_radius=max(config.close_radius, 2),
                      min_area=max(config.min_area // 4, 8), fill_holes=True)


def _pixels_of(voxels: np.ndarray, carver: Carver, c: int) -> np.ndarray:
    """(H, W) uint8: 1 at the pixels of camera ``c`` that the voxels' centres project to."""
    w, h = carver.cameras[c].size
    out = np.zeros((h, w), np.uint8)
    idx = carver.tables[c][voxels.reshape(-1)]
    out.reshape(-1)[idx[idx >= 0] - int(carver._offsets[c])] = 1
    return out


def _cover(person: np.ndarray, carver: Carver, c: int,
           seen: np.ndarray | None = None, *, support: np.ndarray | None = None) -> np.ndarray:
    """Pixels of camera ``c`` covered by the person.

    The pixels of its voxels, dilated by a voxel's footprint and a margin, then closed with a
    disk of :data:`COVER_CLOSING` × the person's height in the image, holes filled: a torso that
    the plate absorbed (not carved) between carved arms and legs is covered too, without the
    whole convex hull under outstretched arms.

    With ``support`` (an occupancy: the person), the voxels under it down to the grid's floor
    are covered too, whether this view saw them or not (see below in the code).

    The person's cast shadow is not covered: a shadow that stays in one place for most of the
    frames ends up in the plate (and is then taken for background where it is, foreground
    where it left); covering a floor zone around the feet was tried and kept the place where
    the person stood covered in every frame of a short sequence.
    """
    cam = carver.cameras[c]
    out = _pixels_of(person, carver, c)
    if not out.any():
        return out.astype(bool)
    rows = np.flatnonzero(out.any(axis=1))
    # a voxel's footprint: its half-diagonal at the person's depth
    grid = carver.grid
    centre = grid.centre_of(np.argwhere(person).mean(axis=0))
    depth = max(float((matmul(cam.R, centre) + np.asarray(cam.T))[2]), grid.voxel_size)
    r = int(np.ceil(max(cam.fc) * grid.voxel_size * 0.87 / depth)) + 2
    out = cv2.dilate(out, _disk(r))
    if seen is not None:
        # the carve of a few views is fatter than the person: keep what this view saw, near
        out &= cv2.dilate(seen.astype(np.uint8), _disk(2 * r))
    if support is not None and support.any():
        # What lies under the person down to the floor is covered whatever this view saw: legs
        # the first plate absorbed (a subject who stands in one place) are missing from the
        # view's mask and the carve, so they were never covered and stayed in the plate.
        under = np.cumsum(support[:, :, ::-1], axis=2)[:, :, ::-1] > 0
        out |= cv2.dilate(_pixels_of(under & ~support, carver, c), _disk(r))
    close = int(COVER_CLOSING * (rows.max() - rows.min() + 2 * r))
    if close > 0:
        pad = close + 1
        out = cv2.morphologyEx(cv2.copyMakeBorder(out, pad, pad, pad, pad, cv2.BORDER_CONSTANT),
                               cv2.MORPH_CLOSE, _disk(close))[pad:-pad, pad:-pad]
    return _fill_holes(out.astype(bool))


def _disk(r: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))


def _fill_holes(mask: np.ndarray) -> np.ndarray:
    return ndimage.binary_fill_holes(mask)
