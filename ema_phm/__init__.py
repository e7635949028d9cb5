"""ema_phm: model-based fault isolation for aircraft electromechanical actuators.

- `errors`: every exception ema_phm raises on purpose.
- `limits`: allowed ranges of every user-settable number.
- `physics`, `telemetry`, `diagnosis`, `ros`, `tools`: subpackages (each lists its modules).

The library and CLI never import rclpy; only `ema_phm.ros` does.
"""

__version__ = "0.1.0"
