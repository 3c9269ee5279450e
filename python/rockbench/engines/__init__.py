"""Engines written in Python, run by the Rust harness as worker processes
(``python -m rockbench.worker``): ``mujoco_engine`` and ``pybullet_engine``."""

__all__ = ["common", "mujoco_engine", "pybullet_engine"]
