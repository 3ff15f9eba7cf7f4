"""State and fault estimation: the EKF and the Two-Stage Kalman Filter on one state layout."""
