"""Graph configs: every malformed file is one clear ConfigError (file, line or key, what is expected)."""
import pytest

from agnav_bringup.graph_config import ConfigError, available_configs, load_config


def write(tmp_path, text):
    path = tmp_path / "graph.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("text,expected", [
    ("nodes:\n  - {executable: bag_recorder\n", r"graph\.yaml:3:1: YAML syntax error"),
    ("nodes:\n  - executable: a\n   name: b\n", r"graph\.yaml:3:\d+: YAML syntax error"),
    ("nodez: []\n", r"unknown key 'nodez'; did you mean 'nodes'\?"),
    ("nodes:\n  - {executable: x, paramters: {a: 1}}\n", r"unknown key 'nodes\[0\]\.paramters'; did you mean 'parameters'"),
    ("nodes: {executable: x}\n", r"'nodes' must be a list"),
    ("nodes: [bag_recorder]\n", r"nodes\[0\] must be a map"),
    ("nodes:\n  - {name: x}\n", r"nodes\[0\]: missing 'executable'"),
    ("nodes:\n  - {executable: x, parameters: [a, b]}\n", r"'nodes\[0\]\.parameters' must be a map"),
    ("record: /odometry/filtered\n", r"'record' must be a list of topic names"),
    ("use_sim_time: yes please\n", r"'use_sim_time' must be true or false"),
    ("static_transforms:\n  - {parent: base_link, child: imu_link, xyz: [0, 0]}\n",
     r"'static_transforms\[0\]\.xyz' must be \[x, y, z\]"),
    ("- just\n- a list\n", r"the file must be a map of keys"),
])
def test_malformed_config_is_one_clear_error(tmp_path, text, expected):
    with pytest.raises(ConfigError, match=expected) as info:
        load_config(write(tmp_path, text))
    assert str(tmp_path / "graph.yaml") in str(info.value) and "\n" not in str(info.value)


def test_nested_parameters_become_dotted_names(tmp_path):
    config = load_config(write(tmp_path, "use_sim_time: true\nnodes:\n  - executable: x\n"
                                         "    parameters: {roll_kf: {tau: 1.1, incl_noise: 0.02}, gate: 3}\n"))
    assert config.nodes[0].parameters == {"roll_kf.tau": 1.1, "roll_kf.incl_noise": 0.02, "gate": 3}
    assert config.use_sim_time is True and config.nodes[0].label == "x"


def test_every_bundled_config_loads():
    names = available_configs()
    assert {"nsm", "replay", "steer"} <= set(names)
    for name in names:
        assert load_config(name).path.stem == name


def test_missing_config_names_the_bundled_ones():
    with pytest.raises(ConfigError, match="config 'no_such' not found; bundled: .*nsm"):
        load_config("no_such")
