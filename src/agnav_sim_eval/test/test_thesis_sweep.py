"""`agnav bench thesis_sweep` scales one parameter of config nsm and keeps every other one (a variant built from the
settings class's defaults replaced the config's receiver-bias and jerk settings with them)."""
from agnav_sim_eval import offline
from agnav_sim_eval.bench.module_runs import NSM
from agnav_sim_eval.bench.thesis_sweep import SCALED, variants


def test_each_variant_scales_one_config_parameter_and_keeps_the_others():
    base = offline.pipeline_for(NSM).backend.settings
    runs = variants()
    for path in SCALED:
        for factor in (0.5, 2.0):
            overrides = runs[f"{path} x{factor:g}"]
            assert list(overrides) == [path]
            settings = offline.pipeline_for(NSM, **overrides).backend.settings
            for other in SCALED:
                value, expected = settings, base
                for part in other.split("."):
                    value, expected = getattr(value, part), getattr(expected, part)
                assert value == (factor * expected if other == path else expected)
            assert settings.ekf.gnss_bias_tau == base.ekf.gnss_bias_tau > 0
