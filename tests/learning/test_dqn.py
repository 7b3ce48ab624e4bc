"""The trainer: a short run learns the grid example's first task; checkpoints resume; the demo memory."""

import json

import numpy as np
import pytest

from learning.q.replay import COMPLETE, CONTINUE, TERMINAL, Replay, mixed_batch
from learning.q.training import Config, Trainer, bound_suffix, domain_defaults, epsilon, random_action
from learning.q.value import ValueFunction
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from tests.conftest import MINIMAL


def small_config(model, out, horizon="myopic", **over) -> Config:
    values = {
        **domain_defaults(model, horizon),
        "steps": 1200,
        "eps_decay_steps": 800,
        "learning_starts": 100,
        "lr": 1e-3,
        "hidden": 64,
        "target_every": 100,
        "demo_fraction": 0.5,
        "eval_every": 10**9,
        "checkpoint_every": 1000,
        "log_every": 500,
        **over,
    }
    return Config(domain=MINIMAL, horizon=horizon, out=str(out), **values)


def greedy_clears(model, vf, seeds) -> int:
    """How many start worlds the greedy policy clears C from within the 64-action budget."""
    clear = model.tasks.get("clear(c)")
    done = 0
    for seed in seeds:
        s = model.reset_state(seed)
        for _ in range(64):
            s = model.apply(s, int(vf.greedy([s], clear.index)[0]))
            if clear.satisfied(s):
                done += 1
                break
    return done


def test_short_training_learns_the_first_task_and_resumes(minimal, tmp_path):
    trainer = Trainer(small_config(minimal, tmp_path), progress=False)
    assert len(trainer.demos) > 0
    kinds = trainer.demos.kinds[: len(trainer.demos)]
    assert (kinds == COMPLETE).sum() > 0 and (kinds == TERMINAL).sum() > 0  # clear completes, deliver ends
    # the oracle's return from each demonstrated step: the reward at completion, discounted before it
    g, r = trainer.demo_returns, trainer.demos.rewards[: len(trainer.demos)]
    done = kinds != CONTINUE
    assert np.isfinite(g).all() and np.allclose(g[done], r[done])
    assert np.allclose(g[:-1][~done[:-1]], r[:-1][~done[:-1]] + trainer.cfg.gamma * g[1:][~done[:-1]], atol=1e-4)
    trainer.train()
    vf = ValueFunction(trainer.net, trainer.enc)
    assert greedy_clears(minimal, vf, range(20)) >= 18
    rows = [json.loads(line) for line in (tmp_path / "metrics.jsonl").read_text().splitlines()]
    logged = [r for r in rows if "step" in r and "eval" not in r]
    assert {"success_rate", "task_return", "selected_q", "td_target", "action_share"} <= set(logged[-1])
    assert (tmp_path / "best.pt").is_file() and (tmp_path / "last.pt").is_file()
    final = [r["eval"] for r in rows if "eval" in r][-1]  # myopic: Q against the oracle's returns
    assert abs(final["demo_q_bias"]) < 1.0, final
    # resume: a new trainer picks up the step, memory and world where the last one stopped
    again = Trainer(small_config(minimal, tmp_path, steps=1250), progress=False)
    with open(tmp_path / "metrics.jsonl", "a") as f:  # a row logged after the checkpoint, then interrupted
        f.write(json.dumps({"step": 1300, "tasks": 0}) + "\n")
    again.resume(tmp_path / "last.pt")
    steps = [json.loads(line).get("step") for line in (tmp_path / "metrics.jsonl").read_text().splitlines()]
    assert 1300 not in steps and 1000 in steps  # rows past the checkpoint are dropped on resume
    assert again.step == 1200 and len(again.memory) == len(trainer.memory)
    assert again.world.state == trainer.world.state
    again.train()
    assert again.step == 1250
    with pytest.raises(DomainError, match="goal_reward=10.0, not 12.0"):
        Trainer(small_config(minimal, tmp_path, goal_reward=12.0), progress=False).resume(tmp_path / "last.pt")
    with pytest.raises(DomainError, match="horizon"):
        Trainer(small_config(minimal, tmp_path, horizon="anticipatory"), progress=False).resume(tmp_path / "last.pt")
    with pytest.raises(DomainError, match="explore='factored', not 'uniform' .pass --explore factored"):
        Trainer(small_config(minimal, tmp_path, explore="uniform"), progress=False).resume(tmp_path / "last.pt")
    # a checkpoint from before the exploration settings existed was trained with the old ones
    from learning.q.checkpoints import read_checkpoint, save_checkpoint

    old = read_checkpoint(tmp_path / "last.pt")
    for key in ("eps_schedule", "explore", "demo_planner"):
        del old["config"][key]
    save_checkpoint(tmp_path / "old" / "last.pt", old)
    with pytest.raises(DomainError, match="eps_schedule='reach', not 'time-constant' .pass --eps-schedule reach"):
        Trainer(small_config(minimal, tmp_path / "old"), progress=False).resume(tmp_path / "old" / "last.pt")
    Trainer(small_config(minimal, tmp_path / "old", eps_schedule="reach", explore="uniform"), progress=False).resume(
        tmp_path / "old" / "last.pt"
    )


