"""The navigation backends behind NavigationPipeline, chosen by the `estimator` parameter: NavSensorModule for
`agnav`/`thesis`, the GNSS/INS InsNavigation for `ins`, each with its own settings dataclass as parameters. ROS-free:
nav_sensor_module_node declares these settings, the offline replay applies a config's parameters to them."""
from typing import NamedTuple

from agnav_common.parameters import apply

from agnav_fusion.nav_ins import SKIP as INS_SKIP, InsNavigation, InsNavSettings
from agnav_fusion.nav_sensor_module import MOUNTS, NavSensorModule, NavSensorModuleSettings
from agnav_fusion.pipeline import FrontEndSettings, NavigationPipeline


class Backend(NamedTuple):
    make: type          # the backend, built from its settings
    settings: type      # its settings dataclass: the backend's parameters
    skip: tuple         # settings fields that are not parameters (mounts from TF, ...)


_NSM = Backend(NavSensorModule, NavSensorModuleSettings, MOUNTS + ("estimator",))
BACKENDS = {"agnav": _NSM, "thesis": _NSM, "ins": Backend(InsNavigation, InsNavSettings, INS_SKIP)}
ESTIMATOR_DOC = "agnav (attitude KF + nav EKF) | thesis (attitude LSM + Kise/drift LSM + DR) | ins (GNSS/INS EKF)"


def settings_for(estimator):
    """[(settings, fields that are not parameters)] of the pipeline of `estimator`: front end, backend."""
    if estimator not in BACKENDS:
        raise ValueError(f"estimator must be one of {', '.join(BACKENDS)}, not {estimator!r}")
    backend = BACKENDS[estimator].settings()
    if hasattr(backend, "estimator"):
        backend.estimator = estimator
    return [(FrontEndSettings(), ()), (backend, BACKENDS[estimator].skip)]


def make_backend(estimator, settings):
    return BACKENDS[estimator].make(settings)


def pipeline_from_parameters(params, estimator="agnav"):
    """The NavigationPipeline the navigation node builds from the parameters {name: value} (`estimator`: the
    default when params name none); missing parameters keep their defaults."""
    estimator = params.get("estimator", estimator)
    (front, _), (backend, _) = settings_for(estimator)
    return NavigationPipeline(make_backend(estimator, apply(backend, params)), apply(front, params))
