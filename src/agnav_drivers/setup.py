from glob import glob

from setuptools import find_packages, setup

package_name = "agnav_drivers"

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
            "bag_player = agnav_drivers.bag_player_node:main",
            "bag_recorder = agnav_drivers.bag_recorder_node:main",
            "nmea_gnss_node = agnav_drivers.nmea_gnss_node:main",
            "ubx_gnss_node = agnav_drivers.ubx_gnss_node:main",
            "rtcm_base_node = agnav_drivers.rtcm_base_node:main",
            "adc_sensor_node = agnav_drivers.adc_sensor_node:main",
            "agnav_csv_import = agnav_drivers.csv_import:main",
        ],
    },
)
