"""Write the config golden files: the TOML text of a few configs and the verdict on many probes.

The files in this folder were written by the code of commit c97013a (``voxelmocap/config.py``
before it became a schema, issue 32, with issue 33's facing keys), so
``tests/test_config_schema.py`` holds the schema to the behaviour it replaced. Rerun against
another checkout with ``PYTHONPATH=<checkout> python tests/data/config/make_golden.py`` (it
writes beside itself).

``probes.json``: one entry per probe, ``[data, verdict]``, where ``data`` is the nested dict
handed to ``config_from_dict`` (source ``cfg``) and ``verdict`` is ``"ok"`` or the error message.
The probes set one key (or a few keys that go together) to values on and around every bound.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import types
import typing
from pathlib import Path

from voxelmocap.config import (
    CuesConfig,
    ExportConfig,
    FilterConfig,
    InitConfig,
    LikelihoodConfig,
    MeasurementConfig,
    RecoveryConfig,
    SilhouetteConfig,
    TrackConfig,
    config_from_dict,
    config_to_toml,
    with_overrides,
)
from voxelmocap.errors import InputError

HERE = Path(__file__).resolve().parent

SECTIONS = {
    ("measurement", "silhouette"): SilhouetteConfig,
    ("measurement",): MeasurementConfig,
    ("likelihood",): LikelihoodConfig,
    ("filter",): FilterConfig,
    ("init",): InitConfig,
    ("export",): ExportConfig,
    ("recovery",): RecoveryConfig,
    ("cues",): CuesConfig,
}

FLOATS = [-1e9, -2.0, -1.5, -1.0, -0.5, -1e-9, 0.0, 1e-9, 1e-4, 0.02, 0.3, 0.5, 0.9, 0.99, 1.0,
          1.01, 1.5, 2.0, 4.0, 9.99, 10.0, 10.01, 16.0, 249.9, 250.0, 250.1, 1e9,
          math.nan, math.inf, -math.inf, 3, "x", True]
INTS = [-1000000, -3, -2, -1, 0, 1, 2, 3, 4, 7, 8, 15, 16, 17, 31, 32, 33, 1000000, 2.5, "x",
        False]
PAIR = [-1.0, 0.0, 0.3, 0.5, 1.0, 1.5, 2.0]


def _values(hint, name, choices=()):
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        inner = next(a for a in args if a is not type(None))
        return [None, *_values(inner, name, choices)]
    if hint is bool:
        return [True, False, 1, "yes"]
    if hint is int:
        return INTS
    if hint is float:
        return FLOATS
    if hint is str:
        return ["zzz", 1, "", *choices]
    if origin is dict:
        if name == "weights":
            return [{}, 3, {"voxel": 1.0}, {"voxel": 0.0}, {"voxel": -1.0}, {"voxel": math.nan},
                    {"voxel": 1.0, "roi": 4.0, "edges": 0.1}, {"edgse": 1.0}, {"voxel": "x"},
                    {"silhouette": 1.0, "dt": 2.0, "blob3d": 1.0, "skin": 1.0, "uniform": 1.0}]
        return [{}, 3, *({"C1": v} for v in FLOATS), {"C1": 1.0, "C2": -1.0}]
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            if args[0] is str:
                return [[], ["trc"], ["c3d", "csv"], ["fbx"], ["trc", "xyz"], [1], "trc"]
            return [[], [0.1], [1.0] * 6, [0.1, 0.4, 1.0], [0.0] * 6, [-0.1] + [1.0] * 5,
                    [math.nan] * 6, [1, 4, 25, 25, 25, 25], [0.5] * 6, [2.0] * 6, "x", [1, "a"]]
        n = len(args)
        if n <= 2:
            scalars = [1, 2, 8, 0, -1, 100] if args[0] is int else PAIR
        else:
            scalars = [1, 7, 8, 0, -1] if args[0] is int else [-1.0, 0.0, 0.5]
        combos = [list(c) for c in itertools.product(scalars, repeat=min(n, 3))]
        if n == 4:
            combos = [[*c, 0.1] for c in combos] + [[0.1, *c] for c in combos]
        return [*combos, [1] * (n - 1), [1] * (n + 1), "x", 3, [1.5, "x"][:1] * n]
    raise AssertionError(hint)


def _nest(path, fields):
    data = fields
    for name in reversed(path):
        data = {name: data}
    return data


def _verdict(data):
    try:
        config_from_dict(data, "cfg")
    except InputError as exc:
        return str(exc)
    return "ok"


def probes():
    out = []
    for path, cls in SECTIONS.items():
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            if dataclasses.is_dataclass(hints[f.name]):
                continue
            for value in _values(hints[f.name], f.name, f.metadata.get("choices", ())):
                out.append(_nest(path, {f.name: value}))
    # keys that go together or depend on each other
    for origin, shape in itertools.product([None, [0.0, 0.0, 0.0], [-1e3, 5.5, 0]],
                                           [None, [8, 8, 8], [7, 100, 100], [100, 100, 2]]):
        fields = {k: v for k, v in (("grid_origin", origin), ("grid_shape", shape)) if v}
        out.append(_nest(("measurement",), fields))
    for layers, betas, alphas in itertools.product([1, 2, 3, 6], [None, [0.5, 1.0], [0.1, 0.4, 1.0]],
                                                   [None, [1, 4], [1, 4, 25], [0, 1, 1]]):
        fields = {"layers": layers, "betas": betas, "alphas": alphas}
        out.append(_nest(("filter",), {k: v for k, v in fields.items() if v is not None}))
    for strategy, search, dynamics in itertools.product(["apf", "sir", "iapf"],
                                                        ["joint", "hierarchical"],
                                                        ["velocity", "elbow"]):
        out.append({"filter": {"strategy": strategy, "search": search, "dynamics": dynamics,
                               "velocity_factor": 0.5}})
    for a, b in itertools.product([0.0, 0.5, 1.0, 1.5], repeat=2):
        out.append({"filter": {"survival": a, "noise_decay": b}})
    for hb, sb in itertools.product([0, 4, 16, 17], [0, 8, 32, 33]):
        out.append({"cues": {"histogram_bins": hb, "skin_bins": sb}})
    return out


def configs() -> dict:
    """The configs whose TOML text is kept, by file name."""
    return {
        "default": TrackConfig(),
        "grid_and_risk": with_overrides(TrackConfig(), **{
            "measurement.grid_origin": (-2000.0, -2000.0, 0.0),
            "measurement.grid_shape": (200, 200, 110), "measurement.min_views": 5,
            "measurement.silhouette.camera_risk": {"BW1": 1e6, "C2": 3}}),
        "filter_and_init": with_overrides(TrackConfig(), **{
            "filter.layers": 3, "filter.strategy": "iapf", "filter.betas": [0.1, 0.4, 1.0],
            "filter.alphas": [1, 4, 25], "filter.beta_max": 5.0, "filter.trunk_layers": 2,
            "filter.limb_particles": 50, "filter.dynamics": "elbow", "init.method": "voxels",
            "init.previous_pass_start": 0, "likelihood.root_pitch_prior_deg": 10.0,
            "recovery.enabled": False}),
        "cues_export_silhouette": with_overrides(TrackConfig(), **{
            "cues.weights": {"voxel": 1.0, "roi": 4.0, "edges": 0.1}, "cues.edge_c2": 9.0,
            "cues.canny": (10, 20), "export.formats": [], "export.cutoff_hz": 6.0,
            "export.axes": "y_up", "measurement.silhouette.method": "mog2",
            "measurement.silhouette.camera_var_threshold": {"C1": 30.0},
            "measurement.silhouette.shadow_brightness": (0.3, 0.9),
            "measurement.carve_holes": 1, "measurement.person_only": True,
            "measurement.grid_placement": "person"}),
    }


def main():
    data = [[p, _verdict(p)] for p in probes()]
    (HERE / "probes.json").write_text(json.dumps(data, indent=None, separators=(",", ":"))
                                      .replace("],[{", "],\n[{") + "\n")
    for name, config in configs().items():
        (HERE / f"{name}.toml").write_text(config_to_toml(config))
    refused = sum(v != "ok" for _, v in data)
    print(f"{len(data)} probes ({refused} refused), {len(configs())} configs")


if __name__ == "__main__":
    main()
