"""The body tracker: the body model, its voxel likelihood and the annealed particle filter, per frame.

:class:`BodyTracker` owns everything between a measured frame and a pose estimate:

* the body model (:class:`~voxelmocap.body.BodyModel`) and the likelihood's variances;
* the noise profile (:func:`noise_profile`: which state dimension gets which propagation noise);
* the dynamics, built by name from :data:`voxelmocap.tracking.DYNAMICS` (:func:`build_dynamics`);
* the filter (:class:`~voxelmocap.tracking.AnnealedParticleFilter`, :func:`build_filter`);
* the initialisation (fit to a ground-truth pose, or a search around the voxel blob).

It knows nothing about files: the runner (:mod:`voxelmocap.run.pipeline`) measures frames and writes
what :meth:`BodyTracker.step` returns, a :class:`FrameRecord`. Studies and benchmarks call the same
class, so they measure the product, not a copy of its loop.

Observers, in the spirit of the ``particles`` library's collectors, are callables
``observer(record, tracker)`` called after every step (:class:`Collector` stacks chosen record
fields). :meth:`BodyTracker.get_state` / :meth:`BodyTracker.set_state` checkpoint the filter so
that a resumed run continues bit-identically.

>>> import numpy as np
>>> from voxelmocap.body import BodyModel
>>> from voxelmocap.config import TrackConfig, with_overrides
>>> from voxelmocap.grid import VoxelGrid
>>> from voxelmocap.score.likelihood import Measurement, rasterise
>>> model = BodyModel()
>>> grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
>>> seen = Measurement(rasterise(model, model.default_state()[None], grid) > 0, grid)
>>> config = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 20})
>>> tracker = BodyTracker(model, config, seed=0)
>>> tracker.initialise(seen, model.landmarks(model.default_state()[None])[0], frame=1)
'the ground truth of frame 1'
>>> record = tracker.step(seen, frame=1)
>>> record.landmarks.shape, record.endpoints.shape, record.ess.shape
((15, 3), (20, 3), (2,))
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np

from ..config import FilterConfig, TrackConfig
from ..errors import InputError

__all__ = [
    "BodyTracker",
    "Collector",
    "FrameRecord",
    "absent_record",
    "build_dynamics",
    "build_filter",
    "ground_truth_landmarks",
    "initial_state_from_voxels",
    "noise_profile",
]

#: How :meth:`BodyTracker.initial_state` names a start from the ground truth.
GROUND_TRUTH_START = "the ground truth"

#: Trunk angles that get the root rotation's noise, not the limbs' (see :func:`noise_profile`).
TRUNK_ANGLES = ("waist_flex", "waist_side", "waist_twist", "neck_flex", "neck_side")


@dataclass(frozen=True)
class FrameRecord:
    """What one tracked frame produced (the estimate is clipped into the model's legal ranges).

    Attributes
    ----------
    frame : int
        Synchronised 1-based frame number.
    state : (27,) ndarray
        The estimate: weighted mean of the last annealing layer (mm, rad).
    map_state : (27,) ndarray
        The particle of largest last-layer weight (not clipped; it is a particle).
    landmarks : (15, 3) ndarray
        Landmarks of ``state`` (mm) in ``voxelmocap.joints.LANDMARK_NAMES`` order.
    endpoints : (20, 3) ndarray
        ``body_pose`` endpoints of ``state`` (mm) in ``ENDPOINT_NAMES`` order.
    part_scores : (n_parts, 4) ndarray
        Out, DO, Empty, Surf of every part of ``state``.
    ess, betas : (L,) ndarray
        Effective sample size and likelihood exponent of each annealing layer.
    seconds : float
        Wall time of :meth:`BodyTracker.step` (the runner stores the whole frame's instead,
        measurement included).
    log_likelihood : float
        Log-likelihood of ``state`` under the selected cues (voxel only: from ``part_scores``).
    likelihood_seconds : float
        The part of ``seconds`` spent in the filter's likelihood evaluations.
    landmark_spread : (15,) ndarray
        Weighted RMS distance (mm) of each landmark over the last layer's particles
        (:func:`voxelmocap.pose.confidence.landmark_spread`); NaN when unknown.
    confidence : (15,) ndarray
        Each landmark's confidence in [0, 1] (:func:`voxelmocap.pose.confidence.landmark_confidence`
        of the spread and ``part_scores``); NaN when unknown.
    observed : bool
        False for a frame without a person (``voxelmocap.pose.recovery``): the filter did not step
        and the estimate repeats the last one; evaluations skip such frames.
    note : str
        What happened besides tracking, e.g. a re-initialisation (empty when nothing did).
    """

    frame: int
    state: np.ndarray
    map_state: np.ndarray
    landmarks: np.ndarray
    endpoints: np.ndarray
    part_scores: np.ndarray
    ess: np.ndarray
    betas: np.ndarray
    seconds: float
    log_likelihood: float
    likelihood_seconds: float = 0.0
    landmark_spread: np.ndarray = field(default_factory=lambda: np.full(15, np.nan))
    confidence: np.ndarray = field(default_factory=lambda: np.full(15, np.nan))
    observed: bool = True
    note: str = ""


Observer = Callable[[FrameRecord, "BodyTracker"], None]


class Collector:
    """An observer that keeps chosen fields of every record, e.g. ``Collector("state")``.

    >>> c = Collector("frame", "log_likelihood")
    >>> c.stacked()["frame"].shape
    (0,)
    """

    def __init__(self, *fields: str):
        unknown = [f for f in fields if f not in FrameRecord.__dataclass_fields__]
        if unknown:
            raise ValueError(f"Collector: FrameRecord has no field {unknown[0]!r}")
        self.fields = fields or tuple(FrameRecord.__dataclass_fields__)
        self.values: dict[str, list] = {f: [] for f in self.fields}

    def __call__(self, record: FrameRecord, tracker: BodyTracker) -> None:
        for f in self.fields:
            self.values[f].append(getattr(record, f))

    def stacked(self) -> dict[str, np.ndarray]:
        """Each field's values stacked along a new first axis (frames)."""
        return {f: np.array(v) for f, v in self.values.items()}


