"""The navigation backends behind NavigationPipeline, chosen by the `estimator` parameter: NavSensorModule for
`agnav`/`thesis`, the GNSS/INS InsNavigation for `ins`, its loose / tight / INS-only switching InsTightNavigation for
`ins_tight`, each with its own settings dataclass as parameters. Only the chosen estimator's module is imported (the
INS and raw-GNSS modules pull in scipy and cssrlib: seconds of start-up). ROS-free: nav_sensor_module_node declares
these settings, the offline replay applies a config's parameters to them."""
import importlib
from typing import NamedTuple

from agnav_common.parameters import apply

from agnav_fusion.pipeline import FrontEndSettings, NavigationPipeline


class Backend(NamedTuple):
    module: str         # the module that holds the backend
    make: str           # the backend class, built from its settings
    settings: str       # its settings dataclass: the backend's parameters
    skip: str           # the module's tuple of settings fields that are not parameters (mounts from TF, ...)
    skip_extra: tuple = ()

    def load(self):
        """(backend class, settings class, fields that are not parameters)."""
        module = importlib.import_module(self.module)
        return (getattr(module, self.make), getattr(module, self.settings),
                getattr(module, self.skip) + self.skip_extra)


_NSM = Backend("agnav_fusion.nav_sensor_module", "NavSensorModule", "NavSensorModuleSettings", "MOUNTS",
               ("estimator",))
BACKENDS = {"agnav": _NSM, "thesis": _NSM,
            "ins": Backend("agnav_fusion.nav_ins", "InsNavigation", "InsNavSettings", "SKIP"),
            "ins_tight": Backend("agnav_fusion.nav_ins_tight", "InsTightNavigation", "InsTightSettings", "SKIP")}
ESTIMATOR_DOC = ("agnav (attitude KF + nav EKF) | thesis (attitude LSM + Kise/drift LSM + DR) | ins (GNSS/INS EKF) | "
                 "ins_tight (GNSS/INS switching loose / tight on raw observations / INS only)")


def settings_for(estimator):
    """[(settings, fields that are not parameters)] of the pipeline of `estimator`: front end, backend."""
    if estimator not in BACKENDS:
        raise ValueError(f"estimator must be one of {', '.join(BACKENDS)}, not {estimator!r}")
    _, settings, skip = BACKENDS[estimator].load()
    backend = settings()
    if hasattr(backend, "estimator"):
        backend.estimator = estimator
    return [(FrontEndSettings(), ()), (backend, skip)]


def make_backend(estimator, settings):
    return BACKENDS[estimator].load()[0](settings)


def pipeline_from_parameters(params, estimator="agnav"):
    """The NavigationPipeline the navigation node builds from the parameters {name: value} (`estimator`: the
    default when params name none); missing parameters keep their defaults."""
    estimator = params.get("estimator", estimator)
    (front, _), (backend, _) = settings_for(estimator)
    return NavigationPipeline(make_backend(estimator, apply(backend, params)), apply(front, params))
