"""The monitor: one policy that turns a stream of windows into fits, a history and a prognosis."""