# ---------------------------------------------------------------------------- assembly
def noise_profile(model, config: TrackConfig) -> np.ndarray:
    """(27,) per-frame propagation noise (mm, rad): translation, root rotation and joint groups.

    The root, waist and neck angles get ``rotation_std_rad``; shoulders, elbows, hips and knees
    ``joint_std_rad``. The trunk moves as slowly as the root, and the pelvis orientation is nearly
    unobservable (no part spans the pelvis), so a compensating root pitch + waist flexion + hip
    flexion change costs almost nothing in the likelihood. With the limbs' larger noise on the
    waist the filter random-walked along that direction (root pitch −40°, waist +44° after 6
    frames of a walk) and lost the legs. Measured with ``scripts/study_tracking.py`` (synthetic,
    7 cameras, 6 × 300 particles, ``joint_std_rad`` 0.1): trunk on the limbs' noise → on the
    root's: walk μ 58 → 59 mm (5 seeds, no change), jog 67 → 60 mm, box 68 → 56 mm (3 seeds);
    ``docs/benchmarks.md``, tracking accuracy study.
    """
    fc = config.filter
    std = np.full(model.n_dims, fc.joint_std_rad)
    std[:3] = fc.translation_std_mm
    std[3:6] = fc.rotation_std_rad
    names = list(model.state_names)
    std[[names.index(n) for n in TRUNK_ANGLES]] = fc.rotation_std_rad
    return std


def build_dynamics(model, fc: FilterConfig):
    """The motion model named by ``fc.dynamics`` (:data:`voxelmocap.tracking.DYNAMICS`).

    The velocity drift applies to every state dimension (heading included: the estimates it is
    taken from never jump across ±π within a frame or two of a walk).
    """
    from ..tracking import DYNAMICS, TwoStateElbow, VelocityModel

    cls = DYNAMICS[fc.dynamics]
    kwargs = {}
    if issubclass(cls, VelocityModel):
        kwargs["factor"] = fc.velocity_factor
    if issubclass(cls, TwoStateElbow):
        names = list(model.state_names)
        kwargs.update(twist_indices=[names.index("l_shoulder_rot"), names.index("r_shoulder_rot")],
                      elbow_indices=[names.index("l_elbow"), names.index("r_elbow")],
                      threshold=fc.elbow_threshold_rad, singular_std=fc.elbow_singular_std_rad)
    return cls(**kwargs)


def build_filter(model, config: TrackConfig, rng, *, noise_std=None):
    """The annealed particle filter of a config, over the body model's legal ranges.

    Parameters
    ----------
    model : BodyModel
    config : TrackConfig
        ``config.filter`` is used.
    rng : numpy.random.Generator or int
        The filter's generator (or its seed).
    noise_std : (27,) array_like, optional
        Propagation noise; default :func:`noise_profile`.
    """
    from ..tracking import AnnealedParticleFilter

    fc = config.filter
    noise = noise_profile(model, config) if noise_std is None else noise_std
    if searches_hierarchically(config):
        from ..tracking.partitioned import PartitionedParticleFilter
        from .hierarchy import body_partitions

        opts = fc.filter_options()
        return PartitionedParticleFilter(
            body_partitions(fc), model.low, model.high, noise, rng=rng,
            survival=opts["survival"], noise_decay=opts["noise_decay"],
            dynamics=build_dynamics(model, fc), resampling=opts["resampling"],
            beta_max=opts["beta_max"], refine_evaluations=fc.refine_evaluations,
            explore=fc.limb_explore)
    return AnnealedParticleFilter(
        fc.particles, fc.layers, model.low, model.high, noise, strategy=fc.strategy, rng=rng,
        dynamics=build_dynamics(model, fc), **fc.filter_options())


