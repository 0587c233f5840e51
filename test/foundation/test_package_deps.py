"""Every package.xml declares the rosdep keys of what its Python imports, so `rosdep install --from-paths src`
leaves no ImportError on a full ROS install; agnav packages import only the layers below them."""
import ast
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src"
PYTHON_PACKAGES = sorted(p.parent.name for p in SRC.glob("*/setup.py"))

# import name -> rosdep key (rosdistro rosdep/python.yaml; `-pip` keys where no Debian package exists)
IMPORT_KEYS = {
    "numpy": "python3-numpy", "scipy": "python3-scipy", "yaml": "python3-yaml", "serial": "python3-serial",
    "matplotlib": "python3-matplotlib", "tqdm": "python3-tqdm", "pymap3d": "python3-pymap3d",
    "pynmea2": "python3-pynmea2", "pytest": "python3-pytest", "hypothesis": "python3-hypothesis",
    "rosbags": "python3-rosbags-pip", "pyubx2": "python3-pyubx2-pip", "ahrs": "python3-ahrs-pip",
    # not in rosdistro yet (NO_UPSTREAM_KEY): pip-style keys, skipped by the README's rosdep command
    "pygeomag": "python3-pygeomag-pip", "pyrtklib": "python3-pyrtklib-pip", "imufusion": "python3-imufusion-pip",
    "cssrlib": "python3-cssrlib-pip", "pyrtcm": "python3-pyrtcm-pip",
}
NO_UPSTREAM_KEY = {"pygeomag", "pyrtklib", "imufusion", "cssrlib", "pyrtcm"}
# ROS packages whose Python module is the package (and rosdep key) name
ROS_MODULES = {"rclpy", "rcl_interfaces", "builtin_interfaces", "std_srvs", "launch", "launch_ros"}
# keys a package needs without importing them: run-time executables and interface runtime
NOT_IMPORTED = {"agnav_bringup": {"tf2_ros", "agnav_drivers", "agnav_fusion", "agnav_control"}}  # their nodes run
# agnav packages each layer may import (besides itself and agnav_msgs)
LAYERS = {"agnav_common": set(), "agnav_drivers": {"agnav_common"}, "agnav_fusion": {"agnav_common"},
          "agnav_control": {"agnav_common"},
          "agnav_bringup": {"agnav_common", "agnav_drivers", "agnav_fusion", "agnav_control"},
          "agnav_sim_eval": {"agnav_common", "agnav_drivers", "agnav_fusion", "agnav_control", "agnav_bringup"}}
# the agnav CLI (agnav_bringup) imports the simulator, evaluator and benchmarks on use, when installed
OPTIONAL_IMPORTS = {("agnav_bringup", "agnav_sim_eval")}


def imported_modules(path):
    """Top-level names of the absolute imports in one file (also inside functions)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def rosdep_key(module):
    if module in IMPORT_KEYS:
        return IMPORT_KEYS[module]
    if module in ROS_MODULES or module.startswith("agnav_") or module.endswith(("_msgs", "_srvs")):
        return module
    return None


def declared(package):
    root = ET.parse(SRC / package / "package.xml").getroot()
    keys = {tag: {e.text.strip() for e in root.findall(tag)} for tag in ("depend", "exec_depend", "test_depend")}
    return keys["depend"] | keys["exec_depend"], keys["test_depend"]


def third_party(files, local=()):
    """{module: first file importing it} for the non-stdlib, non-local imports of `files`."""
    found = {}
    for f in files:
        for m in imported_modules(f) - set(sys.stdlib_module_names) - set(local):
            found.setdefault(m, f.relative_to(SRC))
    return found


def runtime_files(package):
    files = [f for f in (SRC / package / package).rglob("*.py") if f.name != "testing.py"]
    return files + sorted((SRC / package / "launch").glob("*.py"))


def test_every_ament_python_package_is_checked():
    assert PYTHON_PACKAGES == sorted(LAYERS)


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_runtime_imports_are_exec_depends(package):
    exec_keys, _ = declared(package)
    imports = third_party(runtime_files(package), local=[package] + [m for p, m in OPTIONAL_IMPORTS if p == package])
    unknown = {m: str(f) for m, f in imports.items() if rosdep_key(m) is None}
    assert not unknown, f"imports without a rosdep key in IMPORT_KEYS: {unknown}"
    missing = {rosdep_key(m): str(f) for m, f in imports.items() if rosdep_key(m) not in exec_keys}
    assert not missing, f"{package}/package.xml lacks <exec_depend> for {missing}"
    needed = {rosdep_key(m) for m in imports} | NOT_IMPORTED.get(package, set())
    unused = {k for k in exec_keys - needed if k.startswith("agnav_") or k in IMPORT_KEYS.values()}
    assert not unused, f"{package}/package.xml declares dependencies its code does not import: {unused}"


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_test_imports_are_declared(package):
    exec_keys, test_keys = declared(package)
    test_dir = SRC / package / "test"
    files = sorted(test_dir.glob("*.py")) + sorted((SRC / package / package).glob("testing.py"))
    local = [f.stem for f in test_dir.glob("*.py")] + [package]
    imports = third_party(files, local)
    assert all(rosdep_key(m) for m in imports), f"unknown test imports: {sorted(imports)}"
    missing = {rosdep_key(m): str(f) for m, f in imports.items() if rosdep_key(m) not in exec_keys | test_keys}
    assert not missing, f"{package}/package.xml lacks <test_depend> for {missing}"


def test_readme_rosdep_command_skips_exactly_the_keys_rosdistro_lacks():
    readme = (SRC.parent / "README.md").read_text()
    skipped = readme.split('--skip-keys "')[1].split('"')[0].split()
    assert sorted(skipped) == sorted(IMPORT_KEYS[m] for m in NO_UPSTREAM_KEY)
    pip_line = next(line for line in readme.splitlines() if line.startswith("pip install pygeomag"))
    pins = dict(line.split("==") for name in ("requirements.txt", "requirements-nodeps.txt")
                for line in (SRC.parent / name).read_text().split() if "==" in line)
    assert sorted(pip_line.split("#")[0].split()[2:]) == sorted(f"{m}=={pins[m]}" for m in NO_UPSTREAM_KEY)


def test_agnav_layers():
    violations = set()
    for package in PYTHON_PACKAGES:
        for m in third_party(runtime_files(package), local=[package]):
            if m.startswith("agnav_") and m != "agnav_msgs" and m not in LAYERS[package]:
                violations.add((package, m))
    assert violations == OPTIONAL_IMPORTS


def test_ros_interface_package_declares_its_generators():
    root = ET.parse(SRC / "agnav_msgs" / "package.xml").getroot()
    assert root.find("export/build_type").text == "ament_cmake"
    assert {e.text for e in root.findall("buildtool_depend")} >= {"ament_cmake", "rosidl_default_generators"}
    assert "rosidl_default_runtime" in {e.text for e in root.findall("exec_depend")}
