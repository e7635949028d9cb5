"""Recordings from other systems into ema_phm's own: a channel map and `ema-phm import`.

- `channel_map`: the YAML file saying where each monitor channel comes from (format:
  docs/your_recordings.md);
- `units`: the units a map may name and their conversion to the monitor's SI units;
- `sources`: time series read from ROS 2 bags (MCAP, sqlite3) and tables (CSV, Parquet);
- `derive`: the channels computed from others (equivalent current, speed, motor angle);
- `resample`: series onto the actuator's sample grid, split at gaps;
- `segments`: where the windows are (a time list, a marker, the excitation, a length);
- `importer`: all of it, writing one-window recordings that every command reads.
"""
