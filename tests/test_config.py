import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from voxelmocap.config import (
    MeasurementConfig,
    SilhouetteConfig,
    TrackConfig,
    config_from_dict,
    config_from_toml,
    config_to_toml,
    load_config,
    with_overrides,
)
from voxelmocap.errors import InputError


def test_defaults_are_the_papers_working_point():
    cfg = TrackConfig()
    assert (cfg.filter.layers, cfg.filter.particles) == (6, 600)
    assert cfg.measurement.voxel_size == 20.0
    assert cfg.likelihood.variances == (0.01, 0.1, 0.1, 0.1)


def test_toml_round_trip(tmp_path):
    cfg = with_overrides(TrackConfig(), **{"filter.layers": 3, "measurement.min_views": 6,
                                           "measurement.grid_shape": (10, 20, 30),
                                           "measurement.grid_origin": (-100.0, -200.0, 0.0)})
    path = tmp_path / "cfg.toml"
    path.write_text(config_to_toml(cfg))
    assert load_config(path) == cfg


def test_silhouette_settings_are_typed_and_round_trip():
    text = ("[measurement.silhouette]\nmethod = 'mog2'\nmin_area = 12\n"
            "shadow_brightness = [0.3, 0.9]\n"
            "[measurement.silhouette.camera_risk]\nBW1 = 1e6\nC2 = 3\n")
    cfg = config_from_toml(text, "cfg.toml")
    sil = cfg.measurement.silhouette
    assert isinstance(sil, SilhouetteConfig)
    assert sil.method == "mog2" and sil.min_area == 12 and sil.shadow_brightness == (0.3, 0.9)
    assert sil.camera_risk == {"BW1": 1e6, "C2": 3.0} and isinstance(sil.camera_risk["C2"], float)
    assert sil.risk_for("BW1") == 1e6 and sil.risk_for("C1") == 1.0
    assert sil.var_threshold == SilhouetteConfig().var_threshold  # not given: the default
    # the stored text reads back to the same config, and writes the same text again
    stored = config_to_toml(cfg)
    assert "[measurement.silhouette.camera_risk]" in stored
    assert config_from_toml(stored) == cfg and config_to_toml(config_from_toml(stored)) == stored
    # built in Python, the same values give the same config (lists and ints normalised)
    direct = SilhouetteConfig(method="mog2", min_area=12, shadow_brightness=[0.3, 0.9],
                              camera_risk={"BW1": 1e6, "C2": 3})
    assert TrackConfig(measurement=MeasurementConfig(silhouette=direct)) == cfg


def test_overrides_reach_nested_tables():
    base = with_overrides(TrackConfig(), **{"measurement.silhouette.min_area": 7})
    cfg = with_overrides(base, **{"measurement.silhouette.method": "mog2", "filter.layers": 2})
    assert cfg.measurement.silhouette.method == "mog2" and cfg.filter.layers == 2
    assert cfg.measurement.silhouette.min_area == 7  # the other settings are kept
    with pytest.raises(InputError, match=r"^options: key 'measurement\.silhouette\.method'"):
        with_overrides(cfg, **{"measurement.silhouette.method": "knn"})


def test_default_config_text_round_trips_exactly():
    text = config_to_toml(TrackConfig())
    assert config_to_toml(config_from_toml(text)) == text
    assert config_from_toml(text) == TrackConfig()


@pytest.mark.parametrize("kwargs, key", [
    ({"method": "magic"}, "method"),
    ({"risk": -1.0}, "risk"),
    ({"risk": True}, "risk"),
    ({"min_variance": 0.0}, "min_variance"),
    ({"camera_var_threshold": {"C1": float("nan")}}, "camera_var_threshold.C1"),
    ({"shadow_ncc": 2.0}, "shadow_ncc"),
    ({"open_radius": -1}, "open_radius"),
    ({"min_area": 2.5}, "min_area"),
])
def test_silhouette_config_built_directly_is_validated(kwargs, key):
    with pytest.raises(InputError, match=f"'measurement.silhouette.{key}'"):
        SilhouetteConfig(**kwargs)


