"""The paper's pendulum swing-up robot as a gymnasium environment (needs
``gymnasium``: ``pip install nprl[envs]``).

Registered as ``"nprl/HandPendulum-v0"`` on import::

    import gymnasium as gym
    import nprl.envs
    env = gym.make("nprl/HandPendulum-v0")
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

try:
    import gymnasium as gym
    from gymnasium import spaces
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError("nprl.envs needs gymnasium: pip install 'nprl[envs]'") from e

from . import _nprl


def from_upright(theta: float) -> float:
    """``theta - pi`` wrapped into (-pi, pi]: the angle from upright."""
    d = (theta - math.pi) % (2 * math.pi)
    return d - 2 * math.pi if d > math.pi else d


class HandPendulum(gym.Env):
    """A pendulum hanging from a hand that moves horizontally: the robot of
    the paper's swing-up (Atkeson and Schaal 1997), simulated in Rust
    (``swingup::plant``: RK4, 10 substeps per 60 Hz sample).

    - State ``(theta, theta_dot, x, x_dot)``: ``theta = 0`` hanging down,
      ``pi`` upright; ``x`` the hand's position (m).
    - Action: the commanded hand acceleration (m/s^2), clipped to
      ``[-u_limit, u_limit]`` (15).
    - Observation: the state plus the robot's Gaussian sensor noise (standard
      deviations ``sensor_noise``: 0.005 rad, 0.02 rad/s, 0.002 m,
      0.01 m/s), drawn from the environment's ``np_random`` (seeded by
      ``reset(seed=...)``); ``noise=False`` observes the state exactly.
    - Reward: ``-(a^2 + 0.1 theta_dot^2 + x^2 + 0.001 u^2)`` with ``a`` the
      angle from upright.
    - Terminated when the hand leaves its workspace ``|x| > x_limit``
      (0.8 m); truncated after ``max_steps`` samples (330: the paper's
      2.5 s swing-up window and 3 s of balancing).
    - ``info["upright_seconds"]``: how long the pendulum has stayed within
      0.2 rad of upright; the swing-up succeeds at 2 s.

    Parameters
    ----------
    plant : {"robot", "human"}
        The robot (l = 0.6 m, b = 0.2/s) or the demonstrating human
        (l = 0.5 m, b = 0.05/s).
    lag : float
        The hand's time constant (s) in following its command; 0 for none.
    noise : bool
        Whether observations carry the sensor noise.
    max_steps : int
        Samples before truncation.
    """

    metadata = {"render_modes": []}

    def __init__(self, plant: str = "robot", lag: float = 0.0, noise: bool = True, max_steps: int = 330):
        self._plant = _nprl.Plant(plant, lag)
        params = self._plant.params()
        self.dt = params["dt"]
        self.x_limit = params["x_limit"]
        self.u_limit = params["u_limit"]
        self.sensor_noise = np.asarray(_nprl.sensor_noise()) if noise else np.zeros(4)
        self.max_steps = int(max_steps)
        self.action_space = spaces.Box(-self.u_limit, self.u_limit, shape=(1,), dtype=np.float64)
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(4,), dtype=np.float64)
        self.state = np.zeros(4)
        self._a = 0.0
        self._steps = 0
        self._upright = 0

    def _observe(self) -> np.ndarray:
        return self.state + self.sensor_noise * self.np_random.standard_normal(4)

    def _info(self) -> dict:
        return {"state": self.state.copy(), "upright_seconds": self._upright * self.dt}

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        """Hanging at rest, the hand at the origin (``options["state"]``
        starts elsewhere)."""
        super().reset(seed=seed)
        start = None if options is None else options.get("state")
        self.state = np.zeros(4) if start is None else np.asarray(start, dtype=float).copy()
        self._a, self._steps, self._upright = 0.0, 0, 0
        return self._observe(), self._info()

    def step(self, action):
        u = float(np.clip(np.asarray(action, dtype=float).reshape(-1)[0], -self.u_limit, self.u_limit))
        s, self._a = self._plant.step(tuple(self.state), self._a, u)
        self.state = np.asarray(s)
        self._steps += 1
        a = from_upright(self.state[0])
        self._upright = self._upright + 1 if abs(a) < 0.2 else 0
        reward = -(a * a + 0.1 * self.state[1] ** 2 + self.state[2] ** 2 + 0.001 * u * u)
        terminated = bool(abs(self.state[2]) > self.x_limit)
        truncated = self._steps >= self.max_steps
        return self._observe(), float(reward), terminated, truncated, self._info()


if "nprl/HandPendulum-v0" not in gym.registry:
    gym.register(id="nprl/HandPendulum-v0", entry_point=HandPendulum)
