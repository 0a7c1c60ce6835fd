"""Typed, validated configuration of the tracking pipeline: the one home of its defaults.

Each stage has a frozen dataclass; :class:`TrackConfig` groups them. A TOML file may set any subset
of the keys (tables ``[measurement]`` with ``[measurement.silhouette]``, ``[likelihood]``,
``[filter]``, ``[init]``, ``[export]``); unknown keys, wrong types and values out of range are refused with an
error naming the file and the key, by one validator (:func:`config_from_dict`). Command-line options override
the file (:func:`with_overrides`), and the resolved configuration is stored with every result
(:func:`config_to_toml`), so a run can be reproduced and a resumed run checked against it.

>>> cfg = with_overrides(TrackConfig(), **{"filter.layers": 3})
>>> cfg.filter.layers, cfg.filter.particles
(3, 600)
"""

from __future__ import annotations

import dataclasses
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import InputError
from .grid import MIN_VOXELS_PER_AXIS
from .io.toml import dumps_toml, parse_toml, read_toml

__all__ = [
    "EXPORT_FORMATS",
    "CuesConfig",
    "ExportConfig",
    "FilterConfig",
    "InitConfig",
    "LikelihoodConfig",
    "MeasurementConfig",
    "RecoveryConfig",
    "SilhouetteConfig",
    "TrackConfig",
    "config_from_dict",
    "config_from_toml",
    "config_to_dict",
    "config_to_toml",
    "load_config",
    "with_overrides",
]


#: Sane voxel edges (mm). Finer than 1 mm is below a pixel's footprint at any capture distance
#: (≈ 5 mm per pixel at 4 m with HumanEva's lenses) and only costs memory; coarser than 250 mm
#: cannot hold a body part (limbs are 80–160 mm wide, the torso ≈ 320 mm) and puts fewer than
#: MIN_VOXELS_PER_AXIS voxels along a 2 m person. The paper works at 10–40 mm.
VOXEL_SIZE_RANGE = (1.0, 250.0)
#: Gaussian smoothing of the surface (voxels): beyond 10 voxels the smoothed surface is a blur
#: wider than the body at the default voxel size.
MAX_SURFACE_SIGMA = 10.0


def _choice(*options, default):
    return field(default=default, metadata={"choices": options})


@dataclass(frozen=True)
class SilhouetteConfig:
    """Background subtraction (:mod:`voxelmocap.measure.silhouette`): model, thresholds, shadows, clean-up.

    The TOML table ``[measurement.silhouette]``; per-camera thresholds are tables too
    (``camera_risk.BW1 = 1e6``). Built directly (``SilhouetteConfig(method="mog2")``) it is
    checked by the same validator as a file, so a bad value raises :class:`InputError`.
    """

    #: ``gaussian``: the HumanEva toolkit's per-pixel Gaussians learnt from background videos;
    #: ``mog2``: OpenCV's adaptive mixture (Zivkovic), learnt from background frames and online
    #: ``plate``: a static plate with per-pixel noise (:mod:`voxelmocap.measure.background`), from the
    #: background videos or, without them, learnt from the sequence itself (also what
    #: ``gaussian`` falls back to when a camera has no background video)
    method: str = _choice("gaussian", "mog2", "plate", default="gaussian")
    #: Gaussian model: foreground iff background likelihood < 1 / (256^C · risk); larger = fewer
    #: foreground pixels. The toolkit suggests 1 (colour), up to 1e60–1e100 for S1's noisy BW
    #: cameras (on its 0–1 intensity scale)
    risk: float = 1.0
    camera_risk: dict[str, float] = field(default_factory=dict)  #: per-camera ``risk``
    #: floor of the per-pixel variances (intensity², 0–255 scale). The toolkit uses 1e-3; 4
    #: (σ ≥ 2 grey levels) keeps video-compression wobble out of the foreground: on the
    #: project's synthetic MJPG sequences colour precision 0.90 → 0.96 at the same recall
    min_variance: float = 4.0
    var_threshold: float = 16.0  #: MOG2 ``varThreshold`` (squared Mahalanobis distance)
    camera_var_threshold: dict[str, float] = field(default_factory=dict)  #: per camera
    mog2_history: int = 500  #: MOG2 history length (frames)
    #: MOG2 learning rate while segmenting (-1 = OpenCV's automatic 1/history, 0 = frozen)
    mog2_learning_rate: float = -1.0
    #: remove cast shadows (Gaussian: Horprasert distortions; MOG2: OpenCV's shadow detector)
    shadows: bool = True
    #: range of the brightness ratio α (image / background) a shadow may have
    shadow_brightness: tuple[float, float] = (0.4, 0.95)
    shadow_chromaticity: float = 0.08  #: largest chromaticity distortion ``|I − αE| / |αE|``
    #: also suppress shadows on grayscale cameras (α in range and the background texture kept);
    #: off: where the floor has little texture it also removes dark clothing
    shadow_gray: bool = False
    shadow_ncc: float = 0.5  #: smallest image/background cross-correlation of a gray shadow
    shadow_window: int = 2  #: half-size (pixels) of that correlation window
    open_radius: int = 1  #: elliptic opening radius (pixels; 0 = off), removes speckle
    close_radius: int = 2  #: elliptic closing radius (pixels; 0 = off), fills gaps
    min_area: int = 50  #: remove 4-connected blobs smaller than this (pixels; toolkit: 10)
    largest_only: bool = False  #: keep only the largest 8-connected component (``one_comp``)
    fill_holes: bool = False  #: fill background regions enclosed by the silhouette
    #: ``plate``: probability that noise alone makes a pixel foreground; the threshold is the χ²
    #: quantile (C degrees of freedom) of the distance in units of each pixel's own noise σ,
    #: measured from the plate's frames (compression noise differs per camera and per pixel)
    false_alarm: float = 1e-4
    #: learnt plate: frames sampled over the sequence (spread evenly) to learn it from
    plate_frames: int = 60
    #: learnt plate: carve / project / re-estimate passes at most (they stop when stable)
    plate_iterations: int = 3
    #: learnt plate: a blob whose outline is this many times stronger an edge in the plate than
    #: in the frame is a ghost (the plate holds the person there); 0 = no ghost test
    plate_ghost_ratio: float = 1.5
    #: learnt plate: a frame whose person is below this share of the typical volume has the
    #: person inside the plate (absorbed); it covers its whole image while the plate is learnt
    plate_vanish_share: float = 0.3
    #: learnt plate: fewest uncovered frames a pixel needs for its background to be known
    plate_min_seen: int = 1
    #: learnt plate: largest share of an image whose background is never seen (the person is
    #: there in every frame) before the plate is refused; those pixels count as foreground
    plate_max_unknown: float = 0.4
    #: learnt plate: a pixel whose background samples spread (robust σ) beyond this many times
    #: the camera's noise is no background (a person who never left it, a moving object): it
    #: counts as foreground, and no pixel's noise σ is taken above this multiple
    plate_unstable: float = 4.0
    #: learnt plate: what a pixel whose background was never seen is, per frame. ``grabcut``:
    #: decided by OpenCV's GrabCut around it, from the colours of this frame's known person and
    #: known background (the Pose2Sim demo's silhouette IoU 0.37–0.60 → 0.59–0.73);
    #: ``foreground``: always foreground (the carving of the other views decides)
    plate_unknown: str = _choice("grabcut", "foreground", default="grabcut")
    #: learnt plate: while learning, cover in every view what lies under the carved person down
    #: to the floor (legs the first plate absorbed stay in it otherwise). On the Pose2Sim demo:
    #: recall 0.82–0.93 → 0.90–0.99 but precision 0.68–0.78 → 0.56–0.67 (never-seen regions
    #: grow, GrabCut takes part of them for the person) and tracking within the seed spread
    #: (docs/benchmarks.md): off by default
    plate_support: bool = False
    #: learnt plate from a previous run's body (``track --plate-from RUN``): the tracked body's
    #: image, grown by this margin (mm at the body's depth), is the person's cover in each frame.
    #: On the Pose2Sim demo (the one recording measured) 0 / 20 / 50 / 90 / 150 mm gave silhouette
    #: IoU 0.797 / 0.801 / 0.790 / 0.775 / 0.750: a wider cover leaves more pixels never seen
    plate_body_margin: float = 20.0
    #: learnt plate from a tracked body: a pixel the body left free in fewer than this share of
    #: the sampled frames (rounded to a count, at least ``plate_min_seen``) is unknown (GrabCut
    #: decides it per frame): where the person nearly always is, a few frames the body missed
    #: the person in can outvote the background. On the
    #: Pose2Sim demo (pass 2 from seed 0's pass 1, MediaPipe's masks as the reference) 0 (one
    #: frame) / 0.1 / 0.17 / 0.25 / 0.37 gave silhouette IoU 0.769 / 0.781 / 0.788 / 0.789 /
    #: 0.786, but 0.2 tracked seeds 0 / 1 / 2 to 71 / 428 / 117 mm against 130 / 102 / 107 mm
    #: with 0 (seed 1 kept a start facing backwards): not better, so 0 (docs/benchmarks.md)
    plate_body_min_seen: float = 0.0
    #: learnt plate: tracking passes. Each pass after the first learns the plate from the body
    #: the previous pass tracked (what ``track --plate-from RUN`` does by hand) and adds the
    #: silhouette cue; the earlier passes' results go to ``RUN/<subject>/pass<k>/``. On the
    #: Pose2Sim demo (seeds 0 / 1 / 2) one pass tracked to 470 / 270 / 452 mm, two to
    #: 130 / 102 / 107 mm, three to 73 / 68 / 72 mm (the third started from the second:
    #: ``[init] previous_pass_start``; started from the voxels it chose a start facing
    #: backwards for seed 1, 423 mm). Each pass tracks the whole sequence again: on an idle
    #: machine a pass tracked the demo's 100 frames in about 105 s (docs/benchmarks.md)
    plate_passes: int = 3
    #: GrabCut runs at this share of the image's resolution (its cost grows with the pixels)
    grabcut_scale: float = 0.33
    grabcut_iterations: int = 2  #: GrabCut's iterations per silhouette

    def __post_init__(self):
        _validate(self, "measurement.silhouette", "SilhouetteConfig")

    def risk_for(self, camera: str | None) -> float:
        """The Gaussian model's risk for ``camera`` (its override, else ``risk``)."""
        return float(self.camera_risk.get(camera, self.risk)) if camera else float(self.risk)

    def var_threshold_for(self, camera: str | None) -> float:
        """The MOG2 ``varThreshold`` for ``camera`` (its override, else ``var_threshold``)."""
        if camera:
            return float(self.camera_var_threshold.get(camera, self.var_threshold))
        return float(self.var_threshold)


