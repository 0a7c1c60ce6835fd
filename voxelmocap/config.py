"""Typed, validated configuration of the tracking pipeline: the one home of its defaults.

Each stage has a frozen dataclass; :class:`TrackConfig` groups them. A TOML file may set any subset
of the keys (tables ``[measurement]`` with ``[measurement.silhouette]``, ``[likelihood]``,
``[filter]``, ``[init]``, ``[export]``, ``[recovery]``, ``[cues]``); unknown keys, wrong types
and values out of range are refused with an error naming the file and the key. Command-line
options override the file (:func:`with_overrides`), and the resolved configuration is stored with
every result (:func:`config_to_toml`), so a run can be reproduced and a resumed run checked
against it.

Every field is a schema entry (:func:`voxelmocap._config_schema.setting`): its default, a one-line
doc, its unit and its range or choices, read by the one check
(:func:`voxelmocap._config_schema.check_section`) that a section runs when it is built, from a
file or in Python. Rules between fields are each section's ``_rules``. ``docs/usage.md``'s
configuration reference lists every key with its range and says why each default has its value.

>>> cfg = with_overrides(TrackConfig(), **{"filter.layers": 3})
>>> cfg.filter.layers, cfg.filter.particles
(3, 600)
"""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._config_schema import Rule, Section, also, setting, together
from .errors import InputError
from .grid import MIN_VOXELS_PER_AXIS
from .io.toml import dumps_toml, parse_toml, read_toml

