"""Health monitoring: fault detection and isolation on what the estimators report."""
