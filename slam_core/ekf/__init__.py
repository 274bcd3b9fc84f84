"""Landmark EKF SLAM: state, extraction, association and the estimator."""
