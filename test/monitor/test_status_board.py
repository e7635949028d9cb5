"""The status board: a fault shows over the cause before it, until a good input or a new cause."""

from __future__ import annotations

from ema_phm.monitor import status_texts
from ema_phm.monitor.outputs import Outputs
from ema_phm.monitor.status_board import StatusBoard
from ema_phm.monitor.status_cause import StatusCause


def _board() -> StatusBoard:
    return StatusBoard(lambda: status_texts.StatusContext(hardware_id="u1"))


def test_a_good_input_brings_back_the_cause_before_the_fault():
    board = _board()
    board.decide(StatusCause("waiting", reason="no window yet"), Outputs())
    board.fault("/ema/telemetry", "bad rows", Outputs())
    assert board.cause.kind == "fault"
    board.clear_fault()
    assert (board.cause.kind, board.cause.reason) == ("waiting", "no window yet")


def test_a_new_cause_after_a_fault_is_not_undone_by_a_later_good_input():
    """Found by review: a commissioning status after a fault was replaced by the older one."""
    board = _board()
    board.decide(StatusCause("waiting"), Outputs())
    board.fault("/ema/telemetry", "bad rows", Outputs())
    board.decide(StatusCause("commissioning", reason="kept 1 of 3"), Outputs())
    board.clear_fault()
    assert (board.cause.kind, board.cause.reason) == ("commissioning", "kept 1 of 3")
