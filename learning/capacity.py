"""Can the Q-network hold a domain's values? The thesis's network fitted to the myopic oracle's Q by regression.

The Double-DQN learns Q from its own experience; where it does not learn on a domain, this
check asks whether the network could hold the answer at all. It labels (state, task, action)
triples with the optimal myopic Q,

    Q*(s, a) = r(a) + R_goal                 if a completes the task,
             = r(a) + gamma V*(s')           otherwise,

V*(s') the discounted return of an optimal plan from s' (our exact A*), on the states a persistent
stream visits when the oracle acts with random detours (each action random with probability
--detour, so states off the optimal path are labelled too), and fits a fresh network (the training's
architecture, Adam, Huber loss, gradient clipping) to them. It reports how often the network's best
action is an optimal one, on its training states and on held-out states (one in five, by state),
and the greedy policy's success on the training's evaluation stream. A network that cannot fit Q*
from exact labels will not learn it from rewards; one that fits its training states but not held-out
ones needs more experience than the labels hold, or an encoding that generalises.

    python -m learning.capacity --domain domains/blockworld --layout grid7x7 [--states 3000] [--epochs 150]

With --score CHECKPOINT a trained myopic Q-network (learning.dqn's, exported) is scored on the same
kind of labels instead of a network being fitted: how often its best action is optimal, how far its Q
is from Q* (L1, and the means of both), and its greedy success. Where a Double-DQN does not learn,
this says whether its values are wrongly shaped or have not yet grown to the returns. The labels use
the checkpoint's discount and R_goal. Default file: results/[<domain>-]capacity-score-<its run name>.json.

    python -m learning.capacity --domain domains/blockworld --layout grid7x7 --score CHECKPOINT [--states 3000]
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from tqdm import tqdm

from learning.encoding import TASK_FEATURES, Encoding
from learning.export import domain_prefix
from learning.q.network import build_network
from learning.q.training import Config, eval_stream_seed, greedy_evaluation
from learning.q.value import ValueFunction
from learning.reward import cost_scale, goal_reward
from planning import cli
from planning.atomic import OutputLock, write_json
from planning.domain.batched import BatchedModel
from planning.domain.compiler import compile_domain
from planning.domain.identity import identity, refuse_other
from planning.errors import DomainError
from planning.parallel import one_thread, results_provenance
from planning.search.optimal import optimal_plan

DEFAULTS = Config()


@dataclass(frozen=True)
class Settings:
    states: int = 3000
    """distinct (state, task) pairs to label"""
    epochs: int = 150
    """passes over the training pairs"""
    detour: float = 0.3
    """probability of a random action instead of the oracle's while visiting states"""
    max_actions: int = 20
    """actions per task while visiting (a task not finished by then is left as it stands)"""
    hidden: int = DEFAULTS.hidden
    """width of the network's shared encoder"""
    lr: float = DEFAULTS.lr
    """Adam learning rate"""
    batch_size: int = DEFAULTS.batch_size
    """minibatch size"""
    gamma: float = DEFAULTS.gamma
    """discount per action"""
    task_features: str = "arguments"
    """the task encoding (learning.encoding)"""
    goal_reward: float | None = None
    """completion reward R_goal (RL units); None: the layout's, as the training's (learning.reward.goal_reward)"""
    seed: int = 0
    """seeds the visits, the held-out split and the network"""


