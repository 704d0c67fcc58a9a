"""rotor_avc: active vibration control of rotating machines.

The core (models, control, balancing, sim, analysis, bag) is pure numpy/scipy; only
``rotor_avc.nodes`` imports rclpy.
"""

__version__ = "0.1.0"
