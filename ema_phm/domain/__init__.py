"""The floor every other part stands on: what k's entries and the telemetry's channels mean."""
