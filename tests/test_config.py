import pytest

from voxelmocap.config import (
    TrackConfig,
    config_from_dict,
    config_to_toml,
    load_config,
    with_overrides,
)
from voxelmocap.errors import InputError


def test_defaults_are_the_papers_working_point():
    cfg = TrackConfig()
    assert (cfg.filter.layers, cfg.filter.particles) == (6, 600)
    assert cfg.measurement.voxel_size == 20.0
    assert cfg.likelihood.variances == (0.01, 0.01, 0.1, 0.1)


def test_toml_round_trip(tmp_path):
    cfg = with_overrides(TrackConfig(), **{"filter.layers": 3, "measurement.min_views": 6,
                                           "measurement.grid_shape": (10, 20, 30),
                                           "measurement.grid_origin": (-100.0, -200.0, 0.0)})
    path = tmp_path / "cfg.toml"
    path.write_text(config_to_toml(cfg))
    assert load_config(path) == cfg


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
        ("[measurement]\nvoxel_size = -5\n", "'voxel_size' must be > 0"),
        ("[filter]\nsurvival = 1.5\n", "survival"),
        ("[filter\n", "invalid TOML"),
        ("[measurement]\ngrid_shape = [10, 10, 10]\n", "go together"),
        ("[measurement.silhouette]\nrisky = 3\n", "unknown silhouette setting"),
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