def initial_state_from_voxels(measurement, model, variances, *, n_yaw: int = 36,
                              coverage: float = 0.0) -> np.ndarray:
    """A standing pose at the voxel blob's centroid, facing the best of ``n_yaw`` headings.

    Parameters
    ----------
    measurement : voxelmocap.score.likelihood.Measurement
        The first frame.
    model : BodyModel
    variances : (4,) sequence of float
        The likelihood's σ².
    n_yaw : int
        Headings tried, evenly spread over the full turn.
    coverage : float
        Weight of the likelihood's coverage term.

    Returns
    -------
    (27,) ndarray

    Raises
    ------
    InputError
        When the frame has no occupied voxel.
    """
    from ..score.likelihood import log_likelihood

    occ = measurement.occupancy
    idx = np.argwhere(occ)
    if len(idx) == 0:
        raise InputError("first frame", "no occupied voxel: cannot initialise from the voxels "
                                        "(is the person in view? is the background model right? "
                                        "without background videos it is learnt from the "
                                        "sequence, see the log above)")
    centre = measurement.grid.centre_of(idx).mean(axis=0)
    base = model.default_state()
    base[0], base[1] = centre[0], centre[1]
    yaw_i = list(model.state_names).index("root_yaw")
    candidates = np.repeat(base[None], n_yaw, axis=0)
    candidates[:, yaw_i] = np.linspace(-np.pi, np.pi, n_yaw, endpoint=False)
    scores = log_likelihood(measurement, model, candidates, variances=variances,
                            coverage=coverage)
    return candidates[int(np.argmax(scores))]


def searches_hierarchically(config: TrackConfig) -> bool:
    """Whether the filter searches partition by partition: ``filter.search = "hierarchical"``
    with the ``apf`` strategy and the voxel likelihood at weight 1 (a limb is scored by
    re-scoring its two cones; other cues are added evaluated on the whole state). Without the
    voxel cue, and with the other strategies, the search is over all dimensions at once."""
    fc = config.filter
    return (fc.search == "hierarchical" and fc.strategy == "apf"
            and dict(config.cues.weights).get("voxel") == 1.0)


def annealing_layers(config: TrackConfig) -> int:
    """Layers per frame of the filter a config builds (one ESS and β each in a record)."""
    fc = config.filter
    if fc.strategy == "sir":
        return 1
    if searches_hierarchically(config):
        from .hierarchy import body_partitions

        return sum(p.layers for p in body_partitions(fc))
    return fc.layers


def absent_record(model, observation, state, *, frame: int, n_layers: int, variances,
                  seconds: float = 0.0) -> FrameRecord:
    """The record of a frame without a person (``voxelmocap.pose.recovery``): nothing was tracked.

    It repeats ``state`` (the last estimate, or wherever the track will start) so that every
    export stays a valid pose, with ``observed = False``; ESS and β are NaN (no filter step).
    """
    from ..body import joints_to_endpoints
    from ..score.likelihood import log_likelihood_from_scores, part_scores

    state = np.asarray(state, dtype=float)
    joints = model.forward(state[None]).joints
    scores = part_scores(observation, model, state[None])[0]
    return FrameRecord(
        frame=int(frame), state=state.copy(), map_state=state.copy(), landmarks=joints[0],
        endpoints=joints_to_endpoints(joints)[0], part_scores=scores,
        ess=np.full(n_layers, np.nan), betas=np.full(n_layers, np.nan), seconds=seconds,
        log_likelihood=float(log_likelihood_from_scores(scores, variances=variances)),
        observed=False, note="no person in view")


def ground_truth_landmarks(gt, frame: int) -> np.ndarray | None:
    """A frame's true landmarks ``(15, 3)`` (mm) for :meth:`BodyTracker.initialise`.

    Parameters
    ----------
    gt : voxelmocap.io.body_pose_xml.BodyPoseSequence or None
        The sequence's ground truth.
    frame : int
        Synchronised frame number.

    Returns
    -------
    (15, 3) ndarray or None
        None when there is no ground truth, the frame is not in it, or an endpoint is disabled.
    """
    from ..joints import endpoints_to_landmarks

    if gt is None:
        return None
    row = int(gt.index_of([frame])[0])
    if row < 0 or not bool(gt.enabled[row].all()):
        return None
    return endpoints_to_landmarks(gt.endpoints[row])


