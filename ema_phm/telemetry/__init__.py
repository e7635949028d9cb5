"""What travels on the wire and in bags.

- `wire`: every topic name, message type and message layout; encode and decode.
- `window`: `Window` (one stretch of telemetry) and its channel layout `CHANNELS`.
- `bags`: rosbag2/MCAP writing, recording and reading.
- `bag_recovery`: reading and rebuilding a recording that was killed mid-write.
- `window_assembler`: cutting a stream of telemetry messages into windows.

Nothing here imports rclpy.
"""