__all__ = [
    "CUE_NAMES",
    "EXPORT_FORMATS",
    "SECTIONS",
    "CuesConfig",
    "ExportConfig",
    "FilterConfig",
    "InitConfig",
    "LikelihoodConfig",
    "MeasurementConfig",
    "RecoveryConfig",
    "SilhouetteConfig",
    "TrackConfig",
    "check_cue_weights",
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
_VOXEL_SAYS = "between {low:g} and {high:g} mm, got {value:g}"

#: Formats ``track`` and ``export`` write (:mod:`voxelmocap.io.exports`).
EXPORT_FORMATS = ("trc", "c3d", "csv")

#: The cues ``[cues] weights`` and ``track --cues`` may name: the keys of
#: :data:`voxelmocap.score.cues.CUES` (a test holds the two equal; the config sits below the cues).
CUE_NAMES = ("voxel", "edges", "dt", "roi", "blob3d", "skin", "uniform", "silhouette")


@dataclass(frozen=True)
class SilhouetteConfig(Section):
    """Background subtraction (:mod:`voxelmocap.measure.silhouette`): model, thresholds, shadows, clean-up.

    The TOML table ``[measurement.silhouette]``; per-camera thresholds are tables too
    (``camera_risk.BW1 = 1e6``). Built directly (``SilhouetteConfig(method="mog2")``) it is
    checked like a file, so a bad value raises :class:`InputError`.
    """

    _section: typing.ClassVar[str] = "measurement.silhouette"

    method: str = setting("gaussian", "background model: the HumanEva toolkit's per-pixel Gaussians, "
                          "OpenCV's MOG2 or a static plate", choices=("gaussian", "mog2", "plate"))
    risk: float = setting(1.0, "Gaussian model: foreground iff background likelihood < "
                          "1 / (256^C · risk); larger = fewer foreground pixels", gt=0)
    camera_risk: dict[str, float] = setting(factory=dict, doc="per-camera `risk` (camera = value)",
                                            gt=0, each=True)
    min_variance: float = setting(4.0, "floor of the per-pixel variances (0–255 intensity scale)",
                                  unit="intensity²", gt=0)
    var_threshold: float = setting(16.0, "MOG2 `varThreshold` (squared Mahalanobis distance)", gt=0)
    camera_var_threshold: dict[str, float] = setting(
        factory=dict, doc="per-camera `var_threshold` (camera = value)", gt=0, each=True)
    mog2_history: int = setting(500, "MOG2 history length", unit="frames", ge=1)
    mog2_learning_rate: float = setting(
        -1.0, "MOG2 learning rate while segmenting (-1 = OpenCV's automatic 1/history, 0 = frozen)",
        ge=-1, le=1, says="-1 (automatic) or between 0 and {high:g}")
    shadows: bool = setting(True, "remove cast shadows (Gaussian: Horprasert distortions; MOG2: "
                            "OpenCV's shadow detector)")
    shadow_brightness: tuple[float, float] = setting(
        (0.4, 0.95), "[low, high] of the brightness ratio α (image / background) a shadow may have",
        ge=0, le=1.5, each=True, says="[low, high] with {low:g} <= low < high <= {high:g}, got {value}")
    shadow_chromaticity: float = setting(0.08, "largest chromaticity distortion |I − αE| / |αE| of "
                                         "a shadow", ge=0)
    shadow_gray: bool = setting(False, "also suppress shadows on grayscale cameras (α in range and "
                                "the background texture kept)")
    shadow_ncc: float = setting(0.5, "smallest image/background cross-correlation of a gray shadow",
                                ge=-1, le=1)
    shadow_window: int = setting(2, "half-size of that correlation window", unit="pixels", ge=0)
    open_radius: int = setting(1, "elliptic opening radius (0 = off), removes speckle",
                               unit="pixels", ge=0)
    close_radius: int = setting(2, "elliptic closing radius (0 = off), fills gaps", unit="pixels",
                                ge=0)
    min_area: int = setting(50, "remove 4-connected blobs smaller than this (toolkit: 10)",
                            unit="pixels", ge=0)
    largest_only: bool = setting(False, "keep only the largest 8-connected component (the "
                                 "toolkit's `one_comp`)")
    fill_holes: bool = setting(False, "fill background regions enclosed by the silhouette")
    false_alarm: float = setting(1e-4, "`plate`: probability that noise alone makes a pixel "
                                 "foreground", gt=0, lt=0.5)
    plate_frames: int = setting(60, "learnt plate: frames sampled evenly over the sequence to "
                                "learn it from", unit="frames", ge=1)
    plate_iterations: int = setting(3, "learnt plate: carve / project / re-estimate passes at most "
                                    "(they stop when stable)", ge=1)
    plate_ghost_ratio: float = setting(
        1.5, "learnt plate: a blob whose outline is this many times stronger an edge in the plate "
        "than in the frame is a ghost (0 = no ghost test)", ge=0)
    plate_vanish_share: float = setting(
        0.3, "learnt plate: a frame whose person is below this share of the typical volume has the "
        "person inside the plate", ge=0, le=1)
    plate_min_seen: int = setting(1, "learnt plate: fewest uncovered frames a pixel needs for its "
                                  "background to be known", unit="frames", ge=1)
    plate_max_unknown: float = setting(
        0.4, "learnt plate: largest share of an image whose background is never seen before the "
        "plate is refused", ge=0, le=1)
    plate_unstable: float = setting(
        4.0, "learnt plate: a pixel whose background samples spread beyond this many times the "
        "camera's noise is no background", unit="× noise σ", gt=1)
    plate_unknown: str = setting("grabcut", "learnt plate: what a pixel whose background was never "
                                 "seen is, per frame", choices=("grabcut", "foreground"))
    plate_support: bool = setting(False, "learnt plate: while learning, cover in every view what "
                                  "lies under the carved person down to the floor")
    plate_body_margin: float = setting(
        20.0, "learnt plate from a tracked body: margin of the body's image, the person's cover in "
        "each frame", unit="mm at the body's depth", ge=0)
    plate_body_support: float = setting(
        0.0, "learnt plate from a tracked body: radius of the vertical column under the pelvis, "
        "down to the floor, also covered in each frame around the body of the pass that learnt "
        "its plate by carving (a standing leg that pass lost is in it; 0 = none)", unit="mm", ge=0)
    plate_body_min_seen: float = setting(
        0.0, "learnt plate from a tracked body: a pixel the body left free in fewer than this "
        "share of the sampled frames is unknown", ge=0, lt=1)
    plate_passes: int = setting(3, "learnt plate: tracking passes, each after the first learning "
                                "the plate from the body the previous pass tracked", ge=1)
    grabcut_scale: float = setting(0.33, "GrabCut runs at this share of the image's resolution "
                                   "(its cost grows with the pixels)", gt=0, le=1)
    grabcut_iterations: int = setting(2, "GrabCut's iterations per silhouette", ge=1)

    _rules: typing.ClassVar[tuple[Rule, ...]] = (
        also("mog2_learning_rate", lambda rate: rate == -1 or rate >= 0),
        also("shadow_brightness", lambda pair: pair[0] < pair[1]),
    )

    def risk_for(self, camera: str | None) -> float:
        """The Gaussian model's risk for ``camera`` (its override, else ``risk``)."""
        return float(self.camera_risk.get(camera, self.risk)) if camera else float(self.risk)

    def var_threshold_for(self, camera: str | None) -> float:
        """The MOG2 ``varThreshold`` for ``camera`` (its override, else ``var_threshold``)."""
        if camera:
            return float(self.camera_var_threshold.get(camera, self.var_threshold))
        return float(self.var_threshold)


@dataclass(frozen=True)
class MeasurementConfig(Section):
    """Background subtraction, carving and surface smoothing."""

    _section: typing.ClassVar[str] = "measurement"

    voxel_size: float = setting(20.0, "voxel edge", unit="mm", ge=VOXEL_SIZE_RANGE[0],
                                le=VOXEL_SIZE_RANGE[1], says=_VOXEL_SAYS)
    grid_origin: tuple[float, float, float] | None = setting(
        None, "grid corner, with `grid_shape`; unset: placed by `grid_placement`", unit="mm",
        unbounded=True)
    grid_shape: tuple[int, int, int] | None = setting(
        None, "grid size, with `grid_origin`", unit="voxels", ge=MIN_VOXELS_PER_AXIS, each=True,
        says="at least {low:g} voxels along every axis, got {value}")
    min_views: int | None = setting(
        None, "a voxel is occupied when inside the silhouette of at least this many of the cameras "
        "that see it; unset = all of them (the strict visual hull)", unit="cameras", ge=1)
    surface_sigma: float = setting(1.0, "Gaussian smoothing of the surface voxels", unit="voxels",
                                   gt=0, le=MAX_SURFACE_SIGMA,
                                   says="> {low:g} and <= {high:g} voxels, got {value:g}")
    background_frames: int = setting(200, "background-video frames per camera used to learn the "
                                     "model", unit="frames", ge=1)
    silhouette: SilhouetteConfig = setting(factory=SilhouetteConfig, doc="background model, "
                                           "thresholds (per camera too) and clean-up")
    grid_placement: str = setting("auto", "where the grid goes when `grid_origin` is not given",
                                  choices=("auto", "rig", "person"))
    grid_margin: float = setting(400.0, "`person` placement: margin around the person's box over "
                                 "the sampled frames", unit="mm", ge=0)
    carve_holes: int | None = setting(
        None, "silhouettes that may miss an occupied voxel (segmentation holes) when `min_views` "
        "is unset", unit="cameras", ge=0)
    carve_hole_reach: float = setting(
        0.005, "with `carve_holes`: a silhouette may miss a voxel only within this share of the "
        "image diagonal of it (0 = any distance)", ge=0, le=1)
    person_only: bool | None = setting(None, "keep only the largest 3D component of every frame; "
                                       "unset: on when the background is learnt from the sequence")
    coarse_voxel_size: float = setting(50.0, "voxel edge of the coarse carves that learn the plate "
                                       "and place the grid", unit="mm", ge=VOXEL_SIZE_RANGE[0],
                                       le=VOXEL_SIZE_RANGE[1], says=_VOXEL_SAYS)

    max_image_side: int = setting(
        0, "images longer than this on a side are shrunk to it as they are decoded (area "
        "average), and their cameras with them, so a recording is measured at one resolution "
        "however it was filmed (0 = as filmed)", unit="pixels", ge=0,
        says="0 (as filmed) or at least 64 pixels, got {value}")

    _rules: typing.ClassVar[tuple[Rule, ...]] = (
        together("grid_origin", "grid_shape"),
        # a person a few dozen pixels tall carves nothing a body could be fitted to
        also("max_image_side", lambda side: side == 0 or side >= 64),
    )


@dataclass(frozen=True)
class LikelihoodConfig(Section):
    """Voxel likelihood (paper 002 eqs 7–9)."""

    _section: typing.ClassVar[str] = "likelihood"

    variances: tuple[float, float, float, float] = setting(
        (0.01, 0.1, 0.1, 0.1), "σ² of the Out, DO, Empty and Surf scores (paper 002 eq. 9)",
        gt=0, each=True, says="positive")
    coverage: float = setting(1000.0, "weight w of the coverage term −½ w u² / 0.1, u the share "
                              "of occupied voxels no part contains (0: paper 002 alone)", ge=0,
                              says=">= {low:g}, got {value}")
    root_pitch_prior_deg: float | None = setting(
        None, "standard deviation of a zero-mean Gaussian prior on the root pitch; unset: none",
        unit="degrees", gt=0)


#: ``AnnealedParticleFilter`` argument → FilterConfig key, for messages.
_FILTER_KEYS = {"n_particles": "particles", "n_layers": "layers"}
_CHECK_OPTIONS = "voxelmocap.tracking.check_options"
_ELBOW = "voxelmocap.tracking.TwoStateElbow"


def _filter_options(obj: FilterConfig, key, source) -> None:
    """The filter's and the dynamics' own range checks, reported with the config key."""
    from .tracking import TwoStateElbow, check_options

    try:
        check_options(n_particles=obj.particles, n_layers=obj.layers, strategy=obj.strategy,
                      **obj.filter_options())
    except InputError as exc:
        raise InputError(source, f"key {key(_FILTER_KEYS.get(exc.source, exc.source))!r} "
                                 f"{exc.problem}") from None
    try:
        TwoStateElbow([0], [1], threshold=obj.elbow_threshold_rad,
                      singular_std=obj.elbow_singular_std_rad, factor=obj.velocity_factor)
    except ValueError as exc:
        names = ("velocity_factor", "elbow_threshold_rad", "elbow_singular_std_rad")
        raise InputError(source, f"filter dynamics: {exc} (keys "
                                 f"{', '.join(repr(key(n)) for n in names)})") from None


@dataclass(frozen=True)
class FilterConfig(Section):
    """Annealed particle filter and its dynamics (``voxelmocap.tracking``).

    Every option of ``AnnealedParticleFilter`` and of the dynamics models can be set here; their
    legal ranges are stated once, by ``voxelmocap.tracking.apf.check_options`` and the dynamics'
    constructors, and checked when a config is built.
    """

    _section: typing.ClassVar[str] = "filter"

    layers: int = setting(6, "annealing layers per frame (an integer >= 1)", checked_by=_CHECK_OPTIONS)
    particles: int = setting(600, "particles per layer (an integer >= 2)", checked_by=_CHECK_OPTIONS)
    strategy: str = setting("apf", "filtering strategy: annealed (`apf`), one layer of layers × "
                            "particles (`sir`) or with the detector proposal (`iapf`)",
                            choices=("apf", "sir", "iapf"))
    survival: float = setting(0.5, "target share of surviving particles per layer (β by "
                              "bisection), in (0, 1]", checked_by=_CHECK_OPTIONS)
    noise_decay: float = setting(0.5, "propagation covariance multiplier per layer, in (0, 1]",
                                 checked_by=_CHECK_OPTIONS)
    betas: tuple[float, ...] | None = setting(
        None, "fixed likelihood exponents, one per layer (e.g. Fontmarty's [0.1, 0.4, 1]) instead "
        "of the adaptive β", checked_by=_CHECK_OPTIONS)
    alphas: tuple[float, ...] | None = setting(
        None, "Fontmarty's dynamics exponents, one per layer (noise std / √α); overrides "
        "`noise_decay`", checked_by=_CHECK_OPTIONS)
    beta_max: float | None = setting(None, "upper limit of the adaptive β (> 0; unset: unbounded)",
                                     checked_by=_CHECK_OPTIONS)
    resampling: str = setting("systematic", "resampling scheme",
                              choices=("systematic", "stratified", "multinomial", "residual"))
    iapf_fractions: tuple[float, float] = setting(
        (0.8, 0.2), "IAPF: shares of layer 1 drawn from the dynamics and from the proposal (rest: "
        "the prior)", checked_by=_CHECK_OPTIONS)
    dynamics: str = setting("random_walk", "motion model: random walk, constant velocity (Azad eq. "
                            "14) or the two-state elbow (eq. 16)",
                            choices=("random_walk", "velocity", "elbow"))
    velocity_factor: float = setting(
        0.7, "`velocity` and `elbow`: the diagonal of A in s_k = s_{k-1} + A (s̄_{k-1} − s̄_{k-2}) "
        "(paper 000 eq. 15), in [0, 1]", checked_by=_ELBOW)
    elbow_threshold_rad: float = setting(
        0.2, "`elbow`: an elbow closer to straight than this counts as singular (paper 000 §4.4, "
        "φ; >= 0)", unit="rad", checked_by=_ELBOW)
    elbow_singular_std_rad: float = setting(
        0.4, "`elbow`: the shoulder-twist noise while the elbow is singular (β̂; >= 0)", unit="rad",
        checked_by=_ELBOW)
    translation_std_mm: float = setting(25.0, "per-frame propagation noise of the root position "
                                        "at 60 Hz (scaled by 60 / the frame rate)", unit="mm",
                                        gt=0)
    rotation_std_rad: float = setting(0.06, "per-frame propagation noise of the root rotation, "
                                      "waist and neck at 60 Hz (scaled by 60 / the frame rate)",
                                      unit="rad", gt=0)
    joint_std_rad: float = setting(0.1, "per-frame propagation noise of the limb joints at 60 Hz "
                                   "(scaled by 60 / the frame rate)", unit="rad", gt=0)
    search: str = setting("hierarchical", "`joint`: every layer searches all 27 dimensions; "
                          "`hierarchical`: trunk first, then each limb", choices=("hierarchical", "joint"))
    trunk_layers: int | None = setting(None, "hierarchical search: layers of the root-and-trunk "
                                       "partition; unset: from `layers`", gt=0)
    trunk_particles: int | None = setting(None, "hierarchical search: particles of the "
                                          "root-and-trunk partition; unset: from `particles`", ge=2)
    limb_layers: int | None = setting(None, "hierarchical search: layers per limb partition; "
                                      "unset: from `layers`", gt=0)
    limb_particles: int | None = setting(None, "hierarchical search: particles per limb partition; "
                                         "unset: from `particles`", ge=2)
    refine_evaluations: int = setting(40, "likelihood evaluations of the compass search refining "
                                      "each partition's estimate (0 = none)", ge=0)
    limb_explore: float = setting(0.0, "hierarchical search: share of each limb partition's first "
                                  "layer drawn uniformly over the limb's legal ranges", ge=0, lt=1)
    limb_proposal: float = setting(0.0, "hierarchical search: share of each limb partition's first "
                                   "layer from the frame's detector proposal (0 = none)", ge=0, lt=1)
    limb_sweep_every: int = setting(5, "search each limb of the estimate over its legal ranges "
                                    "every this many frames (0 = never)", unit="frames", ge=0)
    limb_sweep_gain: float = setting(2.0, "the periodic sweep moves a limb only when it gains more "
                                     "than this", unit="log-likelihood", ge=0)
    limb_sweep_max_hull: float = setting(2.0, "the periodic sweep runs only on frames whose occupied "
                                         "volume is at most this many times the body model's", gt=0)
    limb_sweep_samples: int = setting(256, "Sobol points per limb of the periodic sweep (rounded up "
                                      "to a power of two)", ge=2)
    limb_sweep_silhouette: float = setting(
        10.0, "weight of the silhouette cue in the periodic sweep's score when the tracking cues "
        "leave that cue out (0 = the tracking cues alone)", ge=0)
    limb_swaps: bool = setting(False, "the limb searches first try each pair of limbs exchanged "
                               "(legs crossed onto each other's voxels)")
    facing_check_every: int = setting(0, "every this many frames, check the estimate against its "
                                      "turned-round twin and turn the track round when the twin "
                                      "wins (0 = never)", unit="frames", ge=0)
    facing_margin: float = setting(2.0, "what the twin must win by (likelihood + `facing_weight` × "
                                   "evidence)", unit="log-likelihood", ge=0)
    facing_weight: float = setting(0.0, "weight of the facing evidence in the facing check and the "
                                   "multi-start's choice", unit="log-likelihood per unit", ge=0)

    _rules: typing.ClassVar[tuple[Rule, ...]] = (
        Rule(("layers", "particles", "strategy", "survival", "noise_decay", "betas", "alphas",
              "beta_max", "resampling", "iapf_fractions", "velocity_factor",
              "elbow_threshold_rad", "elbow_singular_std_rad"), _filter_options),
    )

    def filter_options(self) -> dict:
        """The ``AnnealedParticleFilter`` keyword options beyond sizes, strategy and noise."""
        return {"survival": self.survival, "noise_decay": self.noise_decay,
                "betas": self.betas, "alphas": self.alphas,
                "beta_max": np.inf if self.beta_max is None else self.beta_max,
                "resampling": self.resampling, "iapf_fractions": self.iapf_fractions}


@dataclass(frozen=True)
class InitConfig(Section):
    """How tracking starts."""

    _section: typing.ClassVar[str] = "init"

    method: str = setting("auto", "how the first pose is found: fitted to the ground truth, to the "
                          "voxels' extremities, a standing pose, or `auto`",
                          choices=("auto", "ground_truth", "extremities", "voxels"))
    spread: float = setting(0.25, "initial particle spread", unit="× propagation noise",
                            unbounded=True)
    hypotheses: int = setting(4, "`extremities`: distinct starting poses the first particles are "
                              "spread over (equal shares)", gt=0)
    multistart_frames: int = setting(10, "`extremities`: track each starting pose on its own for "
                                     "this many frames and keep the likeliest (0: one mixture)",
                                     unit="frames", unbounded=True)
    body: str = setting("fitted", "body size without a body file or ground truth: scaled to the "
                        "voxels' height, the average adult, or fitted to the voxels",
                        choices=("voxels", "average", "fitted"))
    settle_steps: int = setting(5, "extra filter steps on the first frame before it is recorded",
                                ge=0)
    limb_sweep: bool = setting(True, "search each starting pose's four limbs over their whole "
                               "legal ranges on the first frame")
    previous_pass_start: int = setting(
        3, "a plate learnt in passes: from this pass on, start from the previous pass's body and "
        "first pose (0: never)", ge=0, says="0 (never) or >= 2")

    previous_pass_hypothesis: bool = setting(
        True, "a pass after the first that searches its start: the previous pass's pose at that "
        "frame (all four limbs searched again) is tracked as one more starting pose")
    start_turned: bool = setting(False, "test hook: start from the best start alone, turned round, "
                                 "to check that the facing check turns it back")

    _rules: typing.ClassVar[tuple[Rule, ...]] = (also("previous_pass_start", lambda k: k != 1),)


@dataclass(frozen=True)
class ExportConfig(Section):
    """The landmark files ``track`` writes beside each result (``docs/outputs.md``).

    Not part of tracking: a resumed run may change them, and ``voxelmocap export`` rewrites
    them from a finished result.
    """

    _section: typing.ClassVar[str] = "export"

    formats: tuple[str, ...] = setting(("trc", "csv"), "formats written after tracking (`[]` "
                                       "writes none)", choices=EXPORT_FORMATS, each=True,
                                       noun="format")
    cutoff_hz: float | None = setting(None, "zero-lag Butterworth low-pass of the exported "
                                      "trajectories; absent = no filtering", unit="Hz", gt=0,
                                      says="> {low:g} (leave it out for no filtering)")
    order: int = setting(4, "order of the zero-lag filter (even: a Butterworth of half of it, run "
                         "twice)", ge=2, says="an even integer >= {low:g}, got {value}")
    axes: str = setting("world", "`world`: the calibration's frame (Z up); `y_up`: OpenSim's Y up, "
                        "as Pose2Sim writes (X ← Y, Y ← Z, Z ← X)", choices=("world", "y_up"))

    _rules: typing.ClassVar[tuple[Rule, ...]] = (also("order", lambda n: n % 2 == 0),)


@dataclass(frozen=True)
class RecoveryConfig(Section):
    """Frames without a person, lost tracks and the IAPF's detector proposal
    (``voxelmocap.pose.recovery``)."""

    _section: typing.ClassVar[str] = "recovery"

    enabled: bool = setting(True, "flag frames without a person (not tracked) and re-initialise "
                            "when the person comes back or the track is lost")
    min_volume_share: float = setting(0.3, "a frame has a person when its largest blob of occupied "
                                      "voxels holds at least this share of the body model's volume",
                                      gt=0)
    lost_window: int = setting(30, "lost track: good frames whose median log-likelihood a frame is "
                               "compared with", unit="frames", gt=0)
    lost_drop: float = setting(20.0, "lost track: a frame more than this below that median is bad",
                               unit="log-likelihood", gt=0)
    lost_empty: float = setting(0.5, "lost track: a frame whose parts' mean Empty score is above "
                                "this is bad", gt=0)
    lost_patience: int = setting(3, "lost track: this many bad frames in a row make the track lost",
                                 unit="frames", gt=0)
    reinitialise: bool = setting(True, "re-initialise a lost track (off: only flag it in the log)")
    proposal_spread: float = setting(1.0, "spread of each detector-proposal component",
                                     unit="× propagation noise", gt=0)
    proposal_gate_mm: float = setting(400.0, "a tip farther than this from every body end is "
                                      "ignored", unit="mm", gt=0)
    proposal_mirror: bool = setting(False, "add the left/right-swapped fit as a second proposal "
                                    "component")
    proposal_correction: bool = setting(False, "weight layer 1 by p/q (Table I line 8)")


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


@dataclass(frozen=True)
class CuesConfig(Section):
    """Likelihood cues and their fusion (``voxelmocap.score.cues``, ``docs/cues.md``).

    The global log-likelihood is ``Σ weight · log p`` over the cues named in ``weights``.
    """

    _section: typing.ClassVar[str] = "cues"

    weights: dict[str, float] = setting(factory=lambda: {"voxel": 1.0},
                                        doc="cue name = weight; the default is the voxel "
                                        "likelihood alone", checked_by="check_cue_weights")
    edge_spacing: float = setting(5.0, "Azad's Δ: spacing of the observed contour points (also the "
                                  "`dt` cue's)", unit="pixels", gt=0)
    edge_search: int = setting(15, "Azad's δ: search half-length", unit="pixels", gt=0)
    edge_min_gradient: float = setting(12.0, "Azad's G_MIN: smallest grey step",
                                       unit="grey levels", ge=0)
    edge_variance: float = setting(0.0025, "σ² of Azad's eq. 13", gt=0)
    edge_c1: float = setting(0.0, "cost of a point whose search leaves the picture (C1)", ge=0)
    edge_c2: float | None = setting(None, "cost of an occluded point (C2); unset: δ²", ge=0)
    edge_c3: float | None = setting(None, "cost of a point with no edge (C3); unset: (δ + 5)²",
                                    ge=0)
    occlusion: bool = setting(True, "the fast occlusion test (paper 000 §4.3) for `edges`, `dt`, "
                              "`roi`, `uniform`")
    canny: tuple[float, float] = setting((50.0, 150.0), "Canny hysteresis thresholds of the `dt` "
                                         "cue's edge image", unit="grey levels", ge=0, each=True,
                                         says="[low, high] with {low:g} <= low <= high")
    sigma_dt: float = setting(10.0, "Fontmarty's σ_e (Table II)", unit="pixels", gt=0)
    sigma_roi: float = setting(0.3, "Fontmarty's σ_ROI (Table II)", gt=0)
    sigma_3d_mm: float = setting(150.0, "Fontmarty's σ_3D (Table II, 0.15 m)", unit="mm", gt=0)
    sigma_skin: float = setting(0.02, "Fontmarty's σ_s (Table II)", gt=0)
    sigma_uniform: float = setting(10.0, "Fontmarty's σ_m (Table II)", unit="grey levels", gt=0)
    histogram_bins: int = setting(4, "levels per colour channel of the ROI histograms (n³ bins; n² "
                                  "grey levels for grey cameras)", ge=1, le=16)
    skin_bins: int = setting(8, "levels per channel of the skin colour model", ge=1, le=32)
    roi_samples: tuple[int, int] = setting((5, 8), "samples across and along every part's image "
                                           "quadrangle (`roi`, `uniform`)", ge=1, each=True,
                                           says="two integers >= {low:g}")
    uniform_max_std: float = setting(20.0, "`uniform` applies to the parts whose colour standard "
                                     "deviation in the reference frame is at most this",
                                     unit="grey levels", gt=0)
    silhouette_size: int = setting(320, "`silhouette`: masks are compared at this many pixels "
                                   "along the image's longer side", unit="pixels", gt=0)
    silhouette_scale: float = setting(0.02, "`silhouette`: each camera's log-likelihood is −D / "
                                      "this, D the mismatch share", gt=0)
    silhouette_unseen: str = setting("count", "`silhouette`: silhouette pixels a learnt plate never "
                                     "saw the background of count like any other or are ignored",
                                     choices=("count", "ignore"))

    _rules: typing.ClassVar[tuple[Rule, ...]] = (
        Rule(("weights",), lambda obj, key, source: check_cue_weights(obj.weights, source,
                                                                      key("weights"))),
        also("canny", lambda pair: pair[0] <= pair[1]),
    )


@dataclass(frozen=True)
class TrackConfig(Section):
    """Everything a tracking run depends on, apart from the data and the seed."""

    measurement: MeasurementConfig = setting(factory=MeasurementConfig,
                                             doc="background subtraction, carving, surface")
    likelihood: LikelihoodConfig = setting(factory=LikelihoodConfig, doc="voxel likelihood")
    filter: FilterConfig = setting(factory=FilterConfig, doc="particle filter and dynamics")
    init: InitConfig = setting(factory=InitConfig, doc="how tracking starts")
    export: ExportConfig = setting(factory=ExportConfig, doc="landmark files beside each result")
    recovery: RecoveryConfig = setting(factory=RecoveryConfig,
                                       doc="frames without a person, lost tracks")
    cues: CuesConfig = setting(factory=CuesConfig, doc="likelihood cues and their fusion")


#: The sections in the order of the TOML text, nested ones after their parent.
SECTIONS = (MeasurementConfig, SilhouetteConfig, LikelihoodConfig, FilterConfig, InitConfig,
            ExportConfig, RecoveryConfig, CuesConfig)


# ---------------------------------------------------------------------- TOML and dicts
def _build(cls, data, prefix: str, source):
    if not isinstance(data, dict):
        raise InputError(source, f"[{prefix}] must be a table")
    hints = typing.get_type_hints(cls)
    fields = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - fields)
    if unknown:
        where = f"{prefix}.{unknown[0]}" if prefix else unknown[0]
        raise InputError(source, f"unknown key {where!r} (known: {', '.join(sorted(fields))})")
    kwargs = {}
    for name, value in data.items():
        if dataclasses.is_dataclass(hints[name]):
            value = _build(hints[name], value, f"{prefix}.{name}" if prefix else name, source)
        kwargs[name] = value
    try:
        return cls(**kwargs)  # checked by its __post_init__ (the one check)
    except InputError as exc:  # raised with the class as source: name the file instead
        raise InputError(source, exc.problem) from None


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