@dataclass(frozen=True)
class MeasurementConfig:
    """Background subtraction, carving and surface smoothing."""

    voxel_size: float = 20.0  #: voxel edge (mm), within VOXEL_SIZE_RANGE
    #: grid corner (mm) and size (voxels); None derives the floor-standing box seen by the cameras
    grid_origin: tuple[float, float, float] | None = None
    grid_shape: tuple[int, int, int] | None = None
    #: a voxel is occupied when inside the silhouette of at least this many of the cameras that see
    #: it; None = all of them (the strict visual hull)
    min_views: int | None = None
    surface_sigma: float = 1.0  #: Gaussian smoothing of the surface voxels (voxels)
    background_frames: int = 200  #: background-video frames per camera used to learn the model
    #: background model, thresholds (per camera too) and clean-up
    silhouette: SilhouetteConfig = field(default_factory=SilhouetteConfig)
    #: where the grid goes when ``grid_origin`` is not given: ``rig``, the floor box every
    #: camera sees; ``person``, the box around the person found by a coarse carve of the area
    #: two or more cameras see (sampled frames), grown by ``grid_margin``; ``auto``, ``person``
    #: when the background is learnt from the sequence (a real recording), else ``rig``
    grid_placement: str = _choice("auto", "rig", "person", default="auto")
    #: ``person`` placement: margin (mm) around the person's box over the sampled frames, for
    #: limbs stretched further in frames not sampled (the Pose2Sim demo's leg and arm reached
    #: ~340 mm beyond the all-camera box)
    grid_margin: float = 400.0
    #: silhouettes that may miss an occupied voxel (segmentation holes), ``min_views`` unset:
    #: occupied when ≥ holes + 2 cameras see it and ≤ holes of them miss it. None: 1 when the
    #: background is learnt from the sequence and there are four or more cameras, else 0
    carve_holes: int | None = None
    #: with ``carve_holes``: a silhouette may miss an occupied voxel only when the voxel falls
    #: within this share of the image diagonal of it (a hole *in* the person, not a voxel far
    #: outside one view). The Pose2Sim demo (≈ 11 px): hull 420 → 261 litres, silhouette-
    #: reprojection IoU 0.46 → 0.57, tracked mean error 425 → 322 mm (0.012: 318 litres, 0.53);
    #: 0 = any distance
    carve_hole_reach: float = 0.005
    #: keep only the largest 3D component of every frame (a 2D blob of a background person or
    #: a ghost that carves into a separate piece is not the person). None: on when the
    #: background is learnt from the sequence
    person_only: bool | None = None
    #: voxel edge (mm) of the coarse carves that learn the plate and place the grid
    coarse_voxel_size: float = 50.0