# ---------------------------------------------------------------------------- the tracker
class BodyTracker:
    """Tracks one body through measured frames.

    Parameters
    ----------
    model : BodyModel
        The subject's body.
    config : TrackConfig, optional
        ``likelihood``, ``filter`` and ``init`` are used (default: the working point).
    seed : int or numpy.random.Generator
        The filter's random generator (or its seed).
    noise_std : (27,) array_like, optional
        Propagation noise per state dimension (mm, rad), instead of :func:`noise_profile` of the
        config (for studies of other profiles).
    observers : iterable of callable, optional
        ``observer(record, tracker)`` called after every :meth:`step`.

    Attributes
    ----------
    model, config, variances
        As given (``variances = config.likelihood.variances``).
    noise_std : (27,) ndarray
        The propagation noise in use; the initial spread is ``config.init.spread`` times it.
    filter : voxelmocap.tracking.AnnealedParticleFilter
    init_method : str or None
        How :meth:`initialise` started the track (a phrase naming the frame).
    observers : list of callable
    """

    def __init__(self, model, config: TrackConfig | None = None, *, seed=0, noise_std=None,
                 observers: Iterable[Observer] = ()):
        self.model = model
        self.config = config or TrackConfig()
        self.variances = self.config.likelihood.variances
        #: keyword arguments of the voxel likelihood, shared with the voxel cue: ``variances``
        #: and ``coverage`` (``[likelihood]``; the start is scored with coverage 0, see
        #: :meth:`initial_state`)
        self.voxel_options = {"variances": self.variances,
                              "coverage": self.config.likelihood.coverage}
        if noise_std is None:
            self.noise_std = noise_profile(model, self.config)
        else:
            self.noise_std = np.asarray(noise_std, dtype=float)
            if self.noise_std.shape != (model.n_dims,) or not np.all(
                    np.isfinite(self.noise_std)) or np.any(self.noise_std < 0):
                raise InputError("noise_std", f"expected {model.n_dims} finite values >= 0")
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self.filter = build_filter(model, self.config, rng, noise_std=self.noise_std)
        from ..score.cues import CueSet

        #: the likelihood terms and their weights (``[cues]``; default the voxel likelihood)
        self.cues = CueSet(model, self.config.cues, voxel=self.voxel_options)
        self.init_method: str | None = None
        self.observers: list[Observer] = list(observers)
        self._settle = 0  # settling steps still due on the next frame (see settle)
        #: the IAPF proposal of the next frame when set (a re-initialisation's hypotheses), and
        #: the last one used (``voxelmocap.pose.recovery.MixtureProposal``)
        self.pending_proposal = None
        self.last_proposal = None
        self._recovery = None

    def __repr__(self) -> str:
        return f"BodyTracker({self.model!r}, {self.filter!r})"

    @property
    def coverage(self) -> float:
        """Weight of the likelihood's coverage term now (``[likelihood] coverage``)."""
        return self.voxel_options["coverage"]

    @contextlib.contextmanager
    def _paper_likelihood(self):
        """Score with paper 002's likelihood alone (coverage 0) inside the block.

        The coverage term is symmetric under turning the body round and cannot tell which arm
        is which; scoring the start's hypotheses with it picked a start facing backwards on
        one of three gestures runs and mislabelled the jog's arms (docs/benchmarks.md).
        """
        saved = self.voxel_options["coverage"]
        self.voxel_options["coverage"] = 0.0
        try:
            yield
        finally:
            self.voxel_options["coverage"] = saved

    @property
    def initialised(self) -> bool:
        """Whether the filter holds particles (after :meth:`initialise` or :meth:`set_state`)."""
        return self.filter.particles is not None

    # ------------------------------------------------------------------ start
    def initial_state(self, observation, ground_truth=None, *, frame=None) -> tuple[str, np.ndarray]:
        """Where ``config.init.method`` starts the track: ``(phrase, state)``.

        ``state`` is (27,), or (K, 27) starting poses for a mixture (``extremities``, best first).

        Parameters
        ----------
        observation : voxelmocap.score.likelihood.Measurement
            The first frame.
        ground_truth : (15, 3) array_like, optional
            The frame's true landmarks (mm), when known and complete.
        frame : int, optional
            Its synchronised number, for the phrase and error messages.

        Notes
        -----
        The hypotheses are scored by paper 002's likelihood without the coverage term
        (:meth:`_paper_likelihood`); the tracking that follows uses ``[likelihood] coverage``.
        """
        with self._paper_likelihood():
            return self._initial_state(observation, ground_truth, frame=frame)

    def _initial_state(self, observation, ground_truth, *, frame) -> tuple[str, np.ndarray]:
        from ..body import fit_to_landmarks

        method = self.config.init.method
        which = "the first frame" if frame is None else f"frame {int(frame)}"
        if method == "ground_truth" and ground_truth is None:
            raise InputError("init.method", f"ground truth of {which} is not available")
        if method == "ground_truth" or (method == "auto" and ground_truth is not None):
            return (f"{GROUND_TRUTH_START} of {which}",
                    fit_to_landmarks(self.model, np.asarray(ground_truth, dtype=float)))
        if method == "voxels":
            phrase = f"the voxels of {which} (centroid + yaw search)"
            states = initial_state_from_voxels(observation, self.model, self.variances,
                                               coverage=self.coverage)
        else:
            from ..measure.detect import find_extremities
            from .initialise import initial_pose

            ex = find_extremities(observation.occupancy, observation.grid)
            if ex is None:
                raise InputError(which, "no occupied voxel: cannot initialise from the voxels "
                                        "(is the person in view? is the background model right?)")
            states, how = initial_pose(ex, self.model, self.log_likelihood(observation),
                                       n_best=self.config.init.hypotheses)
            phrase = f"the voxels of {which}: {how}"
        if self.config.init.limb_sweep:
            states, moved = self.searched_starts(observation, states)
            phrase += f"; limbs searched over their ranges ({moved} moved)"
        return phrase, states

    def _sweep_estimate(self, observation, est):
        """The estimate ``(1, 27)`` with its limbs searched over their ranges; the filter's
        particles follow a limb that moved (``filter.limb_sweep_every``)."""
        from .limb_search import sweep_limbs

        new, gains = sweep_limbs(observation, self.model, est[0], variances=self.variances,
                                 coverage=self.coverage, sweeps=1, seed=self.filter.frame,
                                 min_gain=self.config.filter.limb_sweep_gain,
                                 samples=self.config.filter.limb_sweep_samples,
                                 others=self._other_cues(observation),
                                 voxel_weight=self._voxel_weight,
                                 swaps=self.config.filter.limb_swaps)
        if sum(gains.values()) > 0:
            self.filter.move_estimate(new)
            return new[None]
        return est

    @property
    def _voxel_weight(self) -> float:
        """The voxel cue's weight in the fused likelihood (0 when it is not selected)."""
        return float(dict(self.config.cues.weights).get("voxel", 0.0))

    def _other_cues(self, observation):
        """The cues other than the voxel one, ``(P, 27) -> (P,)`` on whole states, or None when
        the voxel cue is alone (the limb search adds them to its partial voxel scores). A cue
        still without its reference appearance (no pose yet to learn it from) scores 0."""
        if self.cues.voxel_only:
            return None
        return self.cues.frame(observation, reference=self._cue_reference, without=("voxel",))

    def _hull_is_tight(self, observation) -> bool:
        """Whether the frame's occupied volume is at most ``filter.limb_sweep_max_hull`` times
        the body model's: the periodic sweep trusts the hull to show where a limb is, and a
        hull several times the body (few cameras, poor silhouettes) offers phantom volume that
        a swept limb scores well in."""
        from .recovery import body_volume

        occupied = float(observation.n_occupied) * float(observation.grid.voxel_size) ** 3
        return occupied <= self.config.filter.limb_sweep_max_hull * body_volume(self.model)

    def sweep_limbs(self, observation, states, limbs=None) -> tuple[np.ndarray, int]:
        """Each starting pose's limbs (``limbs``: these only, names of
        :data:`~voxelmocap.pose.limb_search.LIMBS`) searched over their legal ranges on this frame
        (:func:`voxelmocap.pose.limb_search.sweep_limbs`); returns the poses (same shape) and how
        many limbs moved over all of them."""
        from .limb_search import sweep_limbs

        states = np.asarray(states, dtype=float)
        out = np.atleast_2d(states).copy()
        others = self._other_cues(observation)
        moved = 0
        for k in range(len(out)):
            out[k], gains = sweep_limbs(observation, self.model, out[k], variances=self.variances,
                                        coverage=self.coverage, seed=k, others=others,
                                        voxel_weight=self._voxel_weight,
                                        swaps=self.config.filter.limb_swaps, limbs=limbs)
            moved += sum(g > 0 for g in gains.values())
        return out.reshape(states.shape), moved

    def searched_starts(self, observation, states, limbs=None) -> tuple[np.ndarray, int]:
        """:meth:`sweep_limbs` scored as a start is (paper 002's likelihood, no coverage term):
        the first start's and every re-initialisation's candidates (``init.limb_sweep``), and
        the arms of a pass continuing the previous one."""
        with self._paper_likelihood():
            return self.sweep_limbs(observation, states, limbs)

    def initialise(self, observation, ground_truth=None, *, frame=None) -> str:
        """Draw the first particles around :meth:`initial_state`; returns how it started.

        The spread is ``config.init.spread`` times the propagation noise.
        """
        phrase, mean = self.initial_state(observation, ground_truth, frame=frame)
        return self.start(phrase, mean)

    def start(self, phrase: str, mean) -> str:
        """Draw the first particles around ``mean`` ((27,) or (K, 27) for a mixture).

        A start from the ground truth is exact: it gets no settling steps (``init.settle_steps``
        apply to every other start: from the voxels, or a previous pass's pose).
        """
        self.init_method = phrase
        self._start_pose = np.atleast_2d(np.asarray(mean, dtype=float))[0]   # best start first
        self.filter.initialise(mean, self.config.init.spread * self.noise_std)
        self._settle = (0 if phrase.startswith(GROUND_TRUTH_START)
                        else self.config.init.settle_steps)
        return phrase

    def _run_filter(self, observation, spent):
        pf = self.filter
        if hasattr(pf, "step_partitioned"):
            share = self.config.filter.limb_proposal
            options = {}
            if share > 0 and pf.estimate is not None:
                mix = self.detector_mixture(observation, pf.estimate)
                options = {"proposal": mix.sample, "proposal_share": share}
            return pf.step_partitioned(self.partition_log_likelihood(observation, spent),
                                       **options)
        proposal = self.proposal(observation) if pf.strategy == "iapf" else {}
        return pf.step(self.log_likelihood(observation, spent), **proposal)

    def settle(self, observation) -> None:
        """Run ``config.init.settle_steps`` filter steps on the first frame (not recorded).

        The estimates of these steps are not motion: the history the dynamics use and the frame
        count are reset afterwards, so the first recorded step starts from zero velocity.
        """
        steps, self._settle = self._settle, 0
        pf = self.filter
        for _ in range(steps):
            self._run_filter(observation, None)
        if steps:
            pf.clear_history()

    # ------------------------------------------------------------------ one frame
    def log_likelihood(self, observation, spent: list | None = None
                       ) -> Callable[[np.ndarray], np.ndarray]:
        """The filter's per-frame callable: ``(P, 27)`` states → ``(P,)`` log-likelihoods.

        When ``spent`` is given, its first element is increased by the seconds of every call.
        """
        from .hierarchy import pitch_prior

        # The selected cues' weighted sum; reference appearances (ROI histograms, skin, limb
        # colour) are learnt from the pose the track starts from (voxelmocap.score.cues.fusion).
        score = self.cues.frame(observation, reference=self._cue_reference)
        prior = self.config.likelihood.root_pitch_prior_deg

        def ll(states):
            t0 = time.perf_counter()
            out = score(states)
            if prior is not None:
                out = out + pitch_prior(states, prior)
            if spent is not None:
                spent[0] += time.perf_counter() - t0
            return out

        return ll

    def partition_log_likelihood(self, observation, spent: list | None = None):
        """The hierarchical filter's per-frame factory ``(k, reference) -> ll`` (see
        :func:`voxelmocap.pose.hierarchy.log_likelihood_for`); ``spent`` as for
        :meth:`log_likelihood`."""
        from .hierarchy import log_likelihood_for

        # cues other than the voxel one, on whole states (prepared and learnt once per frame)
        others = self._other_cues(observation)

        def factory(k, reference):
            t0 = time.perf_counter()
            inner = log_likelihood_for(observation, self.model, self.variances,
                                       self.config.likelihood.root_pitch_prior_deg, k, reference,
                                       coverage=self.coverage)
            if spent is not None:
                spent[0] += time.perf_counter() - t0

            def ll(states):
                t1 = time.perf_counter()
                out = inner(states) if others is None else inner(states) + others(states)
                if spent is not None:
                    spent[0] += time.perf_counter() - t1
                return out
            return ll

        return factory

    def _cue_reference(self):
        """The pose the cues learn their reference appearance from: the current estimate, else
        the (best) starting pose, else the mean of the first particles (None before any)."""
        pf = self.filter
        if pf.estimate is not None:
            return pf.estimate
        if getattr(self, "_start_pose", None) is not None:
            return self.model.clip(self._start_pose[None])[0]
        return None if pf.particles is None else self.model.clip(pf.particles.mean(axis=0)[None])[0]

    def step(self, observation, *, frame: int | None = None) -> FrameRecord:
        """Track one frame and describe the estimate (then call the observers).

        Parameters
        ----------
        observation : voxelmocap.score.likelihood.Measurement
            This frame's measurement.
        frame : int, optional
            Its synchronised number (default: the filter's step count, 1-based).
        """
        from ..body import joints_to_endpoints
        from ..score.likelihood import part_scores
        from .confidence import landmark_confidence, landmark_spread

        if not self.initialised:
            raise RuntimeError("BodyTracker.step: call initialise() or set_state() first")
        t0 = time.perf_counter()
        pf = self.filter
        spent = [0.0]
        if self._settle:
            self.settle(observation)
        est = self.model.clip(self._run_filter(observation, spent)[None])
        every = self.config.filter.limb_sweep_every
        if every and pf.frame % every == 0 and self._hull_is_tight(observation):
            est = self._sweep_estimate(observation, est)
        # One forward-kinematics pass for the landmarks and the endpoints (the endpoints are
        # joints picked by index); the part scores run their own inside the likelihood kernel.
        joints = self.model.forward(est).joints
        scores = part_scores(observation, self.model, est)[0]
        spread = landmark_spread(self.model.forward(pf.particles).joints, pf.weights)
        record = FrameRecord(
            frame=int(pf.frame if frame is None else frame),
            state=est[0],
            map_state=np.asarray(pf.map_particle, dtype=float),
            landmarks=joints[0],
            endpoints=joints_to_endpoints(joints)[0],
            part_scores=scores,
            ess=np.asarray(pf.layer_ess, dtype=float),
            betas=np.asarray(pf.layer_betas, dtype=float),
            seconds=time.perf_counter() - t0,
            log_likelihood=self._record_log_likelihood(observation, est, scores),
            likelihood_seconds=spent[0],
            landmark_spread=spread,
            confidence=landmark_confidence(spread, scores, self.model.part_names),
        )
        for observer in self.observers:
            observer(record, self)
        return record

    def _record_log_likelihood(self, observation, est, scores) -> float:
        """The selected cues' value of the estimate, the voxel cue's without the coverage term
        (paper 002's, from the part scores when it is alone): what the multi-start ranks starts
        by (the lost-track test watches :meth:`lost_track_value`). The coverage term is
        symmetric under turning round and swings with the hull's phantom volume
        (:meth:`_paper_likelihood`)."""
        from ..score.likelihood import log_likelihood_from_scores

        if self.cues.voxel_only:
            return float(log_likelihood_from_scores(scores, variances=self.variances))
        with self._paper_likelihood():
            return float(self.cues.log_likelihood(observation, est)[0])

    def lost_track_value(self, record: FrameRecord) -> float:
        """What the lost-track rule (:class:`voxelmocap.pose.recovery.LostTrack`) watches: the voxel
        cue's value of the estimate from its part scores (paper 002's likelihood) whenever that
        cue is selected, else the record's fused value.

        ``[recovery] lost_drop`` is a drop on the voxel cue's scale. A fused value with an image
        cue weighted in (the silhouette cue at 10) swings by far more than that from frame to
        frame on a track that is fine: on the Pose2Sim demo the rule fired three times in 100
        frames on the fused value and never on the voxel cue's, and each re-start lost more than
        it mended (docs/benchmarks.md).
        """
        from ..score.likelihood import log_likelihood_from_scores

        if self._voxel_weight > 0:
            return float(log_likelihood_from_scores(record.part_scores, variances=self.variances))
        return float(record.log_likelihood)

    def proposal(self, observation) -> dict:
        """The IAPF's detector proposal for this frame, as ``AnnealedParticleFilter.step`` options.

        :func:`voxelmocap.pose.recovery.detector_proposal` around the latest estimate (or the mean of
        the particles right after a start), or the pending re-initialisation mixture; its
        log-density is passed (importance correction) only with ``recovery.proposal_correction``.
        """
        rc, pf = self.config.recovery, self.filter
        mix, self.pending_proposal = self.pending_proposal, None
        if pf.iapf_fractions[1] == 0:
            return {}  # no particle comes from the proposal: nothing to build
        if mix is None:
            previous = pf.estimate if pf.estimate is not None else pf.weights @ pf.particles
            mix = self.detector_mixture(observation, previous)
        self.last_proposal = mix
        return {"proposal": mix.sample,
                "proposal_log_pdf": mix.log_pdf if rc.proposal_correction else None}

    def detector_mixture(self, observation, previous):
        """The frame's detector proposal around ``previous`` (27,): the extremities of the
        voxels fitted by inverse kinematics (:func:`voxelmocap.pose.recovery.detector_proposal`)."""
        from .recovery import detector_proposal

        rc = self.config.recovery
        mix = detector_proposal(observation, self.model, std=rc.proposal_spread * self.noise_std,
                                previous=previous, gate_mm=rc.proposal_gate_mm,
                                mirror=rc.proposal_mirror)
        self.last_proposal = mix
        return mix

    def observe(self, observation, *, frame: int | None = None) -> FrameRecord:
        """:meth:`step` with recovery (``voxelmocap.pose.recovery.Recovery``, ``config.recovery``).

        A frame without a person is not tracked: its record repeats the last estimate with
        ``observed = False``. The track starts again from the voxels when the person comes back
        or the lost-track rule fires (the record's ``note`` says so). Observers are called for
        every frame.
        """
        from .recovery import Recovery

        if self._recovery is None:
            self._recovery = Recovery(self)
        if frame is None:
            frame = self.filter.frame + 1
        record = self._recovery.step(observation, frame=frame)
        if not record.observed:
            for observer in self.observers:
                observer(record, self)
        return record

    def absent_record(self, observation, state, *, frame: int, seconds: float = 0.0
                      ) -> FrameRecord:
        """:func:`absent_record` with this tracker's model, layers and variances."""
        pf = self.filter
        return absent_record(self.model, observation, state, frame=frame,
                             n_layers=1 if pf.strategy == "sir" else pf.n_layers,
                             variances=self.variances, seconds=seconds)

    @property
    def recovery(self):
        """The :class:`voxelmocap.pose.recovery.Recovery` of :meth:`observe` (None before its use)."""
        return self._recovery

    def track(self, observations: Iterable, frames: Iterable[int] | None = None,
              ground_truth=None) -> list[FrameRecord]:
        """Step through observations (initialising on the first when needed); the records.

        ``ground_truth`` is the first frame's landmarks ``(15, 3)`` or None.
        """
        records = []
        frames = iter(frames) if frames is not None else None
        for observation in observations:
            frame = None if frames is None else int(next(frames))
            if not self.initialised:
                self.initialise(observation, ground_truth, frame=frame)
            records.append(self.step(observation, frame=frame))
        return records

    # ------------------------------------------------------------------ checkpoints
    def get_state(self) -> dict:
        """The filter's complete state (``AnnealedParticleFilter.get_state``), the recovery's, and
        the cues' learnt reference appearances (``cue_*`` keys, only when image cues learnt
        some)."""
        state = self.filter.get_state()
        if self._recovery is not None:
            state.update(self._recovery.get_state())
        state.update(self.cues.get_state())
        return state

    def set_state(self, state: dict) -> None:
        """Restore :meth:`get_state`; stepping on then equals an uninterrupted run."""
        state = dict(state)
        self.cues.set_state({k: state.pop(k) for k in list(state) if k.startswith("cue_")})
        self.filter.set_state(state)
        if "recovery_good" in state:
            from .recovery import Recovery

            self._recovery = Recovery(self)
            self._recovery.set_state(state)


