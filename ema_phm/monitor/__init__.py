"""The monitor: one policy that turns a stream of windows into fits, a history and a prognosis.

- `estimator` / `predictor`: the interfaces (`Estimator.fit`, `Predictor.predict`) and their
  defaults (`IsolationEstimator`: `isolation.isolate`; `RulPredictor`: `rul.prognose`);
- `policy`: `FitPolicy`, when to track or restart a fit and which windows count
  (`window_rule`), the estimates (`estimates`) and the prognosis after each counted window;
- `health_monitor`: `HealthMonitor`, the live monitor (no rclpy), over `state`,
  `window_scheduler`, `job_queue`, `status_board` (its texts: `status_texts`, `status_cause`),
  `commissioning_guard`, `result_log`; `tracker`: its prognosis and alarm;
- `replay`: the same policy offline (`ema-phm prognose`); the scores against the truth are
  `ema_phm.evaluation`'s, beside the monitor.
"""
