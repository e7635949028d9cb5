"""The fleet benchmark in parts: shared pieces, generate, scaling, fleet, sizing, report."""