def test_epsilon_schedules():
    cfg = Config()  # the authors': 100k steps is the decay's time constant
    assert epsilon(cfg, 0) == pytest.approx(1.0)
    assert epsilon(cfg, 100_000) == pytest.approx(0.05 + 0.95 * np.exp(-1)) == pytest.approx(0.3995, abs=1e-4)
    assert epsilon(cfg, 300_000) == pytest.approx(0.0973, abs=1e-4) and epsilon(cfg, 500_000) > 0.05
    reach = Config(eps_schedule="reach")
    assert epsilon(reach, 50_000) == pytest.approx(0.05**0.5)
    assert epsilon(reach, 100_000) == pytest.approx(0.05) and epsilon(reach, 400_000) == pytest.approx(0.05)


def test_factored_exploration_draws_the_type_first():
    # six moves and one pick applicable: the factored draw picks the pick half the time, uniform 1/7
    labels = np.array([[0, 0, l] for l in range(6)] + [[1, 3, 9]])
    actions = np.arange(7)
    rng = np.random.default_rng(0)
    factored = [random_action(actions, labels, rng) for _ in range(4000)]
    uniform = [random_action(actions, labels, rng, factored=False) for _ in range(4000)]
    assert np.mean(np.equal(factored, 6)) == pytest.approx(0.5, abs=0.03)
    assert np.mean(np.equal(uniform, 6)) == pytest.approx(1 / 7, abs=0.02)
    assert set(factored) == set(range(7))
    # a second head chosen among the values valid with the first: (type 2, a, b) with a in {0, 1}
    labels = np.array([[2, 0, 0], [2, 0, 1], [2, 0, 2], [2, 1, 0]])
    draws = [random_action(np.arange(4), labels, rng) for _ in range(4000)]
    assert np.mean(np.equal(draws, 3)) == pytest.approx(0.5, abs=0.03)


def test_protected_demo_fraction():
    agent, demos = Replay(1000, 1), Replay(100, 1)
    for _ in range(1000):
        agent.add(np.zeros(1, np.uint64), 0, 1, 0.0, np.zeros(1, np.uint64), CONTINUE)
    for _ in range(100):
        demos.add(np.zeros(1, np.uint64), 0, 2, 0.0, np.zeros(1, np.uint64), CONTINUE)
    b = mixed_batch(agent, demos, 128, 0.25, np.random.default_rng(0))
    assert (b["actions"] == 2).sum() == 32 and len(b["actions"]) == 128


def test_layout_and_horizon_keyed_training_settings(three_room, two_room):
    assert domain_defaults(three_room, "anticipatory")["demo_tasks"] == 48
    assert domain_defaults(three_room, "myopic")["demo_tasks"] == 480
    assert domain_defaults(two_room, "myopic")["demo_fraction"] == 0.2
    assert domain_defaults(compile_domain(MINIMAL, None), "myopic")["gamma"] == 0.99
    assert domain_defaults(two_room, "anticipatory")["demo_planner"] == "clairvoyant-3"  # keyed by horizon
    assert domain_defaults(three_room, "myopic")["demo_planner"] == "internal"


