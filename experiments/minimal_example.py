"""The minimal example (thesis §5.1, Figure 5.1): myopic vs anticipatory Q of placing the apple on A or B.

Trains both agents on domains/minimal (clear C, then deliver the apple to B with
0.8 or A with 0.2; +10 per task, 1 per step, γ = 0.99; the second task ends the
episode), then prints, per agent, the learned Q(s, clear(c), place(apple, A))
and Q(·, place(apple, B)) with the robot at the receptacle holding the apple,
their gap, and the share of placements on B when acting by softmax over Q
(1,000 episodes, temperature 1 in reward units). The exact values, from
breadth-first search on the grid, are printed beside them.

    python -m experiments.minimal_example [--steps N] [--seed 0] [--out results/minimal-example.json]
"""

from __future__ import annotations

from collections import deque
from dataclasses import asdict

import numpy as np

from learning.q.training import Config, domain_defaults, train_run
from learning.q.value import ValueFunction
from learning.reward import step_reward
from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError

FIRST, TARGETS = "clear(c)", ("a", "b")


def placement_state(model, cell: str) -> int:
    """The world just before the placement: robot on `cell` holding the apple."""
    return model.state_from_atoms([f"(robot-at {cell})", "(holding apple)"])


def exact_task_value(model, state: int, task, gamma: float, r_goal: float, scale: float) -> float:
    """V*(s, τ) of a last task by breadth-first search (all steps cost the same): the discounted return."""
    if task.satisfied(state):
        return r_goal
    seen, frontier = {state}, deque([(state, 0)])
    while frontier:
        s, d = frontier.popleft()
        for _, nxt, cost in model.successors(s):
            if nxt in seen:
                continue
            if task.satisfied(nxt):
                c = cost / scale
                return -c * sum(gamma**k for k in range(d + 1)) + gamma**d * r_goal
            seen.add(nxt)
            frontier.append((nxt, d + 1))
    raise DomainError(task.name, "unreachable from the placement state")


def exact_placement_q(model, cell: str, gamma: float, r_goal: float, scale: float, horizon: str) -> float:
    """Q* of the placement on `cell`: -c + R_goal (+ γ V_AP of the world left behind, anticipatory)."""
    s = placement_state(model, cell)
    a = model.action(f"place(apple, {cell})")
    after = model.tasks.get(FIRST).consume(model.apply(s, a))
    q = step_reward(model.action_cost[a], True, scale, r_goal)
    if horizon == "anticipatory":
        p = model.tasks.probabilities / model.tasks.probabilities.sum()
        q += gamma * sum(
            p[t.index] * exact_task_value(model, after, t, gamma, r_goal, scale) for t in model.tasks if p[t.index] > 0
        )
    return q


def softmax_share_b(model, vf: ValueFunction, episodes: int, temperature: float, seed: int) -> float:
    """Share of first-task completions that leave the apple on B, acting by softmax over Q (batched episodes)."""
    rng = np.random.default_rng(seed)
    task = model.tasks.get(FIRST)
    states = [model.reset_state(rng) for _ in range(episodes)]
    where = [None] * episodes
    on = {c: model.state_from_atoms([f"(at apple {c})"]) for c in TARGETS}
    open_ = list(range(episodes))
    for _ in range(model.config.get("stream", {}).get("max_actions", 64)):
        if not open_:
            break
        q = vf.q_values([states[i] for i in open_], task.index)
        logits = (q - q.max(1, keepdims=True)) / temperature
        p = np.exp(logits)
        p /= p.sum(1, keepdims=True)
        still = []
        for row, i in enumerate(open_):
            a = int(rng.choice(len(p[row]), p=p[row]))
            states[i] = model.apply(states[i], a)
            if task.satisfied(states[i]):
                where[i] = next((c for c, m in on.items() if states[i] & m), "other")
            else:
                still.append(i)
        open_ = still
    placed = [w for w in where if w in TARGETS]
    return sum(w == "b" for w in placed) / max(1, len(placed))


def run(
    domain: str,
    seed: int,
    steps: int | None,
    out_dir: str,
    episodes: int = 1000,
    layout: str | None = None,
    temperature: float = 1.0,
    progress: bool = True,
) -> dict:
    """Train both agents and measure them; the JSON of the --out file."""
    model = compile_domain(domain, layout)
    result = {}
    for horizon in ("myopic", "anticipatory"):
        values = domain_defaults(model, horizon)
        if steps:
            values["steps"] = steps
        cfg = Config(
            domain=domain,
            layout=model.layout,
            horizon=horizon,
            seed=seed,
            out=f"{out_dir}/{horizon}-seed{seed}",
            **values,
        )
        trainer = train_run(cfg, progress=progress)  # an interrupted run goes on; a finished one is measured
        trainer.net.eval()
        vf = ValueFunction(trainer.net, trainer.enc)
        clear = model.tasks.get(FIRST)
        q = {
            c: float(vf.q_values([placement_state(model, c)], clear.index)[0, model.action(f"place(apple, {c})")])
            for c in TARGETS
        }
        exact = {c: exact_placement_q(model, c, cfg.gamma, trainer.r_goal, trainer.scale, horizon) for c in TARGETS}
        result[horizon] = {
            "q_A": round(q["a"], 3),
            "q_B": round(q["b"], 3),
            "gap": round(q["b"] - q["a"], 3),
            "share_B": round(softmax_share_b(model, vf, episodes, temperature, seed + 1), 3),
            "exact_q_A": round(exact["a"], 3),
            "exact_q_B": round(exact["b"], 3),
            "exact_gap": round(exact["b"] - exact["a"], 3),
            "steps": trainer.step,
            "config": asdict(cfg),
        }
    result["thesis"] = {
        "myopic": {"q_A": 9.0, "q_B": 9.0, "gap": -0.01, "share_B": 0.47},
        "anticipatory": {"gap": 5.0, "share_B": 0.99},
    }
    result["softmax"] = {"episodes": episodes, "temperature": temperature}
    return result


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=True, progress=True)
    p.set_defaults(domain="domains/minimal")
    p.add_argument("--steps", type=int, default=None, help="training steps per agent (default: domain.toml)")
    p.add_argument("--runs", default="runs/minimal", help="folder of the two training runs")
    args = p.parse_args()
    r = run(args.domain, args.seed, args.steps, args.runs, layout=args.layout, progress=not args.no_progress)
    print(
        f"{'agent':13s} {'Q(place A)':>11s} {'Q(place B)':>11s} {'gap':>7s} {'share B':>8s}   "
        f"exact: {'Q(A)':>6s} {'Q(B)':>6s} {'gap':>6s}   thesis: gap, share B"
    )
    for h in ("myopic", "anticipatory"):
        x, t = r[h], r["thesis"][h]
        print(
            f"{h:13s} {x['q_A']:11.2f} {x['q_B']:11.2f} {x['gap']:7.2f} {x['share_B']:8.2f}   "
            f"       {x['exact_q_A']:6.2f} {x['exact_q_B']:6.2f} {x['exact_gap']:6.2f}   "
            f"        {t['gap']:+.2f}, {t['share_B']:.2f}"
        )
    if args.out:
        write_json(args.out, r)
        print(f"wrote {args.out}")


if __name__ == "__main__":
    cli.run(main)
