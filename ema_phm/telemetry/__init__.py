"""What travels on the wire and in bags.

- `wire`: every topic name, message type and message layout; encode and decode.
- `window`: `Window` (one stretch of telemetry) and its channel layout `CHANNELS`.
- `bags`: rosbag2/MCAP writing, recording and reading.
- `bag_recovery`: reading and rebuilding a recording that was killed mid-write.
- `recording`: opening the monitor's recording at a path the user names.
- `window_assembler`: cutting a stream of telemetry messages into windows.
- `window_intake`: telemetry and run_info in, window events out (the monitor's front end).

Nothing here imports rclpy.
"""
