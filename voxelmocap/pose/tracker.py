"""The body tracker: the body model, its voxel likelihood and the annealed particle filter, per frame.

:class:`BodyTracker` owns everything between a measured frame and a pose estimate:

* the body model (:class:`~voxelmocap.body.BodyModel`) and the likelihood's variances;
* the noise profile (:func:`noise_profile`: which state dimension gets which propagation noise);
* the dynamics, built by name from :data:`voxelmocap.tracking.DYNAMICS` (:func:`build_dynamics`);
* the filter (:class:`~voxelmocap.tracking.AnnealedParticleFilter`, :func:`build_filter`);
* the initialisation (fit to a ground-truth pose, or a search around the voxel blob:
  :mod:`voxelmocap.pose.starts`, :mod:`voxelmocap.pose.initialise`).

It knows nothing about files: the runner (:mod:`voxelmocap.run.pipeline`) measures frames and writes
what :meth:`BodyTracker.step` returns, a :class:`FrameRecord`. Studies and benchmarks call the same
class, so they measure the product, not a copy of its loop.

Observers (:mod:`voxelmocap.pose.records`) are callables ``observer(record, tracker)`` called
after every step. The filter is assembled in :mod:`voxelmocap.pose.filter_setup`.
:meth:`BodyTracker.get_state` / :meth:`BodyTracker.set_state` checkpoint the filter so
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
from dataclasses import replace

import numpy as np

from ..config import TrackConfig, with_overrides
from ..errors import InputError
from ..portable import weighted_sum
from .filter_setup import REFERENCE_RATE, build_filter, noise_profile
from .records import FrameRecord, Observer, absent_record
from .starts import GROUND_TRUTH_START, initial_state_from_voxels

__all__ = ["BodyTracker"]


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
    frame_rate : float, optional
        The frames' rate (Hz): the config's noise, stated at 60 Hz, is scaled to it
        (:func:`~voxelmocap.pose.filter_setup.noise_profile`). Default 60.
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
                 frame_rate: float = REFERENCE_RATE, observers: Iterable[Observer] = ()):
        self.model = model
        self.config = config or TrackConfig()
        #: the frames' rate (Hz) the noise is scaled to
        self.frame_rate = float(frame_rate)
        self.variances = self.config.likelihood.variances
        #: keyword arguments of the voxel likelihood, shared with the voxel cue: ``variances``
        #: and ``coverage`` (``[likelihood]``; the start is scored with coverage 0, see
        #: :meth:`initial_state`)
        self.voxel_options = {"variances": self.variances,
                              "coverage": self.config.likelihood.coverage}
        if noise_std is None:
            self.noise_std = noise_profile(model, self.config, self.frame_rate)
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
        #: the silhouette cue the periodic sweep adds (:meth:`sweep_scoring`), built on first use
        self._sweep_cues = None
        self.init_method: str | None = None
        self.observers: list[Observer] = list(observers)
        self._settle = 0  # settling steps still due on the next frame (see settle)
        #: the IAPF proposal of the next frame when set (a re-initialisation's hypotheses), and
        #: the last one used (``voxelmocap.pose.proposal.MixtureProposal``)
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
            phrase, states = self._initial_state(observation, ground_truth, frame=frame)
        if self.config.init.start_turned:
            # The test hook: the best start alone (no multi-start to choose another), turned
            # round — a track that starts facing the wrong way on purpose.
            from .facing import turned_round

            states = turned_round(self.model, np.atleast_2d(states)[0])
            phrase += "; its best start turned round on purpose (init.start_turned)"
        return phrase, states

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
            from ..measure.observation import no_voxels
            from .initialise import initial_pose

            ex = find_extremities(observation.occupancy, observation.grid)
            if ex is None:
                raise no_voxels(which, "initialise from the voxels")
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

        new, gains = sweep_limbs(observation, self.model, est[0],
                                 scoring=self.sweep_scoring(observation), sweeps=1,
                                 seed=self.filter.frame,
                                 min_gain=self.config.filter.limb_sweep_gain,
                                 samples=self.config.filter.limb_sweep_samples,
                                 swaps=self.config.filter.limb_swaps)
        if sum(gains.values()) > 0:
            self.filter.move_estimate(new)
            return new[None]
        return est

    @property
    def _voxel_weight(self) -> float:
        """The voxel cue's weight in the fused likelihood (0 when it is not selected)."""
        return float(dict(self.config.cues.weights).get("voxel", 0.0))

    def limb_scoring(self, observation):
        """How a limb search scores states on this frame: this tracker's σ² and coverage
        weight (as they stand: a start is scored without the coverage term), the voxel cue's
        weight and the other cues (:class:`voxelmocap.pose.limb_search.LimbScoring`)."""
        from .limb_search import LimbScoring

        return LimbScoring(variances=self.variances, coverage=self.coverage,
                           voxel_weight=self._voxel_weight, others=self._other_cues(observation))

    def sweep_scoring(self, observation):
        """How the periodic sweep scores a limb: :meth:`limb_scoring`, plus the silhouette cue
        at ``filter.limb_sweep_silhouette`` when the tracking cues leave that cue out and the
        frame has silhouettes.

        The coverage term rewards a limb for any occupied voxels it covers, and the visual hull
        holds volume the cameras cannot carve away (about a third of the occupied voxels of a
        rendered jog lie in no part): a forearm folded into that surplus in front of the chest
        covers as much as the real one, and the voxels alone cannot tell the two apart. The
        silhouettes can: the surplus's image lies inside the torso's in most views, the real
        forearm's does not. Scoring whole images costs too much for every particle; a sweep
        every ``limb_sweep_every`` frames scores a few thousand poses."""
        scoring = self.limb_scoring(observation)
        weight = self.config.filter.limb_sweep_silhouette
        if (not weight or "silhouette" in self.cues.names
                or getattr(observation, "masks", None) is None):
            return scoring
        if self._sweep_cues is None:
            from ..score.cues import CueSet

            cues = with_overrides(self.config, **{"cues.weights": {"silhouette": weight}}).cues
            self._sweep_cues = CueSet(self.model, cues, voxel=self.voxel_options)
        if self._sweep_cues.config.silhouette_unseen == "count":
            from ..score.cues.partial import WeightedPartialSilhouette

            # a limb moves two cones of ten: the others are drawn once per limb, not per pose
            return replace(scoring, partial=WeightedPartialSilhouette(self._sweep_cues,
                                                                      observation, weight))
        silhouette = self._sweep_cues.frame(observation)
        others = scoring.others
        return replace(scoring, others=silhouette if others is None
                       else (lambda states: others(states) + silhouette(states)))

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
        scoring = self.limb_scoring(observation)
        moved = 0
        for k in range(len(out)):
            out[k], gains = sweep_limbs(observation, self.model, out[k], scoring=scoring, seed=k,
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
        from ..body.model import PartGeometry
        from ..score.likelihood import part_scores_of
        from .confidence import landmark_confidence, searched_spread

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
        note = ""
        every = self.config.filter.facing_check_every
        if every and pf.frame % every == 0:
            est, note = self._check_facing(observation, est)
        # One forward-kinematics pass of the estimate: its landmarks, its endpoints (joints
        # picked by index) and the cones its part scores are counted in.
        kinematics = self.model.forward(est)
        joints = kinematics.joints
        scores = part_scores_of(observation, PartGeometry(kinematics, self.model.parts))[0]
        spread = searched_spread(lambda x: self.model.forward(x).joints, est[0], pf.searched)
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
            note=note,
        )
        for observer in self.observers:
            observer(record, self)
        return record

    def _check_facing(self, observation, est):
        """The estimate ``(1, 27)`` or its turned-round twin, whichever the frame prefers, and a
        note when the track turned round (``[filter] facing_check_every``).

        The twin (:func:`voxelmocap.pose.facing.turned_round`: the body turned 180° in place,
        left and right exchanged) has its limbs searched over their ranges on this frame, then
        both are scored by the tracking likelihood plus ``facing_weight`` × the facing evidence
        (:func:`~voxelmocap.pose.facing.facing_evidence`); the twin is taken when it wins by
        more than ``facing_margin``, and the particles follow it without carrying the motion
        across the turn."""
        from .facing import facing_evidence, turned_round
        from .limb_search import sweep_limbs

        fc = self.config.filter
        twin = turned_round(self.model, est[0])
        twin, _ = sweep_limbs(observation, self.model, twin,
                              scoring=self.limb_scoring(observation), sweeps=1,
                              seed=self.filter.frame, samples=fc.limb_sweep_samples)
        both = np.stack([est[0], twin])
        value = self.log_likelihood(observation)(both)
        if fc.facing_weight:
            value = value + fc.facing_weight * facing_evidence(observation, self.model, both)
        gain = float(value[1] - value[0])
        if gain <= fc.facing_margin:
            return est, ""
        self.filter.move_estimate(twin, keep_motion=False)
        return twin[None], f"turned round (the twin facing the other way won by {gain:.1f})"

    def _record_log_likelihood(self, observation, est, scores) -> float:
        """The selected cues' value of the estimate, the voxel cue's without the coverage term
        (paper 002's, from the part scores already counted): what the multi-start ranks starts
        by (the lost-track test watches :meth:`lost_track_value`). The coverage term is
        symmetric under turning round and swings with the hull's phantom volume
        (:meth:`_paper_likelihood`)."""
        from ..score.likelihood import log_likelihood_from_scores

        if self.cues.voxel_only:
            return float(log_likelihood_from_scores(scores, variances=self.variances))
        values = self.cues.evaluate(observation, est, [n for n in self.cues.names if n != "voxel"])
        if "voxel" in self.cues.names:
            values["voxel"] = log_likelihood_from_scores(scores[None], variances=self.variances)
        return float(self.cues.combine(values, 1)[0])

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

        :func:`voxelmocap.pose.proposal.detector_proposal` around the latest estimate (or the mean of
        the particles right after a start), or the pending re-initialisation mixture; its
        log-density is passed (importance correction) only with ``recovery.proposal_correction``.
        """
        rc, pf = self.config.recovery, self.filter
        mix, self.pending_proposal = self.pending_proposal, None
        if pf.iapf_fractions[1] == 0:
            return {}  # no particle comes from the proposal: nothing to build
        if mix is None:
            previous = pf.estimate if pf.estimate is not None else weighted_sum(pf.weights, pf.particles)
            mix = self.detector_mixture(observation, previous)
        self.last_proposal = mix
        return {"proposal": mix.sample,
                "proposal_log_pdf": mix.log_pdf if rc.proposal_correction else None}

    def detector_mixture(self, observation, previous):
        """The frame's detector proposal around ``previous`` (27,): the extremities of the
        voxels fitted by inverse kinematics (:func:`voxelmocap.pose.proposal.detector_proposal`)."""
        from .proposal import detector_proposal

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
