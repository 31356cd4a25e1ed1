"""nprl.envs.HandPendulum: gymnasium's own environment checker, seeds,
and the physics of the plant."""
import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")
from gymnasium.utils.env_checker import check_env  # noqa: E402

import nprl.envs  # noqa: E402
from nprl.envs import HandPendulum, from_upright  # noqa: E402


def test_gymnasiums_environment_checker_passes():
    check_env(HandPendulum(), skip_render_check=True)
    check_env(gym.make("nprl/HandPendulum-v0").unwrapped, skip_render_check=True)


def test_a_seed_fixes_the_noise_and_the_noise_has_the_robots_size():
    a, b = HandPendulum(), HandPendulum()
    oa, _ = a.reset(seed=3)
    ob, _ = b.reset(seed=3)
    np.testing.assert_array_equal(oa, ob)
    noise = np.array([a.step([0.0])[0] - a.state for _ in range(2000)])
    np.testing.assert_allclose(noise.std(axis=0), [0.005, 0.02, 0.002, 0.01], rtol=0.1)
    exact = HandPendulum(noise=False)
    obs, _ = exact.reset(seed=1)
    assert obs.tolist() == [0.0, 0.0, 0.0, 0.0]


def test_the_pendulum_swings_as_a_damped_pendulum():
    env = HandPendulum(noise=False, max_steps=10_000)
    env.reset(options={"state": [0.3, 0.0, 0.0, 0.0]})
    energy = lambda s: 0.5 * 0.6**2 * s[1] ** 2 + 9.81 * 0.6 * (1 - np.cos(s[0]))  # noqa: E731
    e0 = energy(env.state)
    angles = []
    for _ in range(600):
        env.step([0.0])
        angles.append(env.state[0])
    # damping b = 0.2/s: energy decays as exp(-b t) over 10 s, to about 13 %
    assert energy(env.state) / e0 == pytest.approx(np.exp(-0.2 * 10), rel=0.1)
    # small oscillations at sqrt(g / l)
    crossings = np.flatnonzero(np.diff(np.sign(angles)) != 0)
    period = 2 * np.mean(np.diff(crossings)) / 60
    assert period == pytest.approx(2 * np.pi / np.sqrt(9.81 / 0.6), rel=0.02)


def test_leaving_the_workspace_ends_the_episode():
    env = HandPendulum(noise=False)
    env.reset(seed=0)
    for k in range(200):
        _, reward, terminated, truncated, info = env.step([15.0])
        assert reward < 0
        if terminated:
            break
    assert terminated and abs(info["state"][2]) > 0.8
    assert from_upright(np.pi) == 0.0 and from_upright(0.0) == pytest.approx(np.pi)