def test_partial_file_keeps_defaults(tmp_path):
    path = tmp_path / "cfg.toml"
    path.write_text("[filter]\nparticles = 200\n")
    cfg = load_config(path)
    assert cfg.filter.particles == 200 and cfg.filter.layers == 6


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[filter]\nparticle = 200\n", "unknown key 'filter.particle'"),
        ("[filtre]\n", "unknown key 'filtre'"),
        ("[filter]\nparticles = 'many'\n", "'filter.particles' must be an integer"),
        ("[filter]\nparticles = 2.5\n", "'filter.particles' must be an integer"),
        ("[filter]\nstrategy = 'pso'\n", "'filter.strategy' must be one of"),
        ("[likelihood]\nvariances = [0.1, 0.1]\n", "must have 4 values"),
        ("[likelihood]\ncoverage = -1.0\n", r"'likelihood.coverage' must be >= 0, got -1\.0"),
        ("[likelihood]\ncoverage = inf\n", "'likelihood.coverage' must be finite"),
        ("[filter]\nlimb_sweep_gain = -0.5\n", "'filter.limb_sweep_gain' must be >= 0"),
        ("[filter]\nlimb_sweep_gain = nan\n", "'filter.limb_sweep_gain' must be"),
        ("[filter]\nlimb_sweep_max_hull = 0\n", "'filter.limb_sweep_max_hull' must be > 0"),
        ("[filter]\nlimb_sweep_samples = 1\n", "'filter.limb_sweep_samples' must be >= 2"),
        ("[init]\nprevious_pass_start = 1\n", r"'init\.previous_pass_start' must be 0 \(never\) or >= 2"),
        ("[init]\nprevious_pass_start = -3\n", r"'init\.previous_pass_start' must be 0 \(never\) or >= 2"),
        ("[measurement]\nvoxel_size = -5\n",
         r"key 'measurement\.voxel_size' must be between 1 and 250 mm, got -5"),
        ("[measurement]\nvoxel_size = 1e9\n", r"'measurement\.voxel_size' .* got 1e\+09"),
        ("[measurement]\nvoxel_size = 0.5\n", "'measurement.voxel_size' must be between"),
        ("[measurement]\nvoxel_size = 251\n", "'measurement.voxel_size' must be between"),
        ("[measurement]\nsurface_sigma = 0\n", "'measurement.surface_sigma' must be > 0"),
        ("[measurement]\nsurface_sigma = 50.0\n", "'measurement.surface_sigma' must be > 0 and <= 10"),
        ("[measurement]\nbackground_frames = 0\n", "'measurement.background_frames' must be >= 1"),
        ("[measurement]\nmin_views = 0\n", "'measurement.min_views' must be >= 1"),
        ("[measurement]\ngrid_origin = [0.0, 0.0, 0.0]\ngrid_shape = [100, 100, 2]\n",
         r"'measurement\.grid_shape' must be at least 8 voxels along every axis, got \[100, 100, 2\]"),
        ("[filter]\nsurvival = 1.5\n", "survival"),
        ("[filter\n", "invalid TOML"),
        ("[measurement]\ngrid_shape = [10, 10, 10]\n", "go together"),
        ("[measurement.silhouette]\nrisky = 3\n", "unknown key 'measurement.silhouette.risky'"),
        ("[measurement.silhouette]\nrisk = 0\n", "'measurement.silhouette.risk' must be > 0"),
        ("[measurement.silhouette]\nmethod = 'knn'\n", "'measurement.silhouette.method' must be one"),
        ("[measurement.silhouette.camera_risk]\nBW1 = -2.0\n",
         "'measurement.silhouette.camera_risk.BW1' must be > 0"),
        ("[measurement.silhouette.camera_risk]\nBW1 = 'high'\n",
         "'measurement.silhouette.camera_risk.BW1' must be a number"),
        ("[measurement.silhouette]\ncamera_risk = 3\n",
         "'measurement.silhouette.camera_risk' must be a table"),
        ("[measurement.silhouette]\nshadow_brightness = [0.9, 0.5]\n", "shadow_brightness"),
        ("[measurement.silhouette]\nmog2_learning_rate = 2.0\n", "mog2_learning_rate"),
    ],
)
def test_bad_config_names_file_and_key(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as info:
        load_config(path)
    assert str(info.value).startswith(str(path))


def test_missing_config_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        load_config(tmp_path / "none.toml")


def test_config_that_is_not_utf8(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes("# réglages\n[filter]\nlayers = 3\n".encode("latin-1"))
    with pytest.raises(InputError, match="not UTF-8 text") as info:
        load_config(path)
    assert str(info.value).startswith(str(path))


def test_bool_is_not_an_integer():
    with pytest.raises(InputError, match="integer"):
        config_from_dict({"filter": {"layers": True}})


@pytest.mark.parametrize("text", ["[measurement]\nvoxel_size = 1e9\n", "[measurement]\nvoxel_size = 0\n"])
def test_absurd_voxel_size_stops_track_with_one_line(tiny_dataset, tmp_path, capsys, text):
    from voxelmocap.cli import main

    cfg = tmp_path / "cfg.toml"
    cfg.write_text(text)
    out = tmp_path / "run"
    assert main(["track", str(tiny_dataset), "--subject", "S1", "--sequence", "Walking_1",
                 "--frames", "1:2", "--no-progress", "--config", str(cfg), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{cfg}: key 'measurement.voxel_size' must be between" in err[0]
    assert not out.exists()


_VALID = config_to_toml(with_overrides(TrackConfig(), **{
    "measurement.grid_origin": (-2000.0, -2000.0, 0.0), "measurement.grid_shape": (200, 200, 110),
    "measurement.min_views": 5, "measurement.silhouette.camera_risk": {"BW1": 1e6}})).encode()


@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.integers(0, len(_VALID)), junk=st.binary(max_size=8))
def test_mutated_config_files_load_or_raise_input_error(tmp_path, cut, junk):
    path = tmp_path / "cfg.toml"
    path.write_bytes(_VALID[:cut] + junk + _VALID[cut + len(junk):])
    try:
        cfg = load_config(path)
    except InputError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
        return
    assert isinstance(cfg.measurement.silhouette, SilhouetteConfig)
    assert config_from_toml(config_to_toml(cfg)) == cfg


def test_export_section():
    from voxelmocap.config import ExportConfig

    cfg = config_from_toml('[export]\nformats = ["c3d"]\ncutoff_hz = 6.0\naxes = "y_up"\n')
    assert cfg.export == ExportConfig(formats=("c3d",), cutoff_hz=6.0, order=4, axes="y_up")
    assert config_from_toml(config_to_toml(cfg)) == cfg
    assert TrackConfig().export.formats == ("trc", "csv") and TrackConfig().export.cutoff_hz is None
    for text, message in [('formats = ["fbx"]', "unknown format 'fbx'"),
                          ("cutoff_hz = -1.0", "cutoff_hz' must be > 0"),
                          ("order = 3", "even integer"), ('axes = "z_up"', "must be one of")]:
        with pytest.raises(InputError, match=message):
            config_from_toml(f"[export]\n{text}\n")