class Labeller:
    """Q* of every applicable action of visited (state, task) pairs; V* memoised per pair."""

    def __init__(self, model, gamma: float, r_goal: float, time_limit: float = 60.0):
        self.model, self.bm, self.gamma, self.time_limit = model, BatchedModel(model), gamma, time_limit
        self.scale, self.r_goal = cost_scale(model), r_goal
        self.memo: dict = {}

    def plan(self, state: int, task) -> tuple[float, list]:
        """(V*, an optimal plan) from a state where the task is open."""
        key = (state, task.index)
        if key not in self.memo:
            r = optimal_plan(self.bm, state, task, time_limit=self.time_limit)
            if r.plan is None:
                raise DomainError(
                    f"{self.model.name} {self.model.layout}", f"no plan for {task.name} ({r.expansions} expansions)"
                )
            v, last = 0.0, len(r.plan) - 1
            for k, a in enumerate(r.plan):
                v += self.gamma**k * (-self.model.action_cost[a] / self.scale + (self.r_goal if k == last else 0.0))
            self.memo[key] = (v, list(r.plan))
        return self.memo[key]

    def q_star(self, state: int, task) -> list[tuple[int, float]]:
        """[(action, Q*)] over the actions applicable in the state."""
        out = []
        for a, s2, cost in self.model.successors(state):
            done = task.satisfied(s2)
            out.append((a, -cost / self.scale + (self.r_goal if done else self.gamma * self.plan(s2, task)[0])))
        return out

    def visit(self, n_pairs: int, seed: int, detour: float, max_actions: int, progress: bool = False) -> dict:
        """Labelled triples on the states of a persistent i.i.d. stream, with the world reset as the
        domain's stream resets it: arrays state (packed later), task, action, q, pair (its pair's id)."""
        bar = tqdm(total=n_pairs, desc=f"labelling Q* {self.model.layout}", unit="state", disable=not progress)
        model, rng = self.model, np.random.default_rng(seed)
        tasks = list(model.tasks)
        p = np.asarray(model.tasks.probabilities, dtype=np.float64)
        p = p / p.sum()
        per_reset = model.config.get("stream", {}).get("tasks_per_reset", 50)
        rows, pairs, n = [], {}, 0
        state = model.reset_state(rng)
        while len(pairs) < n_pairs:
            if n and n % per_reset == 0:
                state = model.reset_state(rng)
            task = tasks[rng.choice(len(tasks), p=p)]
            n += 1
            for _ in range(max_actions):
                if task.satisfied(state) or len(pairs) >= n_pairs:
                    break
                pid = pairs.setdefault((state, task.index), len(pairs))
                bar.update(len(pairs) - bar.n)
                rows += [(state, task.index, a, q, pid) for a, q in self.q_star(state, task)]
                plan = self.plan(state, task)[1]
                a = plan[0] if rng.random() >= detour else int(rng.choice(model.applicable(state)))
                state = model.apply(state, a)
            if task.satisfied(state):
                state = task.consume(state)
        bar.close()
        cols = list(zip(*rows))
        return {
            "state": list(cols[0]),
            "task": np.array(cols[1], dtype=np.int64),
            "action": np.array(cols[2], dtype=np.int64),
            "q": np.array(cols[3], dtype=np.float32),
            "pair": np.array(cols[4], dtype=np.int64),
        }


def best_is_optimal(q: np.ndarray, target: np.ndarray, pair: np.ndarray, tol: float = 1e-4) -> float:
    """Share of pairs whose highest-q action has the pair's highest target (ties count as optimal)."""
    order = np.lexsort((-q, pair))  # by pair, best q first
    first = np.ones(len(order), dtype=bool)
    first[1:] = pair[order][1:] != pair[order][:-1]
    best_target = np.full(pair.max() + 1, -np.inf)
    np.maximum.at(best_target, pair, target)
    chosen = order[first]
    return float(np.mean(target[chosen] >= best_target[pair[chosen]] - tol))


def pair_inputs(enc: Encoding, data: dict) -> tuple:
    """(observations, valid-action masks) once per labelled (state, task) pair, and each row's pair."""
    first = np.unique(data["pair"], return_index=True)[1]  # a row of each pair: its state and task
    packed = enc.pack([data["state"][i] for i in first])
    obs = torch.from_numpy(enc.observe(packed, data["task"][first]))
    valid = torch.from_numpy(enc.valid_for(packed, data["task"][first]))
    return obs, valid, torch.from_numpy(data["pair"])


