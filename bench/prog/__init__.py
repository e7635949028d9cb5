"""The prognostics benchmark in parts: plan, isolate, score, report, rescore."""
