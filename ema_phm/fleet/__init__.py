"""A fleet: every unit's recordings diagnosed, tracked and ranked; results in a database.

`catalog` finds recordings and their windows, `store` keeps the results (SQLite or
PostgreSQL through SQLAlchemy), `unit_job` diagnoses a unit's windows in time order with the
live monitor's policy and tracker, `ingest` runs the units in parallel on Dask, `summary`
reads a store back as ranked units (`view`), `report` draws them as one HTML page and
`generate` makes a fleet of simulated units for tests and benchmarks.  No rclpy.
"""
