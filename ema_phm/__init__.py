"""ema_phm: model-based fault isolation for aircraft electromechanical actuators.

The library and CLI never import rclpy; only `ema_phm.ros` does.
"""

__version__ = "0.1.0"