@dataclass(frozen=True)
class LikelihoodConfig:
    """Voxel likelihood (paper 002 eqs 7–9)."""

    #: σ² of the Out, DO, Empty and Surf scores. Paper 002 has (0.01, 0.01, 0.1, 0.1); σ²_DO
    #: is 0.1 here because a real body's joints sit inside its neighbours' cones (shoulders
    #: inside the chest outline: the true pose of the mocap subjects has ρ_DO 0.8–0.9 on the
    #: upper arms), and with 0.01 the true pose scored 10–50 log-units *below* the tracked
    #: estimate on four of the five mocap clips (scripts/diagnose_likelihood.py). Measured
    #: (docs/benchmarks.md, "double occupancy"): with the answer 54.1 → 41.1 mm, without it
    #: 62.4 → 62.0 mm (MMTA 86.9 → 90.2 %), seed 0
    variances: tuple[float, float, float, float] = (0.01, 0.1, 0.1, 0.1)
    #: weight w of the coverage term ``−½ w u² / 0.1``, u the share of occupied voxels no part
    #: contains (``voxelmocap.score.likelihood.coverage_log_likelihood``): paper 002's scores judge
    #: each part by the voxels it contains, so a limb folded into its neighbour's voxels lost
    #: nothing for the real limb's voxels it left. 0: the paper's likelihood alone. The start's
    #: hypotheses are scored without it (``BodyTracker.initial_state``). Five clips without the
    #: answer, 3 seeds: 54.9 → 45.3 mm, MMTA 91.8 → 96.8 % (docs/benchmarks.md, "The coverage
    #: term"; 300 and 3000 screened too)
    coverage: float = 1000.0
    #: standard deviation (degrees) of a zero-mean Gaussian prior on the root pitch, which the
    #: voxels cannot see: the hips lie on the pitch axis, so pitch + waist and hip flexion
    #: compensate exactly (docs/benchmarks.md, null direction). None: no prior
    root_pitch_prior_deg: float | None = None


