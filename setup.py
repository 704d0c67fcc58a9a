"""ament_python package that also installs with pip (see README)."""
from glob import glob

from setuptools import find_packages, setup

package_name = "rotor_avc"

NODES = ["plant_simulator", "foot_controller", "synchronous_controller", "harmonic_controller",
         "balancer", "recorder"]   # rotor_avc/nodes

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*", "bench", "bench.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", sorted(glob("config/*.yaml"))),
        ("share/" + package_name + "/launch", sorted(glob("launch/*.launch.py"))),
        ("share/" + package_name + "/layouts",
         sorted(glob("layouts/*.json") + glob("layouts/*.xml"))),
    ],
    package_data={package_name: ["nodes/*.xml"]},   # the nodes' Fast DDS profile
    install_requires=[
        "setuptools",
        "numpy>=1.24",
        "scipy>=1.10",
        "PyYAML>=6",
        "matplotlib>=3.7",
        "mcap>=1.1",
        "zstandard",           # imported by rotor_avc.bag (also a dependency of mcap)
        "lz4",                 # imported by rotor_avc.bag.mcap_writer (also one of mcap)
        "plotly>=5",             # its bundled plotly.js, embedded in the interactive reports
        "pyuff>=2.4",            # UFF type 58 export of the comparison's FRFs (rotor_avc.reports)
    ],
    extras_require={
        # ROS 2 Jazzy from PyPI (not needed inside a colcon workspace, where the distro provides it)
        "ros": ["ros-jazzy-rclpy[fastrtps]", "ros-jazzy-common-interfaces"],
        # studies on a Dask cluster (`--scheduler`); local studies need nothing beyond the core
        "cluster": ["distributed>=2024.1"],
        "test": ["pytest>=7", "pytest-timeout", "rosbags>=0.10", "mcap-ros2-support>=0.5",
                 "control>=0.10", "catkin_pkg", "jsonschema>=4.18",
                 "colcon-core", "colcon-ros", "colcon-python-setup-py", "distributed>=2024.1"],
    },
    zip_safe=True,
    maintainer="rotor_avc developers",
    maintainer_email="rotor-avc@example.org",
    description="Active vibration control of rotating machines (ROS 2 nodes over a numpy/scipy core)",
    license="Apache-2.0",
    entry_points={
        "console_scripts": ["rotor-avc = rotor_avc.cli:main"]
        + [f"{node} = rotor_avc.nodes.{node}:main" for node in NODES],
    },
)