def fit(enc: Encoding, data: dict, s: Settings, log=print, progress: bool = False) -> tuple:
    """A fresh network fitted to the labels; (network, the per-epoch rows it logged)."""
    torch.manual_seed(s.seed)
    rng = np.random.default_rng(s.seed + 1)
    n_pairs = int(data["pair"].max()) + 1
    pair_obs, pair_valid, of = pair_inputs(enc, data)
    act, y = torch.from_numpy(data["action"]), torch.from_numpy(data["q"])
    held = rng.permutation(n_pairs)[: n_pairs // 5]
    test = np.isin(data["pair"], held)
    train_rows, test_rows = np.flatnonzero(~test), np.flatnonzero(test)
    net = build_network(enc, hidden=s.hidden)
    opt = torch.optim.Adam(net.parameters(), lr=s.lr)

    def measure(rows) -> tuple[float, float]:
        with torch.inference_mode():
            q = net.q_taken(pair_obs[of[rows]], pair_valid[of[rows]], act[rows]).numpy()
        return best_is_optimal(q, data["q"][rows], data["pair"][rows]), float(np.abs(q - data["q"][rows]).mean())

    history, every = [], max(1, s.epochs // 10)
    for epoch in tqdm(range(1, s.epochs + 1), desc="fitting", unit="epoch", disable=not progress):
        order = rng.permutation(train_rows)
        for i in range(0, len(order), s.batch_size):
            b = torch.from_numpy(order[i : i + s.batch_size])
            loss = F.smooth_l1_loss(net.q_taken(pair_obs[of[b]], pair_valid[of[b]], act[b]), y[b])
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(net.parameters(), DEFAULTS.grad_clip)
            opt.step()
        if epoch % every == 0 or epoch == s.epochs:
            (tr_best, tr_l1), (te_best, te_l1) = measure(train_rows), measure(test_rows)
            history.append(
                {
                    "epoch": epoch,
                    "train_best_optimal": round(tr_best, 4),
                    "train_l1": round(tr_l1, 4),
                    "held_out_best_optimal": round(te_best, 4),
                    "held_out_l1": round(te_l1, 4),
                }
            )
            log(
                f"epoch {epoch}: best action optimal on {tr_best:.3f} of training states (L1 {tr_l1:.2f}), "
                f"{te_best:.3f} held out (L1 {te_l1:.2f})"
            )
    return net.eval(), history


def score(vf: ValueFunction, data: dict) -> dict:
    """A trained network's Q against the labels: best action optimal (share of pairs), L1, mean Q and Q*."""
    obs, valid, of = pair_inputs(vf.enc, data)
    with torch.inference_mode():
        q = vf.net.q_taken(obs[of], valid[of], torch.from_numpy(data["action"])).numpy().astype(np.float64)
    return {
        "pairs": len(obs),
        "best_optimal": round(best_is_optimal(q, data["q"], data["pair"]), 4),
        "l1": round(float(np.abs(q - data["q"]).mean()), 4),
        "mean_q": round(float(q.mean()), 4),
        "mean_q_star": round(float(data["q"].mean()), 4),
    }


def score_checkpoint(args, model) -> None:
    """--score: a trained myopic checkpoint scored on labels made with its discount and R_goal."""
    from learning.export import rl_name
    from learning.q.checkpoints import read_checkpoint
    from learning.q.value import value_function
    from planning.atomic import sha256

    payload = read_checkpoint(args.score)
    cfg = payload.get("config", {})
    if cfg.get("horizon") != "myopic":
        raise DomainError(
            args.score, f"trained for the {cfg.get('horizon')} horizon: --score compares with the myopic Q*"
        )
    vf = value_function(payload, model, args.score)
    states, seed = args.states or Settings.states, args.seed or Settings.seed
    out = args.out or f"results/{domain_prefix(model.name, '--domain')}capacity-score-{rl_name(cfg)}.json"
    cli.check_writable(out)
    settings = {"checkpoint_sha256": sha256(args.score), "states": states, "seed": seed, "detour": Settings.detour}
    if Path(out).is_file() and not args.force:
        refuse_other(out, model, {"settings": settings}, "capacity score")
    start = time.perf_counter()
    labeller = Labeller(model, cfg["gamma"], cfg["goal_reward"])
    data = labeller.visit(states, seed, Settings.detour, Settings.max_actions, not args.no_progress)
    scored = score(vf, data)
    # the run's own evaluation stream, so the figure is its trainer's check
    stream_seed = eval_stream_seed(int(cfg.get("seed", 0)))
    ev = greedy_evaluation(vf, model, stream_seed, DEFAULTS.eval_tasks, cfg["gamma"], labeller.r_goal, labeller.scale)
    print(
        f"{args.score} (step {payload.get('step'):,}): best action optimal on {scored['best_optimal']:.3f} of "
        f"{scored['pairs']} pairs, L1 {scored['l1']:.2f}, mean Q {scored['mean_q']:.2f} against Q* "
        f"{scored['mean_q_star']:.2f}; greedy success {ev['success_rate']:.2f}"
    )
    result = {
        "domain": model.name,
        "layout": model.layout,
        **identity(model),
        "settings": settings,
        "checkpoint": str(args.score),
        "checkpoint_step": payload.get("step"),
        "run": rl_name(cfg),
        "task_features": cfg.get("task_features") or "arguments",
        "r_goal": labeller.r_goal,
        "gamma": cfg["gamma"],
        "scored": scored,
        "greedy": {**ev, "tasks": DEFAULTS.eval_tasks, "stream_seed": stream_seed},
        "seconds": round(time.perf_counter() - start, 1),
    }
    result["provenance"] = results_provenance(settings)
    with OutputLock(out, "capacity score"):
        write_json(out, result)
    print(f"wrote {out}")


def default_out(model) -> str:
    """The check's results file when --out is not given: results/[<domain>-]capacity-<layout>.json."""
    return f"results/{domain_prefix(model.name, '--domain')}capacity-{model.layout}.json"


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=False, progress=True)
    cli.add_dataclass_options(p, Settings)
    p.add_argument("--force", action="store_true", help="replace a check made with other settings or domain content")
    p.add_argument(
        "--score", help="a trained myopic Q-network checkpoint to score on the labels instead of fitting one"
    )
    args = p.parse_args()
    if args.score:
        one_thread()
        return score_checkpoint(args, compile_domain(args.domain, args.layout))
    s = Settings(**{k: getattr(args, k) for k in Settings.__dataclass_fields__ if getattr(args, k) is not None})
    if s.task_features not in TASK_FEATURES:
        raise DomainError("--task-features", f"{s.task_features!r} is not one of {', '.join(TASK_FEATURES)}")
    if s.states < 10 or s.epochs < 1 or not 0 <= s.detour <= 1:
        raise DomainError("--states/--epochs/--detour", "need at least 10 states, 1 epoch and a detour in [0, 1]")
    one_thread()
    model = compile_domain(args.domain, args.layout)
    out = args.out or default_out(model)
    cli.check_writable(out)
    if Path(out).is_file() and not args.force:
        refuse_other(out, model, {"settings": asdict(s)}, "capacity check")
    start = time.perf_counter()
    labeller = Labeller(model, s.gamma, goal_reward(model) if s.goal_reward is None else s.goal_reward)
    data = labeller.visit(s.states, s.seed, s.detour, s.max_actions, not args.no_progress)
    label_s = time.perf_counter() - start
    print(f"{len(data['q'])} labelled actions on {s.states} (state, task) pairs in {label_s:.0f} s", flush=True)
    enc = Encoding(model, s.task_features)
    net, history = fit(enc, data, s, tqdm.write, not args.no_progress)
    ev = greedy_evaluation(
        ValueFunction(net, enc, s.gamma),
        model,
        eval_stream_seed(s.seed),
        DEFAULTS.eval_tasks,
        s.gamma,
        labeller.r_goal,
        labeller.scale,
    )
    print(
        f"greedy policy: success {ev['success_rate']:.2f}, {ev['actions_per_task']:.1f} actions and "
        f"cost {ev['cost_per_task']:.1f} per task over {DEFAULTS.eval_tasks} tasks"
    )
    result = {
        "domain": model.name,
        "layout": model.layout,
        **identity(model),
        "settings": asdict(s),
        "labelled_actions": len(data["q"]),
        "r_goal": labeller.r_goal,
        "cost_scale": labeller.scale,
        "fit": history,
        "greedy": {**ev, "tasks": DEFAULTS.eval_tasks, "stream_seed": eval_stream_seed(s.seed)},
        "seconds": {"labelling": round(label_s, 1), "total": round(time.perf_counter() - start, 1)},
    }
    result["provenance"] = results_provenance(asdict(s))
    with OutputLock(out, "capacity check"):
        write_json(out, result)
    print(f"wrote {out}")


if __name__ == "__main__":
    cli.run(main)