def test_rl_greedy_agent_loads_a_checkpoint_and_acts(two_room, tmp_path):
    from argparse import Namespace

    from experiments.registry import agent_class
    from learning.encoding import Encoding
    from learning.q.checkpoints import network_payload, save_checkpoint
    from learning.q.network import build_network

    with pytest.raises(DomainError, match="--checkpoint"):
        agent_class("rl-greedy").from_args(Namespace(checkpoint=None))
    enc = Encoding(two_room)
    path = save_checkpoint(tmp_path / "q.pt", network_payload(build_network(enc, 32), enc, {"step": 7}))
    agent = agent_class("rl-greedy").from_args(Namespace(checkpoint=str(path)))
    before = dict(agent.config)  # what the runner compares with a partial run's to resume
    agent.start(two_room, None)
    assert agent.config == before
    s = two_room.reset_state(0)
    task = next(t for t in two_room.tasks if not t.satisfied(s))
    assert agent.act(s, task) in two_room.applicable(s)
    assert agent.config["step"] == 7


def test_throughput_benchmark_reports_rates_and_the_boundary_share():
    from learning.q.bench import bench_horizon

    r = bench_horizon(MINIMAL, "grid", "anticipatory", steps=60, updates=6, seed=0)
    assert r["env_steps_per_s"] > 0 and r["demo_transitions"] > 0
    for regime in ("early", "competent"):
        e = r[regime]
        assert e["updates_per_s"] > 0 and 0 <= e["boundary_share"] < 1
        assert e["boundary_share_uncached"] < 1 and e["completions_per_minibatch"] >= 0
        assert 0 < e["matmul_share"] < 1 and e["matmul_ms"] > 0 and e["matmul_gflops"] > 0
    myopic = bench_horizon(MINIMAL, "grid", "myopic", steps=60, updates=6, seed=0)
    assert "boundary_share" not in myopic["competent"]  # no boundary target without anticipation


def test_a_torn_last_metrics_line_is_dropped_on_resume(tmp_path, capsys):
    """metrics.jsonl is appended to: a run killed mid-write leaves half a line, which resuming drops."""
    from types import SimpleNamespace

    m = tmp_path / "metrics.jsonl"
    m.write_text('{"step": 500}\n{"eval": {"step": 500}}\n{"step": 1000}\n{"step": 1500, "tas')
    Trainer._trim_metrics(SimpleNamespace(metrics=m, step=1000))
    assert m.read_text() == '{"step": 500}\n{"eval": {"step": 500}}\n{"step": 1000}\n'
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "dropped a half-written last line" in err
    m.write_text('{"step": 500}\n{"step": 6\n{"step": 1000}\n')  # not the last line: not a torn write
    with pytest.raises(DomainError, match="metrics.jsonl: line 2 is not a metrics row"):
        Trainer._trim_metrics(SimpleNamespace(metrics=m, step=1000))


def test_training_killed_and_rerun_gives_the_uninterrupted_run(tmp_path):
    """SIGKILL the trainer (twice, after checkpoints), rerun: the same weights, best network and metrics."""
    import subprocess
    import sys

    import torch

    from tests.experiments.test_evaluate import run_killed_and_resumed

    cmd = lambda out: [
        "-m",
        "learning.dqn",
        "--domain",
        MINIMAL,
        "--horizon",
        "anticipatory",
        "--steps",
        "300",
        "--checkpoint-every",
        "100",
        "--target-every",
        "50",
        "--eval-every",
        "100",
        "--eval-tasks",
        "5",
        "--demo-tasks",
        "20",
        "--learning-starts",
        "50",
        "--log-every",
        "50",
        "--hidden",
        "64",
        "--no-progress",
        "--out",
        str(out),
    ]
    whole, resumed = tmp_path / "whole", tmp_path / "resumed"
    assert subprocess.run([sys.executable, *cmd(whole)], capture_output=True).returncode == 0
    assert run_killed_and_resumed(cmd(resumed), resumed / "last.pt") == 0
    rows = lambda d: [
        {k: v for k, v in json.loads(line).items() if not k.endswith("_per_s")}
        for line in (d / "metrics.jsonl").read_text().splitlines()
    ]
    assert rows(resumed) == rows(whole)
    for name in ("last.pt", "best.pt"):
        a, b = (torch.load(d / name, weights_only=True) for d in (whole, resumed))
        assert a["step"] == b["step"] == 300 or name == "best.pt"
        assert all(torch.equal(a["net"][k], b["net"][k]) for k in a["net"])