@dataclass(frozen=True)
class FilterConfig:
    """Annealed particle filter and its dynamics (``voxelmocap.tracking``).

    Every option of ``AnnealedParticleFilter`` and of the dynamics models can be set here; their
    legal ranges are stated once, by ``voxelmocap.tracking.apf.check_options`` and the dynamics'
    constructors, and checked when a config is built.
    """

    layers: int = 6
    particles: int = 600
    #: ``iapf``: a share of layer 1 comes from the detector proposal (``iapf_fractions``,
    #: ``[recovery]``; ``voxelmocap.pose.recovery.detector_proposal``)
    strategy: str = _choice("apf", "sir", "iapf", default="apf")
    #: target share of surviving particles per layer (β by bisection), in (0, 1]. Measured: 0.3
    #: helps a walk (μ 59 → 46 mm, 5 seeds) and a jog (60 → 57 mm) but hurts a box sequence
    #: (56 → 63 mm); 0.7 is worse (walk 89 mm with the earlier noise); see docs/benchmarks.md
    survival: float = 0.5
    noise_decay: float = 0.5  #: propagation covariance multiplier per layer, in (0, 1]
    #: fixed likelihood exponents, one per layer (e.g. Fontmarty's [0.1, 0.4, 1]) instead of the
    #: adaptive β
    betas: tuple[float, ...] | None = None
    #: Fontmarty's dynamics exponents, one per layer (noise std / √α); overrides ``noise_decay``
    alphas: tuple[float, ...] | None = None
    beta_max: float | None = None  #: upper limit of the adaptive β (None: unbounded)
    resampling: str = _choice("systematic", "stratified", "multinomial", "residual",
                              default="systematic")
    #: IAPF: shares of layer 1 drawn from the dynamics and from the proposal (rest: the prior)
    iapf_fractions: tuple[float, float] = (0.8, 0.2)
    dynamics: str = _choice("random_walk", "velocity", "elbow", default="random_walk")
    #: ``velocity`` and ``elbow``: the diagonal of A in ``s_k = s_{k-1} + A (s̄_{k-1} − s̄_{k-2})``
    #: (paper 000 eq. 15), in [0, 1]
    velocity_factor: float = 0.7
    #: ``elbow``: an elbow closer to straight than this counts as singular (paper 000 §4.4, φ)
    elbow_threshold_rad: float = 0.2
    #: ``elbow``: the shoulder-twist noise while the elbow is singular (β̂)
    elbow_singular_std_rad: float = 0.4
    #: per-frame propagation noise (standard deviations) of the state groups at 60 Hz: half the
    #: largest expected change in one frame (paper 002 §2.3). ``rotation_std_rad`` applies to the
    #: root *and* the waist and neck (``tracker.noise_profile``), ``joint_std_rad`` to the limbs.
    translation_std_mm: float = 25.0
    #: measured: 0.03 helps a walk (μ 59 → 47 mm, 5 seeds) and a jog (60 → 52 mm) but hurts a
    #: box sequence, whose trunk turns fast (56 → 63 mm, 3 seeds); 0.1 is worse (walk 73 mm)
    rotation_std_rad: float = 0.06
    #: measured (``scripts/study_tracking.py``, synthetic walk 60 frames, 7 cameras, 6 × 300
    #: particles, 5 seeds): 0.15 → μ 83 mm, MMTA 75 %; 0.1 → μ 58 mm, MMTA 88 % (jog 80 → 60 mm,
    #: box 88 → 56 mm with the trunk on ``rotation_std_rad``, 3 seeds). 0.07 is too little to
    #: follow the knees (walk 76 mm, 3 seeds: the legs are lost mid-stride); 0.12 gave 70 mm on the
    #: jog. 0.1 rad = 5.7° per frame at 60 Hz.
    joint_std_rad: float = 0.1
    #: ``joint``: every layer searches all 27 dimensions (paper 002); ``hierarchical`` (with the
    #: ``apf`` strategy; ``sir`` and ``iapf`` always search jointly): the root,
    #: trunk and head first, then each limb with the rest held at the estimate, the limbs scored
    #: by exact partial re-scoring (``voxelmocap.pose.hierarchy``; ``layers``/``particles`` then do
    #: not apply). Screened without the answer (walk, jog, box, 40 frames, seed 0; with
    #: ``refine_evaluations`` 40 and ``init.settle_steps`` 5): mean μ 89 mm against the joint
    #: search's 115 mm; docs/benchmarks.md, "Accuracy without the answer".
    search: str = _choice("hierarchical", "joint", default="hierarchical")
    #: hierarchical search: layers and particles of the root-and-trunk partition and per limb
    #: (an arm: shoulder 3 + elbow; the two legs are one partition with twice the particles).
    #: None: from ``layers`` and ``particles``, spending the joint search's budget — the trunk
    #: ``layers // 2`` layers of ``particles``, limbs ``layers // 3`` layers of ``3/8 ·
    #: particles`` each (at 6 × 600: 3 × 600, legs 2 × 450, arms 2 × 225: 3600 evaluations)
    trunk_layers: int | None = None
    trunk_particles: int | None = None
    limb_layers: int | None = None
    limb_particles: int | None = None
    #: likelihood evaluations of the deterministic compass search refining each partition's
    #: estimate (hierarchical search; 0 = no refinement)
    refine_evaluations: int = 40
    #: hierarchical search: share of each limb partition's first layer drawn uniformly over the
    #: limb's legal ranges (a 4-dimensional box is small enough to search globally), in [0, 1)
    limb_explore: float = 0.0
    #: hierarchical search: share of each limb partition's first layer whose limb comes from
    #: the detector proposal of the frame (the voxels' extremities fitted by inverse kinematics,
    #: ``voxelmocap.pose.recovery.detector_proposal``, spread ``recovery.proposal_spread``), in
    #: [0, 1); 0 = none (no detection either)
    limb_proposal: float = 0.0
    #: every this many frames, search each limb of the estimate over its legal ranges
    #: (``voxelmocap.pose.limb_search``, the voxel likelihood with the coverage term) and move the
    #: particles to a limb found better: a limb the start folded is unfolded once its voxels
    #: show it (the gestures' forearm), a limb lost by the annealing is found again; 0 = never.
    #: Five clips without the answer, 3 seeds: 10 (gain 2, 256 samples) → 42.8 mm mean,
    #: gestures 59.1 → 47.2; 0 → 45.3 mm (docs/benchmarks.md)
    limb_sweep_every: int = 10
    #: the periodic sweep moves a limb only when it gains more than this (log-likelihood
    #: units): for a frame the likelihood can prefer a wrong fold by a fraction of a unit (the
    #: jog's left forearm flipped for a gain of 0.23 and stayed folded). 0 → 44.0 mm, 2 → 43.6,
    #: 5 → 44.3 (the gestures' forearm then unfolds less often)
    limb_sweep_gain: float = 2.0
    #: ... and only on frames whose occupied volume is at most this many times the body
    #: model's: 7 rendered cameras give 0.75–1.3 ×, 4 of them 3–6 ×, the Pose2Sim demo's four
    #: real views ≈ 5 ×, where every sweep moved a limb into phantom volume (a leg swung by
    #: 1.9 rad, the error up 100 mm at each sweep frame: 270 → 456 mm over the clip). With
    #: the silhouette cue scoring the sweep too and MediaPipe's masks as silhouettes, 2 gave
    #: 116–121 mm there and 1000 (no gate) 74–77 mm; with voxelmocap's own silhouettes the
    #: ungated sweep is worse (docs/benchmarks.md); ``track --masks`` opens it (1000)
    limb_sweep_max_hull: float = 2.0
    #: Sobol points per limb of the periodic sweep (rounded up to a power of two; the start's
    #: sweep uses 1024): 256 → 42.8 mm and ≈ 25 ms a sweep, 1024 → 43.6 mm and ≈ 70 ms
    limb_sweep_samples: int = 256
    #: the limb searches (the start's and the periodic one) first try each pair of limbs
    #: exchanged (``voxelmocap.pose.limb_search.swapped_limbs``): legs crossed onto each other's
    #: voxels are one move from right, which a search of one limb cannot make
    limb_swaps: bool = False
    #: every this many frames, score the estimate against its turned-round twin (the body
    #: turned 180° in place, left and right exchanged, its limbs searched over their ranges;
    #: ``voxelmocap.pose.facing``) with the likelihood and the facing evidence, and turn the
    #: track round when the twin wins by more than ``facing_margin``; 0 = never. A walk
    #: started turned round from its ground truth turned back at frame 10 (mean error
    #: 248 → 63 mm there); no track that faced the right way was turned (docs/benchmarks.md)
    facing_check_every: int = 10
    #: log-likelihood units the twin must win by (likelihood + ``facing_weight`` × evidence)
    facing_margin: float = 2.0
    #: log-likelihood units per unit of facing evidence (feet in front of the ankles, the
    #: direction of travel; each in [−1, 1]) in the facing check and the multi-start's choice
    facing_weight: float = 0.0

    def filter_options(self) -> dict:
        """The ``AnnealedParticleFilter`` keyword options beyond sizes, strategy and noise."""
        return {"survival": self.survival, "noise_decay": self.noise_decay,
                "betas": self.betas, "alphas": self.alphas,
                "beta_max": np.inf if self.beta_max is None else self.beta_max,
                "resampling": self.resampling, "iapf_fractions": self.iapf_fractions}