class MultiStart:
    """Several starting poses tracked side by side for the first frames; the likeliest goes on.

    Within one frame the annealing collapses a mixture of starting poses onto whichever scores
    best on that frame, and far from the truth a mirrored pose (facing the other way) scores
    about as well as the right one. Tracking each start separately for a few frames lets the
    motion tell them apart: the start whose summed log-likelihood over those frames is highest
    is kept, with the records of its first frames.

    Parameters
    ----------
    model : BodyModel
    config : TrackConfig
    seed : int
        Start ``k`` uses ``numpy.random.default_rng([seed, k])``.
    states : (K, 27) array_like
        The starting poses.
    frames : int
        Frames to track before choosing.
    noise_std : (27,) array_like, optional
        As for :class:`BodyTracker`.
    """

    def __init__(self, model, config: TrackConfig, seed: int, states, frames: int, *,
                 noise_std=None):
        self.frames = int(frames)
        self.trackers: list[BodyTracker] = []
        for k, state in enumerate(np.atleast_2d(np.asarray(states, dtype=float))):
            tracker = BodyTracker(model, config, seed=np.random.default_rng([int(seed), k]),
                                  noise_std=noise_std)
            tracker.start("multi-start", state)
            self.trackers.append(tracker)
        self.records: list[list[FrameRecord]] = [[] for _ in self.trackers]
        #: each start's filter state after each frame, so that the kept start's frames can be
        #: written with their checkpoints (a run killed while writing them resumes exactly)
        self.checkpoints: list[list[dict]] = [[] for _ in self.trackers]
        self.chosen: int | None = None

    def step(self, observation, *, frame: int | None = None) -> list[FrameRecord] | None:
        """Step every start; after ``frames`` frames, the chosen start's records (else None)."""
        for tracker, records, states in zip(self.trackers, self.records, self.checkpoints,
                                            strict=True):
            records.append(tracker.step(observation, frame=frame))
            states.append(tracker.get_state())
        return self.finish() if len(self.records[0]) >= self.frames else None

    @property
    def totals(self) -> list[float]:
        """Each start's summed log-likelihood over the frames tracked so far."""
        return [sum(r.log_likelihood for r in records) for records in self.records]

    def finish(self) -> list[FrameRecord]:
        """Choose now (e.g. the sequence ended early): the records of the likeliest start."""
        self.chosen = int(np.argmax(self.totals))
        return self.records[self.chosen]

    @property
    def tracker(self) -> BodyTracker:
        """The chosen start's tracker (after :meth:`finish`)."""
        if self.chosen is None:
            raise RuntimeError("MultiStart.tracker: no start chosen yet")
        return self.trackers[self.chosen]
