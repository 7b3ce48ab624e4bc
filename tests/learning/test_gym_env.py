"""The Gymnasium environment: API conformance, masks, rewards, abandonment, determinism, registration."""

import shutil
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from learning.gym_env import ROOT, register_envs
from learning.reward import step_reward


def make(env_id="AnticipatoryMinimal-grid-v0", **kw):
    return gym.make(env_id, **kw).unwrapped


@pytest.mark.parametrize("env_id", ["AnticipatoryMinimal-grid-v0", "AnticipatoryRestaurant-two-room-v0"])
def test_check_env_passes(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning either
        check_env(gym.make(env_id).unwrapped)


@pytest.mark.parametrize("kw", [{"factored": True}, {"observation": "multibinary"}, {"horizon": "myopic"}])
def test_check_env_passes_for_the_options(kw):
    check_env(make(**kw))


def test_ids_are_registered_for_every_bundled_layout():
    ids = register_envs()
    assert (
        {
            "AnticipatoryRestaurant-two-room-v0",
            "AnticipatoryRestaurant-three-room-v0",
            "AnticipatoryMinimal-grid-v0",
            "Anticipatory-v0",
        }
        <= set(ids)
        <= set(gym.registry)
    )


def test_any_domain_folder_by_path(tmp_path):
    folder = tmp_path / "my-grid"
    shutil.copytree(ROOT / "domains" / "minimal", folder)
    env = gym.make("Anticipatory-v0", domain=str(folder), layout="grid").unwrapped
    obs, info = env.reset(seed=3)
    assert env.model.name == "minimal" and obs.shape == env.observation_space.shape
    assert info["task"] == "clear(c)"


def masked_rollout(env, steps, seed):
    """Random masked actions; yields (mask before, action, step result)."""
    rng = np.random.default_rng(seed)
    obs, info = env.reset(seed=seed)
    for _ in range(steps):
        mask = info["action_mask"]
        a = int(rng.choice(np.flatnonzero(mask)))
        out = env.step(a)
        yield mask, a, out
        obs, _, term, trunc, info = out
        if term or trunc:
            obs, info = env.reset()


@pytest.mark.parametrize("env_id", ["AnticipatoryMinimal-grid-v0", "AnticipatoryRestaurant-two-room-v0"])
def test_mask_is_the_applicable_actions(env_id):
    env = make(env_id)
    obs, info = env.reset(seed=0)
    for _ in range(300):
        expected = np.zeros(env.model.n_actions, dtype=np.int8)
        expected[env.model.applicable(env.state)] = 1
        assert info["action_mask"].dtype == np.int8
        assert np.array_equal(info["action_mask"], expected)
        assert np.array_equal(env.action_masks(), expected.astype(bool))
        a = int(np.flatnonzero(expected)[len(obs) % int(expected.sum())])
        obs, _, term, trunc, info = env.step(a)
        assert not info["invalid"]
        if term or trunc:
            obs, info = env.reset()


def test_factored_heads_masks_and_actions():
    env = make("AnticipatoryRestaurant-two-room-v0", factored=True)
    obs, info = env.reset(seed=1)
    rng = np.random.default_rng(1)
    for _ in range(100):
        applicable = env.model.applicable(env.state)
        labels = env.labels[applicable]
        for h, m in enumerate(info["head_masks"]):
            assert set(np.flatnonzero(m)) == set(labels[:, h].tolist())
        assert np.array_equal(info["action_mask"], np.concatenate(info["head_masks"]))
        a = int(rng.choice(applicable))
        before = env.state
        obs, _, term, trunc, info = env.step(env.labels[a])  # the ground action's label
        assert not info["invalid"]
        assert env.state == env.model.apply(before, a) or info["completed"] or info["finished"]
        if term or trunc:
            obs, info = env.reset()


def test_reward_of_known_steps():
    env = make("AnticipatoryRestaurant-two-room-v0")
    obs, info = env.reset(seed=0)
    a = int(np.flatnonzero(info["action_mask"])[0])
    cost = env.model.action_cost[a]
    _, r, _, _, info = env.step(a)
    assert not info["completed"] and r == pytest.approx(-cost / 100)  # cost_scale 100
    assert info["task_cost"] == cost and info["task_actions"] == 1
    # The minimal grid: clear(c) by the optimal plan; its last action earns -1 + 10.
    from planning.domain.batched import BatchedModel
    from planning.search.optimal import optimal_plan

    env = make()
    env.reset(seed=5)
    plan = optimal_plan(BatchedModel(env.model), env.state, env.task).plan
    rewards = [env.step(a)[1:] for a in plan]
    assert [r for r, *_ in rewards[:-1]] == [-1.0] * (len(plan) - 1)
    r, term, trunc, info = rewards[-1]
    assert info["completed"] and info["finished"] == {
        "task": "clear(c)",
        "cost": len(plan),
        "actions": len(plan),
        "success": True,
    }
    assert r == step_reward(1, True, 1.0, 10.0) + 10.0 * len(info["auto_completed"])
    assert term == bool(info["auto_completed"])  # a delivery already done ends the 2-task episode


def test_invalid_action_is_a_penalised_no_op():
    env = make("AnticipatoryRestaurant-two-room-v0")
    obs, info = env.reset(seed=0)
    bad = int(np.flatnonzero(info["action_mask"] == 0)[0])
    state = env.state
    obs2, r, term, trunc, info = env.step(bad)
    assert info["invalid"] and env.state == state and np.array_equal(obs, obs2)
    assert r == -env.invalid_penalty == -max(env.model.action_cost) / 100
    assert info["task_cost"] == 0 and info["task_actions"] == 1


def moves_only(env):
    return int(next(a for a in np.flatnonzero(env.action_masks()) if env.model.actions[a].startswith("move(")))


@pytest.mark.parametrize("horizon", ["anticipatory", "myopic"])
def test_a_task_is_abandoned_after_64_actions(horizon):
    env = make(horizon=horizon)  # minimal grid: moving never clears C
    obs, info = env.reset(seed=0)
    for k in range(64):
        obs, r, term, trunc, info = env.step(moves_only(env))
        if k < 63:
            assert not (info["abandoned"] or term or trunc) and info["task_actions"] == k + 1
    assert info["abandoned"] and not info["completed"]
    assert info["finished"] == {"task": "clear(c)", "cost": 64, "actions": 64, "success": False}
    if horizon == "myopic":
        assert trunc and not term  # each task its own episode
    else:
        assert not (term or trunc) and info["task"].startswith("deliver(")  # the episode goes on
        assert info["task_actions"] == 0 and info["tasks_done"] == 1
        for _ in range(64):
            obs, r, term, trunc, info = env.step(moves_only(env))
        assert info["abandoned"] and term and not trunc  # the 2-task episode ends, terminal by domain.toml


def test_invalid_actions_count_toward_the_budget():
    env = make()
    obs, info = env.reset(seed=0)
    bad = int(np.flatnonzero(info["action_mask"] == 0)[0])
    for _ in range(64):
        obs, r, term, trunc, info = env.step(bad)
    assert info["abandoned"] and info["finished"]["cost"] == 0


def test_block_end_truncates_in_the_restaurant():
    env = make("AnticipatoryRestaurant-two-room-v0", tasks_per_reset=2)
    obs, info = env.reset(seed=0)
    bad = int(np.flatnonzero(info["action_mask"] == 0)[0])
    ends = []
    for _ in range(200):
        obs, r, term, trunc, info = env.step(bad)  # the world never changes: bad stays invalid
        if term or trunc:
            ends.append((term, trunc, info["tasks_done"]))
            break
    assert ends and ends[0][:2] == (False, True) and ends[0][2] == 2


@pytest.mark.parametrize("kw", [{}, {"factored": True}])
def test_seeded_episodes_are_deterministic(kw):
    def trace(seed):
        env = make("AnticipatoryRestaurant-two-room-v0", **kw)
        rng = np.random.default_rng(7)  # the agent's choices: the same in every run
        out = []
        obs, info = env.reset(seed=seed)
        for _ in range(200):
            if kw:
                a = np.array([rng.choice(np.flatnonzero(m)) for m in info["head_masks"]])
            else:
                a = int(rng.choice(np.flatnonzero(info["action_mask"])))
            obs, r, term, trunc, info = env.step(a)
            out.append((obs.tobytes(), r, term, trunc, info["task"], info["task_cost"], info["invalid"]))
            if term or trunc:
                obs, info = env.reset()
        return out

    a, b, c = trace(3), trace(3), trace(4)
    assert a == b and a != c


def test_maskable_ppo_example_runs(tmp_path, monkeypatch):
    pytest.importorskip("sb3_contrib")
    import json
    import runpy
    import sys

    out = tmp_path / "ppo.json"
    monkeypatch.setattr(
        sys,
        "argv",
        [
            "maskable_ppo_minimal.py",
            "--steps",
            "256",
            "--episodes",
            "3",
            "--horizons",
            "anticipatory",
            "--out",
            str(out),
        ],
    )
    runpy.run_path(str(ROOT / "examples" / "maskable_ppo_minimal.py"), run_name="__main__")
    r = json.loads(out.read_text())["anticipatory"]
    assert sum(r["sampled"][k] for k in ("a", "b", "other", "abandoned")) == 3
