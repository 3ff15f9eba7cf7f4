"""State and fault estimation: the EKF (:mod:`.ekf`, model in :mod:`.ekf_model`) and the
Two-Stage Kalman Filter (:mod:`.tskf`, model in :mod:`.tskf_model`) on one state layout
(:mod:`.state`) and one frame (:mod:`.estimator`); built by name through :mod:`.registry`."""