@dataclass(frozen=True)
class InitConfig:
    """How tracking starts."""

    #: ``ground_truth``: fit the body to the first frame's ground truth; ``extremities``: fit
    #: labelled hypotheses to the voxels' head, hand and foot tips and start from a mixture of
    #: the most likely (``voxelmocap.pose.initialise``); ``voxels``: a standing pose at the voxel
    #: centroid, best of 36 headings (the first method, kept for comparison); ``auto``: ground
    #: truth when the sequence has it, else ``extremities``
    method: str = _choice("auto", "ground_truth", "extremities", "voxels", default="auto")
    spread: float = 0.25  #: initial particle spread, as a multiple of the propagation noise
    #: ``extremities``: distinct starting poses the first particles are spread over (equal shares)
    hypotheses: int = 4
    #: ``extremities``: track each starting pose on its own for this many frames and keep the
    #: likeliest (``tracker.MultiStart``); 0 starts one filter from their mixture. Measured on
    #: the five clips without the answer (3 seeds): 10 → mean μ 95 mm, no lost track; 0 → 143 mm
    #: (one or two seeds of four clips lost, facing turned); docs/benchmarks.md
    multistart_frames: int = 10
    #: body size when there is no body file and no ground truth: ``voxels`` scales the average
    #: adult to the height of the first frame's voxels, ``average`` keeps the 1780 mm adult,
    #: ``fitted`` also fits the limb lengths to the voxels of the multi-start frames and tracks
    #: them again with the fitted body (``voxelmocap.pose.body_size``; needs ``multistart_frames``).
    #: Five clips without the answer (100 frames, 3 seeds, σ²_DO 0.1 and the limb sweep):
    #: fitted 60.5 mm / MMTA 91.2 % against voxels 63.8 mm / 88.4 % (walk 61.9 → 52.4, combo
    #: 62.1 → 56.3, box 56.8 → 58.6); with σ²_DO 0.01 it was within seed noise; with the
    #: candidate bodies scored on re-aimed poses (``body.retarget``) 56.3 mm / 91.3 %, and
    #: with the fit's double-occupancy term off 54.9 mm / 91.8 % (docs/benchmarks.md)
    body: str = _choice("voxels", "average", "fitted", default="fitted")
    #: extra filter steps on the first frame before it is recorded, so that a rough start (an
    #: extremity fit, a standing pose) settles onto the first frame's voxels instead of being
    #: dragged along by the motion while still far off; the estimate history is then cleared
    settle_steps: int = 5
    #: search each starting pose's four limbs over their whole legal ranges on the first frame
    #: (``voxelmocap.pose.limb_search``; starts found from the voxels only): a start fitted to the
    #: extremities often has a limb in a wrong optimum the annealing never leaves. Measured on
    #: the five clips without the answer (seed 0, σ²_DO 0.1): 84.1 mm without, 62.0 mm with.
    #: A re-initialisation (``voxelmocap.pose.recovery``) searches its candidates' limbs too
    limb_sweep: bool = True
    #: a run that learns its plate in passes (``[measurement.silhouette] plate_passes``): pass
    #: ``k`` from this one on starts from the previous pass's body and its pose at the first
    #: frame instead of from the voxels (the second pass, the first on a plate learnt from a
    #: body, finds its own start), only its arms searched again (``limb_sweep``); 0: every pass
    #: starts from the voxels. On the Pose2Sim demo a third pass started from the voxels chose a
    #: start facing backwards (seed 1, 423 mm); started from the second pass, seeds 0 / 1 / 2
    #: tracked to 73 / 68 / 72 mm against 130 / 102 / 107 mm after two passes (all limbs
    #: searched: seed 2 105 mm; none: 73 / 69 / 67 mm, the left arm of seed 0 off for its
    #: first 10 frames; docs/benchmarks.md)
    previous_pass_start: int = 3
    #: test hook: start from the best start alone, turned round
    #: (``voxelmocap.pose.facing.turned_round``), to check that the facing check turns it back
    start_turned: bool = False


#: Formats ``track`` and ``export`` write (:mod:`voxelmocap.io.exports`).
EXPORT_FORMATS = ("trc", "c3d", "csv")


@dataclass(frozen=True)
class ExportConfig:
    """The landmark files ``track`` writes beside each result (``docs/outputs.md``).

    Not part of tracking: a resumed run may change them, and ``voxelmocap export`` rewrites
    them from a finished result.
    """

    #: formats written after tracking (``trc``, ``c3d``, ``csv``); ``[]`` writes none. TRC and
    #: CSV by default: plain text, read by OpenSim / Pose2Sim and by anything, no extra package
    formats: tuple[str, ...] = ("trc", "csv")
    #: zero-lag Butterworth low-pass of the exported trajectories (Hz); absent = no filtering
    #: (the exports equal the result file). 6 Hz lowered μ by 1.8 mm on the benchmark clips
    #: (docs/benchmarks.md); the result file and ``evaluate`` always keep the raw estimates
    cutoff_hz: float | None = None
    order: int = 4  #: order of the zero-lag filter (even: a Butterworth of half of it, run twice)
    #: ``world``: the calibration's frame (Z up); ``y_up``: OpenSim's Y up, as Pose2Sim writes
    #: (X ← Y, Y ← Z, Z ← X)
    axes: str = _choice("world", "y_up", default="world")


@dataclass(frozen=True)
class RecoveryConfig:
    """Frames without a person, lost tracks and the IAPF's detector proposal
    (``voxelmocap.pose.recovery``)."""

    #: flag frames without a person (not tracked) and re-initialise when the person comes back
    #: or the track is lost (``BodyTracker.observe``); off: every frame is tracked
    enabled: bool = True
    #: a frame has a person when its largest blob of occupied voxels holds at least this share
    #: of the body model's volume (a visual hull contains the body: 1.0–1.4 × when in view)
    min_volume_share: float = 0.3
    #: lost track: a frame is bad when the voxel cue's log-likelihood (paper 002's, whatever
    #: other cues are fused; the fused value when the voxel cue is not selected:
    #: ``BodyTracker.lost_track_value``) is more than ``lost_drop`` below the
    #: median of the last ``lost_window`` good frames, or the mean Empty score of the parts is
    #: above ``lost_empty``; ``lost_patience`` bad frames in a row make the track lost (a good
    #: track varies between −11 and −26 on the rendered walk, median −14)
    lost_window: int = 30
    lost_drop: float = 20.0
    lost_empty: float = 0.5
    lost_patience: int = 3
    reinitialise: bool = True  #: re-initialise a lost track (off: only flag it in the log)
    #: spread of each detector-proposal component, as a multiple of the propagation noise
    proposal_spread: float = 1.0
    proposal_gate_mm: float = 400.0  #: a tip farther than this from every body end is ignored
    #: add the left/right-swapped fit as a second component. Off: measured without the answer
    #: (seed 0, docs/benchmarks.md) it let a wrong side win: Jog 280 mm with it, 86 without
    #: (apf 79); Walking 73 / 83 (apf 84); Box 177 / 148 (apf 168)
    proposal_mirror: bool = False
    #: weight layer 1 by p/q (Table I line 8). Off (Fontmarty's practice): the proposal's
    #: particles far from the dynamics would get weight ≈ 0, so the proposal could not recover
    proposal_correction: bool = False


