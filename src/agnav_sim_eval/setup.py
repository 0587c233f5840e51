from glob import glob

from setuptools import find_packages, setup

package_name = "agnav_sim_eval"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
    ],
    install_requires=["setuptools"],
    extras_require={"test": ["pytest"]},  # colcon test runs pytest (not unittest) for these
    zip_safe=True,
    maintainer="agnav developers",
    maintainer_email="dev@agnav.org",
    description=open("package.xml").read().split("<description>")[1].split("</description>")[0],
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "tractor_sim = agnav_sim_eval.sim_node:main",
        ],
    },
)