def test_checkpoint_round_trip_continues_identically(minimal, tmp_path):
    """last.pt holds all of the trainer (networks, fused Adam's state, memories, world, generators):
    a trainer resumed from it in the same process continues exactly as the one that wrote it."""
    import torch

    cfg = lambda out, steps: small_config(
        minimal,
        out,
        "anticipatory",
        steps=steps,
        checkpoint_every=200,
        log_every=100,
        demo_tasks=20,
        hidden=32,
        eval_tasks=10,
    )
    a = Trainer(cfg(tmp_path / "a", 200), progress=False)
    a.train()
    b = Trainer(cfg(tmp_path / "b", 400), progress=False)
    b.resume(tmp_path / "a" / "last.pt")
    a.cfg.steps = 400
    a.train()
    b.train()
    for x, y in ((a.net, b.net), (a.target, b.target)):
        assert all(torch.equal(p, q) for p, q in zip(x.state_dict().values(), y.state_dict().values()))
    rows = lambda d: [
        {k: v for k, v in json.loads(line).items() if not k.endswith("_per_s")}
        for line in (d / "metrics.jsonl").read_text().splitlines()
    ]
    after = [r for r in rows(tmp_path / "a") if r.get("step", r.get("eval", {}).get("step")) > 200]
    assert after and json.dumps(after) == json.dumps(rows(tmp_path / "b"))
    assert a.step == b.step == 400 and a.world.state == b.world.state


def test_every_parameter_steps_as_under_the_per_head_forward(minimal, tmp_path):
    """The per-head forward put every head in every loss, so Adam stepped every parameter each update
    (zero gradients included); the dense forward leaves unused heads out, and the trainer fills in zeros."""
    import torch

    t = Trainer(small_config(minimal, tmp_path, steps=0, demo_tasks=20, hidden=32), progress=False)
    for _ in range(200):
        t.env_step(1.0)
    t.update()
    assert all(p.grad is not None for p in t.net.parameters())
    state = t.opt.state_dict()["state"]
    assert len(state) == len(list(t.net.parameters()))
    assert all(float(s["step"]) == 1.0 for s in state.values())
    assert torch.isfinite(torch.cat([p.detach().reshape(-1) for p in t.net.parameters()])).all()


def test_target_bound_caps_the_targets_and_keeps_the_run_apart(minimal, tmp_path):
    """--target-bound return (not the thesis's): no target above R_goal for a myopic value, R_goal/(1-γ) for an
    anticipatory one; without it the targets are td_targets' own. A bound run has its own folder and checkpoint
    name, and a run resumes only under the bound it was trained with."""
    import torch

    from learning.export import default_names
    from planning.errors import DomainError

    for horizon in ("myopic", "anticipatory"):
        plain = Trainer(
            small_config(minimal, tmp_path / f"p-{horizon}", steps=0, demo_tasks=20, hidden=32, horizon=horizon),
            progress=False,
        )
        bound = Trainer(
            small_config(
                minimal,
                tmp_path / f"b-{horizon}",
                steps=0,
                demo_tasks=20,
                hidden=32,
                horizon=horizon,
                target_bound="return",
            ),
            progress=False,
        )
        for _ in range(200):
            plain.env_step(1.0)
        bound.memory = plain.memory
        bound.net.load_state_dict(plain.net.state_dict())
        for t in (plain, bound):
            with torch.no_grad():
                t.target.value.bias.fill_(1e4)  # values far past any return a task can earn
        batch = mixed_batch(plain.memory, plain.demos, 64, 0.2, np.random.default_rng(0))
        y_plain, y_bound = plain.targets(batch), bound.targets(batch)
        cap = plain.r_goal if horizon == "myopic" else plain.r_goal / (1 - plain.cfg.gamma)
        assert y_plain.max() > cap and torch.equal(y_bound, y_plain.clamp(max=cap))
    assert bound_suffix(bound.cfg) == "-bound-return" and bound_suffix(plain.cfg) == ""
    bound.step = 1
    bound.save()
    (bound.out / "best.pt").write_bytes((bound.out / "last.pt").read_bytes())
    assert default_names(bound.out, gnn=False)[0] == "checkpoints/minimal-rl-anticipatory-grid-seed0-bound-return.pt"
    again = Trainer(
        small_config(minimal, tmp_path / "b-anticipatory", steps=0, demo_tasks=20, hidden=32, horizon="anticipatory"),
        progress=False,
    )
    with pytest.raises(DomainError, match="target_bound"):
        again.resume(bound.out / "last.pt")
