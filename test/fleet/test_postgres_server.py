"""The private PostgreSQL server of the fleet tests: a real server, on 127.0.0.1 only."""

from __future__ import annotations

import sqlalchemy as sa


def test_a_double_round_trips_exactly_and_the_server_listens_on_loopback_only(
    postgres_db_url: str,
) -> None:
    engine = sa.create_engine(postgres_db_url)
    try:
        with engine.begin() as conn:
            conn.execute(
                sa.text("CREATE TABLE sample (id integer PRIMARY KEY, x double precision)")
            )
            conn.execute(sa.text("INSERT INTO sample VALUES (1, :x)"), {"x": 0.1 + 0.2})
        with engine.connect() as conn:
            x = conn.execute(sa.text("SELECT x FROM sample WHERE id = 1")).scalar_one()
            assert type(x) is float and x == 0.1 + 0.2 and x != 0.3
            assert conn.execute(sa.text("SHOW listen_addresses")).scalar_one() == "127.0.0.1"
            host = conn.execute(sa.text("SELECT host(inet_server_addr())")).scalar_one()
            assert host == "127.0.0.1"
            assert conn.execute(sa.text("SELECT current_database()")).scalar_one().startswith("t_")
    finally:
        engine.dispose()