@dataclass(frozen=True)
class CuesConfig:
    """Likelihood cues and their fusion (``voxelmocap.score.cues``, ``docs/cues.md``).

    The global log-likelihood is ``Σ weight · log p`` over the cues named in ``weights``.
    """

    #: cue name → weight: ``voxel`` (paper 002), ``edges`` (000 §4.1.1), ``dt``, ``roi``,
    #: ``blob3d``, ``skin``, ``uniform`` (004 §III-B), ``silhouette`` (the projected body
    #: against each camera's silhouette). The default is the voxel likelihood alone
    weights: dict[str, float] = field(default_factory=lambda: {"voxel": 1.0})
    #: Azad's Δ (pixels between observed contour points; also the ``dt`` cue's), δ (search
    #: half-length, pixels), G_MIN (smallest grey step) and σ² of eq 13
    edge_spacing: float = 5.0
    edge_search: int = 15
    edge_min_gradient: float = 12.0
    edge_variance: float = 0.0025
    #: costs of a point whose search leaves the picture (C1), of an occluded point (C2, default
    #: δ²) and of a point with no edge (C3, default (δ + 5)²)
    edge_c1: float = 0.0
    edge_c2: float | None = None
    edge_c3: float | None = None
    #: the fast occlusion test (paper 000 §4.3) for ``edges``, ``dt``, ``roi``, ``uniform``
    occlusion: bool = True
    #: Canny hysteresis thresholds (grey levels) of the ``dt`` cue's edge image
    canny: tuple[float, float] = (50.0, 150.0)
    #: Fontmarty's Table II: σ_e (pixels), σ_ROI, σ_3D (0.15 m, in mm), σ_s, σ_m (grey levels)
    sigma_dt: float = 10.0
    sigma_roi: float = 0.3
    sigma_3d_mm: float = 150.0
    sigma_skin: float = 0.02
    sigma_uniform: float = 10.0
    #: levels per colour channel of the ROI histograms (n³ bins; n² grey levels for grey cameras)
    histogram_bins: int = 4
    #: levels per channel of the skin colour model
    skin_bins: int = 8
    #: samples across and along every part's image quadrangle (``roi``, ``uniform``)
    roi_samples: tuple[int, int] = (5, 8)
    #: ``uniform`` applies to the parts whose colour standard deviation in the reference frame is
    #: at most this (grey levels)
    uniform_max_std: float = 20.0
    #: ``silhouette``: the masks are compared at this many pixels along the image's longer side,
    #: and each camera's log-likelihood is −D / ``silhouette_scale``, D = (silhouette pixels the
    #: body leaves uncovered + body pixels outside the silhouette) / silhouette pixels
    silhouette_size: int = 320
    silhouette_scale: float = 0.02
    #: silhouette pixels whose background a learnt plate never saw (GrabCut's guess): ``count``
    #: like any other; ``ignore`` — uncovered, they cost nothing (body pixels outside the
    #: silhouette still do). On the Pose2Sim demo ``ignore`` ranked the reference's pose above
    #: the estimate more often but tracked worse (336–358 against 217–227 mm, 2 seeds with
    #: ``plate_support``; docs/benchmarks.md)
    silhouette_unseen: str = _choice("count", "ignore", default="count")


@dataclass(frozen=True)
class TrackConfig:
    """Everything a tracking run depends on, apart from the data and the seed."""

    measurement: MeasurementConfig = field(default_factory=MeasurementConfig)
    likelihood: LikelihoodConfig = field(default_factory=LikelihoodConfig)
    filter: FilterConfig = field(default_factory=FilterConfig)
    init: InitConfig = field(default_factory=InitConfig)
    export: ExportConfig = field(default_factory=ExportConfig)
    recovery: RecoveryConfig = field(default_factory=RecoveryConfig)
    cues: CuesConfig = field(default_factory=CuesConfig)


