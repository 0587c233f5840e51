"""What a recording holds: /tf in every bundled record list."""
import pytest

from agnav_bringup.graph_config import CONFIG_DIRS, load_config

BUNDLED = sorted(p.stem for p in CONFIG_DIRS[0].glob("*.yaml"))


@pytest.mark.parametrize("name", BUNDLED)
def test_bundled_configs_record_tf(name):
    record = load_config(name).record
    assert not record or "/tf" in record