# ---------------------------------------------------------------------- conversion and checks
def _check_value(value, hint, key: str, source):
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        return _check_value(value, inner[0], key, source)
    if hint is bool:
        if not isinstance(value, bool):
            raise InputError(source, f"key {key!r} must be true or false, got {value!r}")
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise InputError(source, f"key {key!r} must be an integer, got {value!r}")
        return int(value)
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
            raise InputError(source, f"key {key!r} must be a number, got {value!r}")
        if not np.isfinite(value):
            raise InputError(source, f"key {key!r} must be finite, got {value!r}")
        return float(value)
    if hint is str:
        if not isinstance(value, str):
            raise InputError(source, f"key {key!r} must be a string, got {value!r}")
        return value
    if origin is dict:
        if not isinstance(value, dict):
            raise InputError(source, f"key {key!r} must be a table, got {value!r}")
        out = {}
        for name, item in value.items():
            if not isinstance(name, str):
                raise InputError(source, f"key {key!r} must have string keys, got {name!r}")
            out[name] = _check_value(item, args[1], f"{key}.{name}", source)
        return out
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise InputError(source, f"key {key!r} must be a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_check_value(v, args[0], key, source) for v in value)
        if len(value) != len(args):
            raise InputError(source, f"key {key!r} must have {len(args)} values, got {len(value)}")
        return tuple(_check_value(v, a, key, source) for v, a in zip(value, args, strict=True))
    raise TypeError(f"unsupported config type {hint!r}")  # pragma: no cover - programming error


def _build(cls, data, prefix: str, source):
    if not isinstance(data, dict):
        raise InputError(source, f"[{prefix}] must be a table")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        where = f"{prefix}.{unknown[0]}" if prefix else unknown[0]
        raise InputError(source, f"unknown key {where!r} (known: {', '.join(sorted(fields))})")
    kwargs = {}
    for name, value in data.items():
        key = f"{prefix}.{name}" if prefix else name
        hint = hints[name]
        if dataclasses.is_dataclass(hint):
            kwargs[name] = _build(hint, value, key, source)
            continue
        checked = _check_value(value, hint, key, source)
        choices = fields[name].metadata.get("choices")
        if choices and checked not in choices:
            raise InputError(source, f"key {key!r} must be one of {', '.join(choices)}, "
                                     f"got {checked!r}")
        kwargs[name] = checked
    try:
        obj = cls(**kwargs)
    except InputError as exc:  # a class that validates itself: the message names the key
        raise InputError(source, exc.problem) from None
    _check_ranges(obj, prefix, source)
    return obj


def _validate(obj, prefix: str, source) -> None:
    """Check the field values of a config built directly (types, choices, ranges).

    Tuples and tables are normalised in place (``object.__setattr__``: the classes are frozen),
    so a config built from Python values equals the same config read from TOML.
    """
    hints = typing.get_type_hints(type(obj))
    for f in dataclasses.fields(obj):
        key = f"{prefix}.{f.name}"
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(hints[f.name]):
            continue
        checked = _check_value(value, hints[f.name], key, source)
        choices = f.metadata.get("choices")
        if choices and checked not in choices:
            raise InputError(source, f"key {key!r} must be one of {', '.join(choices)}, "
                                     f"got {checked!r}")
        object.__setattr__(obj, f.name, checked)
    _check_ranges(obj, prefix, source)


def _check_ranges(obj, prefix: str, source) -> None:
    if isinstance(obj, MeasurementConfig):
        _check_measurement(obj, prefix, source)
    positive = {"voxel_size", "surface_sigma", "layers", "particles", "translation_std_mm",
                "rotation_std_rad", "joint_std_rad", "background_frames", "hypotheses",
                "trunk_layers", "trunk_particles", "limb_layers", "limb_particles",
                "root_pitch_prior_deg",
                "min_volume_share", "lost_window", "lost_drop", "lost_empty", "lost_patience",
                "proposal_spread", "proposal_gate_mm"}
    for name in positive:
        if hasattr(obj, name) and getattr(obj, name) is not None and not getattr(obj, name) > 0:
            key = f"{prefix}.{name}" if prefix else name
            raise InputError(source, f"key {key!r} must be > 0")
    if isinstance(obj, InitConfig) and obj.settle_steps < 0:
        raise InputError(source, f"key '{prefix}.settle_steps' must be >= 0")
    if isinstance(obj, InitConfig) and (obj.previous_pass_start < 0
                                        or obj.previous_pass_start == 1):
        raise InputError(source, f"key '{prefix}.previous_pass_start' must be 0 (never) or >= 2")
    if isinstance(obj, FilterConfig):
        _check_filter(obj, prefix, source)
        if not 0.0 <= obj.limb_explore < 1.0:
            raise InputError(source, f"key '{prefix}.limb_explore' must be in [0, 1)")
        if not 0.0 <= obj.limb_proposal < 1.0:
            raise InputError(source, f"key '{prefix}.limb_proposal' must be in [0, 1)")
        if obj.limb_sweep_every < 0:
            raise InputError(source, f"key '{prefix}.limb_sweep_every' must be >= 0")
        if not obj.limb_sweep_gain >= 0:
            raise InputError(source, f"key '{prefix}.limb_sweep_gain' must be >= 0")
        if obj.limb_sweep_samples < 2:
            raise InputError(source, f"key '{prefix}.limb_sweep_samples' must be >= 2")
        if not obj.limb_sweep_max_hull > 0:
            raise InputError(source, f"key '{prefix}.limb_sweep_max_hull' must be > 0")
        if obj.facing_check_every < 0:
            raise InputError(source, f"key '{prefix}.facing_check_every' must be >= 0")
        if not (obj.facing_margin >= 0 and obj.facing_weight >= 0):
            raise InputError(source, f"keys '{prefix}.facing_margin' and '{prefix}.facing_weight' "
                                     "must be >= 0")
        if obj.refine_evaluations < 0:
            raise InputError(source, f"key '{prefix}.refine_evaluations' must be >= 0")
        for name in ("trunk_particles", "limb_particles"):
            if getattr(obj, name) is not None and getattr(obj, name) < 2:
                raise InputError(source, f"key '{prefix}.{name}' must be >= 2")
    if isinstance(obj, LikelihoodConfig) and min(obj.variances) <= 0:
        raise InputError(source, "key 'likelihood.variances' must be positive")
    if isinstance(obj, LikelihoodConfig) and not obj.coverage >= 0:
        raise InputError(source, f"key 'likelihood.coverage' must be >= 0, got {obj.coverage}")
    if isinstance(obj, SilhouetteConfig):
        _check_silhouette(obj, prefix, source)
    if isinstance(obj, ExportConfig):
        _check_export(obj, prefix, source)

    if isinstance(obj, CuesConfig):
        _check_cues(obj, prefix, source)


def _check_export(obj: ExportConfig, prefix: str, source) -> None:
    unknown = [f for f in obj.formats if f not in EXPORT_FORMATS]
    if unknown:
        raise InputError(source, f"key '{prefix}.formats': unknown format {unknown[0]!r} (known: "
                                 f"{', '.join(EXPORT_FORMATS)})")
    if obj.cutoff_hz is not None and not obj.cutoff_hz > 0:
        raise InputError(source, f"key '{prefix}.cutoff_hz' must be > 0 (leave it out for no "
                                 "filtering)")
    if obj.order < 2 or obj.order % 2:
        raise InputError(source, f"key '{prefix}.order' must be an even integer >= 2, got "
                                 f"{obj.order}")


def _check_measurement(obj: MeasurementConfig, prefix: str, source) -> None:
    def bad(name, rule):
        raise InputError(source, f"key '{prefix}.{name}' must be {rule}")

    low, high = VOXEL_SIZE_RANGE
    if not low <= obj.voxel_size <= high:
        bad("voxel_size", f"between {low:g} and {high:g} mm, got {obj.voxel_size:g}")
    if not 0 < obj.surface_sigma <= MAX_SURFACE_SIGMA:
        bad("surface_sigma", f"> 0 and <= {MAX_SURFACE_SIGMA:g} voxels, got {obj.surface_sigma:g}")
    if obj.background_frames < 1:
        bad("background_frames", ">= 1")
    if obj.min_views is not None and obj.min_views < 1:
        bad("min_views", ">= 1")
    if (obj.grid_origin is None) != (obj.grid_shape is None):
        raise InputError(source, f"keys '{prefix}.grid_origin' and '{prefix}.grid_shape' go "
                                 "together")
    if obj.grid_margin < 0:
        bad("grid_margin", ">= 0")
    if obj.carve_holes is not None and obj.carve_holes < 0:
        bad("carve_holes", ">= 0")
    if not 0 <= obj.carve_hole_reach <= 1:
        bad("carve_hole_reach", "between 0 and 1")
    if not low <= obj.coarse_voxel_size <= high:
        bad("coarse_voxel_size", f"between {low:g} and {high:g} mm, got {obj.coarse_voxel_size:g}")
    if obj.grid_shape is not None and min(obj.grid_shape) < MIN_VOXELS_PER_AXIS:
        bad("grid_shape", f"at least {MIN_VOXELS_PER_AXIS} voxels along every axis, got "
                          f"{list(obj.grid_shape)}")


def _check_silhouette(obj: SilhouetteConfig, prefix: str, source) -> None:
    def bad(name, rule):
        raise InputError(source, f"key '{prefix}.{name}' must be {rule}")

    for name in ("risk", "min_variance", "var_threshold"):
        if not getattr(obj, name) > 0:
            bad(name, "> 0")
    for name in ("camera_risk", "camera_var_threshold"):
        for camera, value in getattr(obj, name).items():
            if not value > 0:
                bad(f"{name}.{camera}", "> 0")
    if not (obj.mog2_learning_rate == -1 or 0 <= obj.mog2_learning_rate <= 1):
        bad("mog2_learning_rate", "-1 (automatic) or between 0 and 1")
    low, high = obj.shadow_brightness
    if not 0 <= low < high <= 1.5:
        bad("shadow_brightness", f"[low, high] with 0 <= low < high <= 1.5, got [{low}, {high}]")
    if not obj.shadow_chromaticity >= 0:
        bad("shadow_chromaticity", ">= 0")
    if not -1 <= obj.shadow_ncc <= 1:
        bad("shadow_ncc", "between -1 and 1")
    for name in ("open_radius", "close_radius", "min_area", "shadow_window"):
        if getattr(obj, name) < 0:
            bad(name, ">= 0")
    if obj.mog2_history < 1:
        bad("mog2_history", ">= 1")
    if not 0 < obj.false_alarm < 0.5:
        bad("false_alarm", "between 0 and 0.5 (exclusive)")
    for name in ("plate_frames", "plate_iterations", "plate_min_seen", "plate_passes"):
        if getattr(obj, name) < 1:
            bad(name, ">= 1")
    if not obj.plate_unstable > 1:
        bad("plate_unstable", "> 1")
    if obj.plate_ghost_ratio < 0:
        bad("plate_ghost_ratio", ">= 0")
    for name in ("plate_vanish_share", "plate_max_unknown"):
        if not 0 <= getattr(obj, name) <= 1:
            bad(name, "between 0 and 1")
    if obj.plate_body_margin < 0:
        bad("plate_body_margin", ">= 0")
    if not 0 <= obj.plate_body_min_seen < 1:
        bad("plate_body_min_seen", "in [0, 1)")
    if not 0 < obj.grabcut_scale <= 1:
        bad("grabcut_scale", "in (0, 1]")
    if obj.grabcut_iterations < 1:
        bad("grabcut_iterations", ">= 1")


#: The cues ``[cues] weights`` and ``track --cues`` may name: the keys of
#: :data:`voxelmocap.score.cues.CUES` (a test holds the two equal; the config sits below the cues).
CUE_NAMES = ("voxel", "edges", "dt", "roi", "blob3d", "skin", "uniform", "silhouette")


def check_cue_weights(weights: dict, source, key: str = "cues.weights") -> None:
    """Refuse unknown cue names, non-positive weights and an empty selection."""
    known = ", ".join(CUE_NAMES)
    if not weights:
        raise InputError(source, f"key {key!r} selects no cue (known: {known})")
    for name, w in weights.items():
        if name not in CUE_NAMES:
            raise InputError(source, f"key {key!r}: unknown cue {name!r} (known: {known})")
        if not (np.isfinite(w) and w > 0):
            raise InputError(source, f"key '{key}.{name}' must be a positive weight, got {w!r}")


def _check_cues(obj: CuesConfig, prefix: str, source) -> None:
    check_cue_weights(obj.weights, source, f"{prefix}.weights")
    for name in ("edge_spacing", "edge_search", "edge_variance", "sigma_dt", "sigma_roi",
                 "sigma_3d_mm", "sigma_skin", "sigma_uniform", "histogram_bins", "skin_bins",
                 "uniform_max_std", "silhouette_size", "silhouette_scale"):
        if not getattr(obj, name) > 0:
            raise InputError(source, f"key '{prefix}.{name}' must be > 0")
    for name in ("edge_min_gradient", "edge_c1", "edge_c2", "edge_c3"):
        value = getattr(obj, name)
        if value is not None and value < 0:
            raise InputError(source, f"key '{prefix}.{name}' must be >= 0")
    if not 0 <= obj.canny[0] <= obj.canny[1]:
        raise InputError(source, f"key '{prefix}.canny' must be [low, high] with 0 <= low <= high")
    if min(obj.roi_samples) < 1:
        raise InputError(source, f"key '{prefix}.roi_samples' must be two integers >= 1")
    if obj.histogram_bins > 16 or obj.skin_bins > 32:
        raise InputError(source, f"keys '{prefix}.histogram_bins' / '{prefix}.skin_bins' must be "
                                 "at most 16 / 32 levels per channel")


#: ``AnnealedParticleFilter`` argument → FilterConfig key, for messages.
_FILTER_KEYS = {"n_particles": "particles", "n_layers": "layers"}


def _check_filter(obj: FilterConfig, prefix: str, source) -> None:
    """The filter's and the dynamics' own range checks, reported with the config key."""
    from .tracking import TwoStateElbow, check_options

    try:
        check_options(n_particles=obj.particles, n_layers=obj.layers, strategy=obj.strategy,
                      **obj.filter_options())
    except InputError as exc:
        key = _FILTER_KEYS.get(exc.source, exc.source)
        raise InputError(source, f"key '{prefix}.{key}' {exc.problem}") from None
    try:
        TwoStateElbow([0], [1], threshold=obj.elbow_threshold_rad,
                      singular_std=obj.elbow_singular_std_rad, factor=obj.velocity_factor)
    except ValueError as exc:
        raise InputError(source, f"filter dynamics: {exc} (keys '{prefix}.velocity_factor', "
                                 f"'{prefix}.elbow_threshold_rad', "
                                 f"'{prefix}.elbow_singular_std_rad')") from None


def config_from_dict(data: dict, source="config") -> TrackConfig:
    """Build and validate a :class:`TrackConfig` from nested dicts (e.g. parsed TOML)."""
    return _build(TrackConfig, data, "", source)


def config_to_dict(config) -> dict:
    """Nested plain dicts/lists of a config, without None values (TOML has no null)."""
    def strip(value):
        if isinstance(value, dict):
            return {k: strip(v) for k, v in value.items() if v is not None}
        if isinstance(value, (tuple, list)):
            return [strip(v) for v in value]
        return value

    return strip(dataclasses.asdict(config))


def config_to_toml(config) -> str:
    """TOML text of a config (the form stored with results)."""
    return dumps_toml(config_to_dict(config))


def config_from_toml(text: str, source="config") -> TrackConfig:
    """Build and validate a :class:`TrackConfig` from TOML text."""
    return config_from_dict(parse_toml(text, source), source)


def load_config(path) -> TrackConfig:
    """Read a TOML config file; keys not given keep their defaults."""
    path = Path(path)
    return config_from_dict(read_toml(path), source=str(path))


def with_overrides(config: TrackConfig, **overrides) -> TrackConfig:
    """A copy with ``"section.key"`` (or ``"section.table.key"``) values replaced.

    None values are ignored; the result is validated like a file (source ``options``).
    """
    data = dataclasses.asdict(config)
    for dotted, value in overrides.items():
        if value is None:
            continue
        *tables, key = dotted.split(".")
        table = data
        for name in tables:
            table = table[name]
        table[key] = value
    return config_from_dict(data, source="options")
