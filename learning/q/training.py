"""Online value learning: the anticipatory / myopic factored Double-DQN of the thesis (Algorithm 1, §4.1).

One loop over the persistent world: act ε-greedily on Q, store the transition,
regress Q on a minibatch toward the Double-DQN target, sync the target network.
The two horizons differ only at a completed task: the myopic target is the
reward, the anticipatory one adds γ V_AP(s') = γ Σ_τ' P(τ') Q(s', τ', ·), exact
over every task instance and batched (`learning.q.targets.td_targets`). A per-task
timeout bootstraps the same task (§4.1.3 a). A world reset bootstraps the
pre-reset state as usual (§4.1.3 b), unless the domain declares its episodes
terminal ([stream] terminal_reset, the minimal example's two-task episode).
A task already satisfied when drawn is the AUTO pseudo-action (zero cost,
reward R_goal), stored like any completion (see `learning.encoding`).

Defaults are Table A.2; domain.toml's [training] table overrides them per
domain, a value there may be keyed by layout and then by horizon.

A run (`train_run`, the command `python -m learning.dqn`) writes DIR/metrics.jsonl,
DIR/last.pt (everything, for resuming: rerun the same command) and DIR/best.pt (the
network with the best greedy evaluation on 100 tasks). The run folder is locked while
it trains: a second trainer of the same DIR (another `learning.dqn`, a sweep's item)
stops with a one-line error, and `learning.export` refuses the run until it ends.
`train_run` is the one way a run starts or resumes, for the command and for
`experiments.sweep` alike.
"""

from __future__ import annotations

import ctypes
import json
import math
import random
import re
import sys
import time
from collections import deque
from contextlib import ExitStack
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from tqdm import tqdm

from learning.encoding import TASK_FEATURES, Encoding
from learning.reward import cost_scale, goal_reward, step_reward
from planning import cli
from planning.atomic import OutputLock, write_text
from planning.domain.compiler import compile_domain
from planning.domain.identity import identity
from planning.errors import DomainError
from planning.world.estimators import build as build_estimator
from planning.world.streams import stream as stream_of
from planning.world.task_stream import PersistentWorld, TaskStream

from .checkpoints import check_domain, network_payload, read_checkpoint, save_checkpoint
from .inference import LiveGreedy
from .network import FactoredQNet, build_network
from .optim import FlatAdam
from .replay import COMPLETE, CONTINUE, TERMINAL, Replay, mixed_batch
from .targets import BoundaryCache, SlotCache, td_targets
from .value import ValueFunction

HORIZONS = ("myopic", "anticipatory")


@dataclass
class Config:
    """Training configuration; defaults are the thesis's Table A.2."""

    domain: str = cli.DEFAULT_DOMAIN
    """domain folder"""
    layout: str | None = None
    """layout name (default: the domain's first)"""
    horizon: str = "anticipatory"
    """myopic (completion is terminal) or anticipatory (completion bootstraps V_AP)"""
    seed: int = 0
    """seeds the task stream, exploration, minibatches and initial weights"""
    steps: int = 500_000
    """total environment steps (primitive actions)"""
    buffer_size: int = 50_000
    """replay capacity for the agent's own transitions"""
    batch_size: int = 128
    """minibatch size"""
    hidden: int = 256
    """width of the shared encoder"""
    lr: float = 3e-4
    """Adam learning rate"""
    gamma: float = 0.97
    """discount per primitive action"""
    eps_start: float = 1.0
    """initial exploration rate"""
    eps_end: float = 0.05
    """final exploration rate"""
    eps_decay_steps: int = 100_000
    """the decay's scale in steps (see eps_schedule)"""
    eps_schedule: str = "time-constant"
    """time-constant: ε = eps_end + (eps_start − eps_end)·exp(−step/eps_decay_steps), the authors'
    (0.40 at 100k steps, 0.10 at 300k); reach: exponential from eps_start to eps_end within
    eps_decay_steps, then flat (the schedule of this project's first runs, kept so they reproduce)"""
    explore: str = "factored"
    """ε's random action: factored (a valid action type uniformly, then each argument head uniformly
    among the values valid with the heads before it, the authors'); uniform (uniform over the
    applicable ground actions, the rule of this project's first runs)"""
    target_every: int = 1_000
    """steps between target-network syncs"""
    grad_clip: float = 1.0
    """max gradient norm"""
    learning_starts: int = 1_000
    """steps of pure collection before the first update (demos count toward the minibatch)"""
    train_every: int = 1
    """environment steps per gradient update"""
    goal_reward: float | None = None
    """completion reward R_goal (RL units); None: learning.reward.goal_reward"""
    demo_tasks: int = 500
    """myopic-oracle task outcomes seeded into the demo memory (Appendix A.1)"""
    demo_planner: str = "internal"
    """the planner of the demonstrations (oracles.rollouts): internal (the optimal myopic oracle) or
    clairvoyant-K (each task planned with the next K-1: the authors' anticipatory demonstrations)"""
    demo_seed: int = 0
    """task-stream seed of the demonstrations (shared across training seeds)"""
    demo_fraction: float = 0.2
    """share of every minibatch reserved for demonstrations"""
    target_bound: str = "none"
    """none (the thesis's targets); return: cap each TD target at the largest return a task can earn,
    R_goal for a myopic value (its rewards before the completion are costs) and R_goal/(1-γ) for an
    anticipatory one; a fix the thesis does not have, for runs whose Q grows past R_goal. A run with a
    bound keeps its files apart (run folder and checkpoint names end in -bound-<value>)"""
    stream: str = "iid"
    """the task stream trained on: iid (domain.toml [tasks], the thesis's) or a [streams.<name>] of the domain
    (planning.world.streams); a run on another stream keeps its files apart (-stream-<name>)"""
    estimator: str = "known"
    """the task distribution of the anticipatory target's boundary, Σ P(τ'|·) Q(s', τ', ·) (planning.world.estimators):
    known (the layout's i.i.d. P, the thesis's), empirical (counts of the stream seen, with a prior and forgetting),
    markov (the stream's P(τ'|τ)), markov-empirical (type transition counts times argument counts); another than
    known keeps its files apart (-est-<name>)"""
    estimator_prior: float = 1.0
    """empirical estimators: pseudo-counts of the uniform prior over the support (and, for markov-empirical, of each
    transition row's over the types)"""
    estimator_forget: float = 1.0
    """empirical estimators: every count decays by this factor per task seen (1: a plain average)"""
    task_features: str = "arguments"
    """the task's encoding (learning.encoding): arguments (one-hots of its type and arguments, the thesis's) or
    arguments+goal (and its goal atoms: for tasks whose arguments do not show their goal)"""
    eval_every: int = 25_000
    """steps between greedy evaluations (best checkpoint selection)"""
    eval_tasks: int = 100
    """tasks per greedy evaluation"""
    log_every: int = 1_000
    """steps between metrics rows"""
    checkpoint_every: int = 5_000
    """steps between resumable checkpoints"""
    out: str | None = None
    """run folder (default runs/dqn/<domain>-<layout>-<horizon>-seed<seed>)"""


CHOICES = {
    "eps_schedule": ("time-constant", "reach"),
    "explore": ("factored", "uniform"),
    "target_bound": ("none", "return"),
    "task_features": TASK_FEATURES,
}
LEGACY = {
    "eps_schedule": "reach",
    "explore": "uniform",
    "demo_planner": "internal",
    "target_bound": "none",
    "stream": "iid",
    "estimator": "known",
    "estimator_prior": 1.0,
    "estimator_forget": 1.0,
    "task_features": "arguments",
}
"""What a checkpoint written before these settings existed was trained with."""


NAME = re.compile(r"[A-Za-z0-9_+-][A-Za-z0-9._+-]*")
"""What may name an output file or folder: letters, digits, '.', '_', '+', '-', not starting with a dot
(so never '..', never a hidden file, never a path)."""


def file_name(value, where, field: str) -> str:
    """`value` as a part of an output's name, or a one-line DomainError naming `where` (the file or option the
    value came from) and `field`: whatever a file read or an option contains, no output path leaves its folder."""
    text = str(value)
    if not NAME.fullmatch(text):
        raise DomainError(
            where,
            f"{field} {text!r} cannot name an output (letters, digits, '.', '_', '+', '-'; not starting with a dot)",
        )
    return text


def file_in(folder, name: str, where, field: str) -> Path:
    """folder/name for an output whose name was built from values read (`file_name` for each), checked to
    stay inside `folder`."""
    path = Path(folder) / name
    if not NAME.fullmatch(name) or path.parent.resolve() != Path(folder).resolve():
        raise DomainError(where, f"{field} makes {str(path)!r}, a path outside {folder}")
    return path


def bound_suffix(cfg) -> str:
    """What a run with a target bound, another stream than the i.i.d. one, another estimator than the known P or
    another task encoding than the thesis's adds to its folder and checkpoint names ('' for the thesis's setting)."""
    get = (lambda k, d: cfg.get(k, d)) if isinstance(cfg, dict) else (lambda k, d: getattr(cfg, k, d))
    bound, stream, est = get("target_bound", "none"), get("stream", "iid"), get("estimator", "known")
    features = get("task_features", "arguments")
    out = "" if features in (None, "arguments") else f"-features-{features.rpartition('+')[2]}"
    out += "" if stream in (None, "iid") else f"-stream-{stream}"
    if est not in (None, "known"):
        out += f"-est-{est}"
        forget = get("estimator_forget", 1.0)
        out += "" if forget in (None, 1.0) else f"-forget{forget:g}"
    return out + ("" if bound in (None, "none") else f"-bound-{bound}")


def run_name(domain: str, cfg, varied: str = "") -> str:
    """<domain>-<layout>-<horizon>-seed<N>[varied][-bound-<bound>]: a training run's folder name (under
    runs/dqn by default); `varied` names a sweep's other settings."""
    get = cfg.get if isinstance(cfg, dict) else lambda key: getattr(cfg, key)
    return f"{domain}-{get('layout')}-{get('horizon')}-seed{get('seed')}{varied}{bound_suffix(cfg)}"


def keep_freed_memory() -> None:
    """Let glibc's malloc keep freed memory instead of handing it back to the kernel.

    An update allocates and frees tensors of a few megabytes; by default glibc maps and
    unmaps them (or trims its heap) each time, and the page faults of touching fresh
    pages cost as much as the arithmetic (measured: a 721-row forward 6.9 -> 4.5 ms).
    Values are unchanged; the process keeps its peak memory. No-op off glibc.
    """
    try:
        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, 32 << 20)  # M_MMAP_THRESHOLD: heap, not mmap, below 32 MB
        libc.mallopt(-1, 1 << 30)  # M_TRIM_THRESHOLD: trim only above 1 GB free
        libc.mallopt(-2, 64 << 20)  # M_TOP_PAD: grow the heap 64 MB at a time
    except (OSError, AttributeError):
        pass


def domain_defaults(model, horizon: str) -> dict:
    """Config values from domain.toml: [training] (a table keyed by layout, by horizon, or by layout then
    horizon) and [reward] gamma."""
    names = {f.name for f in fields(Config)}
    table = dict(model.config.get("training", {}))
    out = {}
    if "gamma" in model.config.get("reward", {}):
        out["gamma"] = model.config["reward"]["gamma"]
    for key, value in table.items():
        if key not in names:
            raise DomainError(model.files["config"], f"[training] '{key}' is not a training setting")
        for selector in (model.layout, horizon):
            if isinstance(value, dict) and selector in value:
                value = value[selector]
        if isinstance(value, dict):
            raise DomainError(model.files["config"], f"[training] {key} has no entry for {model.layout} {horizon}")
        out[key] = value
    return out


def epsilon(cfg: Config, step: int) -> float:
    """ε at a step (cfg.eps_schedule)."""
    if cfg.eps_schedule == "time-constant":
        return cfg.eps_end + (cfg.eps_start - cfg.eps_end) * math.exp(-step / max(1, cfg.eps_decay_steps))
    frac = min(1.0, step / max(1, cfg.eps_decay_steps))
    return cfg.eps_start * (cfg.eps_end / cfg.eps_start) ** frac


def random_action(actions: np.ndarray, labels: np.ndarray, rng, factored: bool = True) -> int:
    """ε's random choice among the applicable ground actions: uniform, or factored as the network
    chooses (a type uniformly among the valid ones, then each argument head in turn uniformly
    among the values valid with the heads chosen before it)."""
    cand = np.asarray(actions)
    if factored:
        for col in range(labels.shape[1]):
            if len(cand) == 1:
                break
            values = labels[cand, col]
            options = np.unique(values)
            if len(options) > 1:
                cand = cand[values == options[rng.integers(len(options))]]
    return int(cand[rng.integers(len(cand))]) if len(cand) > 1 else int(cand[0])


def demonstrations(
    model, enc: Encoding, cfg: Config, r_goal: float, scale: float, terminal_reset: bool, progress: bool = True
) -> tuple[Replay, np.ndarray]:
    """The demo memory: every action transition of the first demo_tasks myopic-oracle outcomes (autos
    store none), and per transition the discounted return the oracle's plan earned from there to its
    task's completion (NaN where the oracle failed): what a myopic Q of the demonstrated action should
    be at least, and not much more."""
    if cfg.demo_tasks <= 0:
        return Replay(1, enc.n_words), np.zeros(0)
    from oracles.rollouts import cached_rollout

    records = cached_rollout(model, cfg.demo_seed, cfg.demo_tasks, planner=cfg.demo_planner, progress=progress)
    per_reset = model.config.get("stream", {}).get("tasks_per_reset", 50)
    rows, returns = [], []
    for rec in records:
        if rec.auto or not rec.plan:
            continue
        task = model.tasks.get(rec.task).index
        packed = enc.pack(rec.states)
        last = len(rec.plan) - 1
        first = len(rows)
        for k, a in enumerate(rec.plan):
            done = k == last and rec.success
            s2 = enc.pack([rec.after])[0] if done else packed[k + 1]
            kind = CONTINUE
            if done:
                kind = TERMINAL if terminal_reset and rec.index % per_reset == per_reset - 1 else COMPLETE
            r = step_reward(model.action_cost[a], done, scale, r_goal)
            rows.append((packed[k], task, a, r, s2, kind))
        g = 0.0 if rec.success else float("nan")
        for row in reversed(rows[first:]):
            g = row[3] + cfg.gamma * g
            returns.append(g)
        returns[first:] = returns[first:][::-1]
    demos = Replay(max(1, len(rows)), enc.n_words)
    for row in rows:
        demos.add(*row)
    return demos, np.array(returns)


def eval_stream_seed(seed: int) -> int:
    """The seed of a run's own greedy-check stream: apart from its training stream (seeded by `seed`), and the
    same for every tool that replays the trainer's check (`learning.capacity`)."""
    return 10_000 + seed


def greedy_evaluation(
    vf: ValueFunction, model, seed: int, n_tasks: int, gamma: float, r_goal: float, scale: float, task_stream=None
) -> dict:
    """Success rate, PDDL cost, actions and discounted return per task of the greedy policy on a seeded stream
    (`task_stream`: a declared stream of `planning.world.streams`; None: i.i.d. from P)."""
    stream, world = TaskStream(model, seed, task_stream), PersistentWorld(model)
    returns = []
    for _ in range(n_tasks):
        task, reset = stream.next()
        if reset is not None:
            world.reset(reset)
        if world.begin(task):
            returns.append(r_goal)
            continue
        g, k = 0.0, 0
        while world.task is not None:
            a = int(vf.greedy([world.state], task.index)[0])
            step = world.act(a)
            g += gamma**k * step_reward(step.cost, step.completed, scale, r_goal)
            k += 1
        returns.append(g)
    outs = world.outcomes
    n = len(outs)
    return {
        "success_rate": sum(o.success for o in outs) / n,
        "cost_per_task": sum(o.cost for o in outs) / n,
        "actions_per_task": sum(o.actions for o in outs) / n,
        "task_return": float(np.mean(returns)),
    }


class Trainer:
    """Algorithm 1 with its state (networks, memories, world, stream, counters) kept for checkpoints.

    `device` (`learning.device`): where the online and target networks, their minibatch passes and the
    optimizer step run (None: the CPU). On another device than the CPU the trainer acts, evaluates and
    checkpoints through `actor`, a CPU copy of the online network refreshed after every update (one copy
    of the flat parameter buffer); on the CPU `actor` is the online network itself. The device is how a
    run is computed, not what it learns: it is not a setting of the run (Config), and a run may resume on
    another device."""

    def __init__(self, cfg: Config, progress: bool = True, device=None):
        # -- setup: model, encodings, R_goal, seeding --------------------------------------------
        check_config(cfg)
        torch.set_num_threads(1)  # one thread per run: parallel runs share the cores, not a pool
        keep_freed_memory()
        self.cfg, self.progress = cfg, progress
        self.model = model = compile_domain(cfg.domain, cfg.layout)
        cfg.layout = model.layout
        self.out = run_folder(cfg, model)
        cli.check_writable(self.out, folder=True)  # before the demonstrations are planned
        cfg.out = str(self.out)
        self.scale = cost_scale(model)
        self.r_goal = float(cfg.goal_reward if cfg.goal_reward is not None else goal_reward(model))
        cfg.goal_reward = self.r_goal
        self.y_max = (
            None
            if cfg.target_bound == "none"
            else self.r_goal
            if cfg.horizon == "myopic"
            else self.r_goal / (1.0 - cfg.gamma)
        )
        stream_cfg = model.config.get("stream", {})
        self.terminal_reset = bool(stream_cfg.get("terminal_reset", False))
        self.per_reset = stream_cfg.get("tasks_per_reset", 50)
        random.seed(cfg.seed)
        np.random.seed(cfg.seed)
        torch.manual_seed(cfg.seed)
        self.rng = np.random.default_rng(cfg.seed)
        self.enc = Encoding(model, cfg.task_features)
        self.type_of = self.enc.action_type
        self.identity = identity(model)  # the domain as it was when the run started, in every checkpoint

        # -- Algorithm 1, line 1: replay memory, online and target networks ---------------------
        self.device = torch.device("cpu") if device is None else torch.device(device)
        self.net = build_network(self.enc, cfg.hidden).to(self.device)
        self.target = build_network(self.enc, cfg.hidden).to(self.device)
        self.target.load_state_dict(self.net.state_dict())
        self.boundary = BoundaryCache()  # target values of replayed completion states, per sync
        self.opt = FlatAdam(self.net.parameters(), lr=cfg.lr)  # the parameters move into one flat buffer
        self.actor = self.net if self.device.type == "cpu" else self._cpu_copy()
        self.greedy = LiveGreedy(self.actor)  # acting: the online net's current weights, in numpy
        self.memory = Replay(cfg.buffer_size, self.enc.n_words)
        self.demos, self.demo_returns = demonstrations(
            model, self.enc, cfg, self.r_goal, self.scale, self.terminal_reset, progress
        )
        self.slots = SlotCache(
            self.enc,
            self.demos.capacity + self.memory.capacity,  # encodings, per slot
            self.net.mask_bits,
        )

        # -- line 2: the world and the task stream ----------------------------------------------
        self.task_stream = stream_of(model, cfg.stream)
        self.stream = TaskStream(model, cfg.seed, self.task_stream)
        self.estimator = build_estimator(
            cfg.estimator, model, self.task_stream, cfg.estimator_prior, cfg.estimator_forget
        )
        self.world = PersistentWorld(model)
        self.step = 0
        self.tasks_done = 0
        self.recent = deque(maxlen=100)  # (success, task return) of the last 100 tasks
        self.type_counts = np.zeros(len(self.enc.type_names), dtype=np.int64)
        self.stats = {"q": [], "y": [], "loss": []}
        self.best = None
        self.task_return, self.task_k = 0.0, 0
        self.metrics = self.out / "metrics.jsonl"
        self.out.mkdir(parents=True, exist_ok=True)

    def _cpu_copy(self) -> FactoredQNet:
        """A CPU network whose parameters are views into one flat buffer laid out as the optimizer's
        (`FlatAdam.flat`), so one copy refreshes it (`_refresh_actor`)."""
        actor = build_network(self.enc, self.cfg.hidden)
        sizes = [p.numel() for p in actor.parameters()]
        self.actor_flat = torch.empty(sum(sizes))
        for p, view in zip(actor.parameters(), self.actor_flat.split(sizes)):
            p.data = view.view(p.shape)
        self.actor_flat.copy_(self.opt.flat.detach())
        return actor.eval()

    def _refresh_actor(self) -> None:
        """The CPU copy of the online weights, after they changed (an update, a resume)."""
        if self.actor is not self.net:
            self.actor_flat.copy_(self.opt.flat.detach())

    # ---- the persistent world ------------------------------------------------------------------
    def _last_in_episode(self) -> bool:
        return self.terminal_reset and (self.stream.count - 1) % self.per_reset == self.per_reset - 1

    def _store(self, s: int, task: int, action: int, reward: float, s2: int, kind: int) -> None:
        packed = self.enc.pack([s, s2])
        self.memory.add(packed[0], task, action, reward, packed[1], kind)

    def _finish_task(self, success: bool) -> None:
        self.recent.append((success, self.task_return))
        self.tasks_done += 1
        self.task_return, self.task_k = 0.0, 0
        self.world.outcomes.clear()  # outcomes are summarised in `recent`; keep memory flat

    def _next_task(self) -> None:
        """Draw tasks until one is open; an already-satisfied task is the AUTO transition (line 6)."""
        while True:
            task, reset = self.stream.next()
            if reset is not None:
                self.world.reset(reset)
                self.estimator.restart()
            self.estimator.observe(task)
            before = self.world.state
            if not self.world.begin(task):
                return
            kind = TERMINAL if self._last_in_episode() else COMPLETE
            self._store(before, task.index, self.enc.AUTO, self.r_goal, self.world.state, kind)
            self.task_return = self.r_goal
            self._finish_task(True)

    # ---- one update (lines 8-20) ---------------------------------------------------------------
    def update(self, batch: dict | None = None) -> None:
        """One gradient step on a minibatch with the protected demo share (or on the given one)."""
        cfg = self.cfg
        if batch is None:
            batch = mixed_batch(self.memory, self.demos, cfg.batch_size, cfg.demo_fraction, self.rng)
        self.descend(batch, self.targets(batch))

    def targets(self, batch: dict) -> torch.Tensor:
        """The minibatch's Double-DQN targets (lines 9-19)."""
        cfg = self.cfg
        y = td_targets(
            self.net, self.target, self.enc, batch, cfg.gamma, cfg.horizon, self.boundary, self.slots, self.estimator
        )
        return y if self.y_max is None else y.clamp_(max=self.y_max)

    def descend(self, batch: dict, y: torch.Tensor, parts: dict | None = None) -> None:
        """The gradient step on the Huber loss toward y (line 20); `parts` collects its CPU seconds."""
        t = time.process_time()
        if "slots" in batch:
            obs, valid, mb = self.slots.observe(batch)
        else:
            obs, valid, mb = (
                self.enc.observe(batch["states"], batch["tasks"]),
                self.enc.valid_for(batch["states"], batch["tasks"]),
                None,
            )
        masks = None if mb is None else self.net.masks_from_bits(mb)
        dev = self.device
        q = self.net.q_taken(
            torch.from_numpy(obs).to(dev),
            torch.from_numpy(valid).to(dev),
            torch.from_numpy(batch["actions"]).to(dev),
            masks,
        )
        loss = F.smooth_l1_loss(q, y.to(dev))
        self.opt.zero_grad()  # a parameter the loss does not reach steps with a zero gradient, as in the
        loss.backward()  # per-head forward, where every head was in every loss (Adam's moments decay)
        t1 = time.process_time()
        self.opt.step(self.cfg.grad_clip)
        self._refresh_actor()
        if parts is not None:
            parts["gradient"] = parts.get("gradient", 0.0) + t1 - t
            parts["optimizer"] = parts.get("optimizer", 0.0) + time.process_time() - t1
        self.stats["q"].append(float(q.detach().mean()))
        self.stats["y"].append(float(y.mean()))
        self.stats["loss"].append(float(loss.detach()))

    def sync_target(self) -> None:
        """Copy the online weights into the target network; its cached boundary values are stale."""
        self.target.load_state_dict(self.net.state_dict())
        self.boundary.clear()
        self.slots.sync()

    def act(self, state: int, task: int, eps: float) -> int:
        """ε-greedy over the applicable actions (line 5)."""
        actions = self.model.applicable(state)
        if self.rng.random() < eps:
            return random_action(actions, self.enc.labels, self.rng, self.cfg.explore == "factored")
        valid = np.zeros(self.enc.n_actions, dtype=bool)
        valid[actions] = True
        return self.greedy(self.enc.observe(self.enc.pack([state]), [task])[0], valid)

    # ---- the loop (lines 3-28) -----------------------------------------------------------------
    def env_step(self, eps: float) -> None:
        """One environment step: act ε-greedily, store the transition, and move on when the task ends."""
        if self.world.task is None:
            self._next_task()
        state, task = self.world.state, self.world.task.index
        a = self.act(state, task, eps)  # line 5
        step = self.world.act(a)  # line 6
        r = step_reward(step.cost, step.completed, self.scale, self.r_goal)
        kind = CONTINUE  # within task or timeout
        if step.completed:
            kind = TERMINAL if self._last_in_episode() else COMPLETE
        self._store(state, task, a, r, self.world.state, kind)  # line 7
        self.type_counts[self.type_of[a]] += 1
        self.task_return += self.cfg.gamma**self.task_k * r
        self.task_k += 1
        self.step += 1
        if step.completed or step.abandoned:  # lines 21, 25-27
            self._finish_task(step.completed)
            self._next_task()

    def train(self) -> dict:
        """Run until cfg.steps, logging, evaluating and checkpointing; returns the last metrics row."""
        return train_loop([self], self.update, self.progress)[0]

    # ---- metrics, evaluation, checkpoints ------------------------------------------------------
    def _log(self, **extra) -> dict:
        recent = list(self.recent)
        counts = self.type_counts
        total = max(1, int(counts.sum()))
        mean = lambda xs: float(np.mean(xs)) if xs else float("nan")
        row = {
            "step": self.step,
            "tasks": self.tasks_done,
            "success_rate": mean([s for s, _ in recent]),
            "task_return": mean([g for _, g in recent]),
            "selected_q": mean(self.stats["q"]),
            "td_target": mean(self.stats["y"]),
            "loss": mean(self.stats["loss"]),
            "action_share": {n: round(int(c) / total, 5) for n, c in zip(self.enc.type_names, counts)},
            **{k: round(v, 4) for k, v in extra.items()},
        }
        self.type_counts[:] = 0
        self.stats = {"q": [], "y": [], "loss": []}
        self.metrics.parent.mkdir(parents=True, exist_ok=True)
        with open(self.metrics, "a") as f:
            f.write(json.dumps(row) + "\n")
        return row

    def demo_q_bias(self) -> float:
        """Mean of Q(s, a) minus the return the myopic oracle's plan earned from there, over the
        demonstrations: a myopic Q near its optimum sits a little above 0; a Q that diverges (the
        deadly triad of bootstrapping, off-policy data and function approximation) far above."""
        ok = np.flatnonzero(np.isfinite(self.demo_returns))
        if not len(ok):
            return float("nan")
        d = self.demos.take(ok)
        obs = torch.from_numpy(self.enc.observe(d["states"], d["tasks"]))
        valid = torch.from_numpy(self.enc.valid_for(d["states"], d["tasks"]))
        with torch.inference_mode():
            q = self.actor(obs, valid).gather(1, torch.from_numpy(d["actions"])[:, None])[:, 0].numpy()
        return round(float(np.mean(q - self.demo_returns[ok])), 4)

    def _evaluate(self) -> None:
        self.net.eval()
        r = greedy_evaluation(
            ValueFunction(self.actor, self.enc),
            self.model,
            eval_stream_seed(self.cfg.seed),
            self.cfg.eval_tasks,
            self.cfg.gamma,
            self.r_goal,
            self.scale,
            self.task_stream,
        )
        if self.cfg.horizon == "myopic":
            r["demo_q_bias"] = self.demo_q_bias()
        self.net.train()
        r["step"] = self.step
        with open(self.metrics, "a") as f:
            f.write(json.dumps({"eval": r}) + "\n")
        score = (r["success_rate"], r["task_return"])
        if self.best is None or score > tuple(self.best["score"]):
            self.best = {"score": list(score), "step": self.step, "eval": r}
            save_checkpoint(
                self.out / "best.pt",
                network_payload(
                    self.actor, self.enc, {**self.identity, "step": self.step, "eval": r, "config": asdict(self.cfg)}
                ),
            )

    def save(self) -> Path:
        """Everything needed to resume, atomically, in last.pt."""
        w = self.world
        payload = network_payload(
            self.actor,
            self.enc,
            {
                **self.identity,
                "config": asdict(self.cfg),
                "target": self.target.state_dict(),
                "opt": self.opt.state_dict(),
                "step": self.step,
                "tasks_done": self.tasks_done,
                "recent": list(self.recent),
                "best": self.best,
                "task_return": self.task_return,
                "task_k": self.task_k,
                "memory": self.memory.state_dict(),
                "rng": self.rng.bit_generator.state,
                "stream": {
                    "rng": self.stream.rng.bit_generator.state,
                    "count": self.stream.count,
                    "previous": None if self.stream.previous is None else self.stream.previous.index,
                },
                "estimator": self.estimator.state_dict(),
                "world": {
                    "state": w.state,
                    "task": None if w.task is None else w.task.index,
                    "cost": w._cost,
                    "actions": w._actions,
                },
                "torch_rng": torch.get_rng_state(),
            },
        )
        return save_checkpoint(self.out / "last.pt", payload)

    def resume(self, path) -> None:
        """Continue from a last.pt written by `save` (same layout, horizon and seed)."""
        p = read_checkpoint(path)
        old = p.get("config", {})
        # The reward and discount define the learning problem: a run continues only under its own
        # (a calibration written after the run started must not change R_goal halfway).
        for key in ("domain", "layout", "horizon", "seed", "hidden", "goal_reward", "gamma", *LEGACY):
            was = old.get(key, LEGACY.get(key))
            if was != getattr(self.cfg, key):
                hint = (
                    f" (pass --{key.replace('_', '-')} {was} to continue it)" if key in ("goal_reward", *LEGACY) else ""
                )
                raise DomainError(path, f"was trained with {key}={was!r}, not {getattr(self.cfg, key)!r}{hint}")
        check_domain(path, p, self.model)
        if p["signature"] != self.enc.signature():
            raise DomainError(path, "was trained on a different compilation of this layout")
        self.net.load_state_dict(p["net"])
        self.target.load_state_dict(p["target"])
        self.boundary.clear()
        self.slots.sync()
        self.opt.load_state_dict(p["opt"])
        self._refresh_actor()
        self.memory.load_state_dict(p["memory"])
        self.step, self.tasks_done, self.best = p["step"], p["tasks_done"], p["best"]
        self.recent.extend(tuple(x) for x in p["recent"])
        self.task_return, self.task_k = p["task_return"], p["task_k"]
        self.rng.bit_generator.state = p["rng"]
        self.stream.rng.bit_generator.state = p["stream"]["rng"]
        self.stream.count = p["stream"]["count"]
        previous = p["stream"].get("previous")
        self.stream.previous = None if previous is None else self.model.tasks[previous]
        if "estimator" in p:
            self.estimator.load_state_dict(p["estimator"])
        w = p["world"]
        self.world.state = w["state"]
        self.world.task = None if w["task"] is None else self.model.tasks[w["task"]]
        self.world._cost, self.world._actions = w["cost"], w["actions"]
        torch.set_rng_state(p["torch_rng"])
        self._trim_metrics()

    def _trim_metrics(self) -> None:
        """Drop metrics rows written after the checkpoint resumed from: those steps run again."""
        if not self.metrics.is_file():
            return
        rows, torn = read_metrics(self.metrics)
        if torn:
            print(
                f"{self.metrics}: dropped a half-written last line (the run was stopped while writing it)",
                file=sys.stderr,
            )
        steps = [row.get("step", row.get("eval", {}).get("step", 0)) for row in rows]
        bad = next((k for k, at in enumerate(steps) if not isinstance(at, (int, float))), None)
        if bad is not None:
            raise DomainError(self.metrics, f"row {bad + 1} has no step; delete the file or pass --fresh to start over")
        keep = [row for row, at in zip(rows, steps) if at <= self.step]
        write_text(self.metrics, "".join(json.dumps(row) + "\n" for row in keep))


def train_loop(trainers: list, update, progress: bool = True) -> list[dict]:
    """Algorithm 1's loop (lines 3-28) for runs in lockstep: one `Trainer`, or the seeds of a
    `learning.q.seeds.SeedBatch`. Each run takes its environment step, then `update()` makes every run's
    gradient step; target syncs, metrics rows, evaluations and checkpoints fall on the same steps for
    all. Runs until cfg.steps; returns each run's last metrics row (its steps_per_s and updates_per_s
    are each run's own, so a batch of S runs does S times as many)."""
    cfg, first = trainers[0].cfg, trainers[0]
    for t in trainers:
        if t.world.task is None:
            t._next_task()
    seeds = "" if len(trainers) == 1 else " seeds " + ",".join(str(t.cfg.seed) for t in trainers)
    bar = tqdm(
        total=cfg.steps,
        initial=first.step,
        desc=f"dqn {first.model.layout} {cfg.horizon}{seeds}",
        unit="step",
        disable=not progress,
        smoothing=0.05,
    )
    rows, t0, s0, updates = [{} for _ in trainers], time.perf_counter(), first.step, 0
    while first.step < cfg.steps:
        for t in trainers:
            t.env_step(epsilon(cfg, t.step))  # lines 5-7, 21, 25-27
        step = first.step
        if step >= cfg.learning_starts and step % cfg.train_every == 0:
            update()  # lines 8-20
            updates += 1
        if step % cfg.target_every == 0:  # lines 22-24
            for t in trainers:
                t.sync_target()
        if step % cfg.log_every == 0:
            dt = time.perf_counter() - t0
            rate = {"eps": epsilon(cfg, step), "steps_per_s": (step - s0) / dt, "updates_per_s": updates / dt}
            rows = [t._log(**rate) for t in trainers]
            t0, s0, updates = time.perf_counter(), step, 0
            mean = {
                key: float(np.mean([r[key] for r in rows])) for key in ("success_rate", "task_return", "selected_q")
            }
            bar.set_postfix(
                success=f"{mean['success_rate']:.2f}", ret=f"{mean['task_return']:.1f}", q=f"{mean['selected_q']:.1f}"
            )
        if step % cfg.eval_every == 0 or step == cfg.steps:
            for t in trainers:
                t._evaluate()
        if step % cfg.checkpoint_every == 0 or step == cfg.steps:
            for t in trainers:
                t.save()
        bar.update(1)
    bar.close()
    return rows


def read_metrics(path, strict: bool = True) -> tuple[list[dict], bool]:
    """(the rows of a run's metrics.jsonl, whether a half-written last line was dropped).

    The file is appended to, so a run killed mid-write leaves a torn last line: it is
    dropped. A bad line before the last is a one-line DomainError (strict) or skipped.
    """
    path = Path(path)
    try:
        lines = [line for line in path.read_text(errors="replace").splitlines() if line.strip()]
    except OSError as e:
        raise DomainError(path, f"cannot read the run's metrics ({e.strerror})") from None
    rows = []
    for k, line in enumerate(lines):
        try:
            row = json.loads(line)
        except ValueError:
            row = None
        if isinstance(row, dict):
            rows.append(row)
        elif k == len(lines) - 1:
            return rows, True
        elif strict:
            raise DomainError(path, f"line {k + 1} is not a metrics row; delete the file or pass --fresh to start over")
    return rows, False


def last_row(path) -> dict:
    """The last log row (not an evaluation) of a run's metrics.jsonl; {} if it logged none."""
    rows = read_metrics(path)[0] if Path(path).is_file() else []
    return next((r for r in reversed(rows) if "eval" not in r), {})


def check_config(cfg: Config) -> None:
    """A one-line DomainError for a setting no run can have, before anything is planned or written."""
    if cfg.horizon not in HORIZONS:
        raise DomainError("--horizon", f"'{cfg.horizon}' is neither myopic nor anticipatory")
    for key, allowed in CHOICES.items():
        if getattr(cfg, key) not in allowed:
            raise DomainError(f"--{key.replace('_', '-')}", f"'{getattr(cfg, key)}' is not one of {', '.join(allowed)}")


def make_config(domain: str | None = None, layout: str | None = None, horizon: str = "anticipatory", **given) -> Config:
    """A run's settings: Table A.2, then domain.toml [training] (keyed by layout and horizon), then `given`
    (a None value counts as not given), checked; learning.dqn's command line and a sweep's items alike."""
    domain = domain or Config.domain
    if horizon not in HORIZONS:
        raise DomainError("--horizon", f"'{horizon}' is neither myopic nor anticipatory")
    model = compile_domain(domain, layout)
    values = {**domain_defaults(model, horizon), **{k: v for k, v in given.items() if v is not None}}
    cfg = Config(**{**values, "domain": domain, "layout": model.layout, "horizon": horizon})
    check_config(cfg)
    return cfg


def run_folder(cfg: Config, model) -> Path:
    """The run's folder: cfg.out, else runs/dqn/<domain>-<layout>-<horizon>-seed<N>[-bound-<bound>] with each part
    checked to name a folder (a layout named '../x' in domain.toml writes nowhere else)."""
    if cfg.out:
        return Path(cfg.out)
    file_name(model.name, model.files["domain"], "domain name")
    file_name(model.layout, model.files["config"], "layout")
    file_name(cfg.seed, "--seed", "seed")
    return file_in(
        "runs/dqn", run_name(model.name, {**asdict(cfg), "layout": model.layout}), "--out", "the default run folder"
    )


def train_run(cfg: Config, fresh: bool = False, progress: bool = True, device=None) -> Trainer:
    """Train the run of `cfg` to cfg.steps, resuming it where it stopped: the one way a run starts or goes
    on (learning.dqn, experiments.sweep's items). Returns the trainer, its run ended (`train_runs`)."""
    return train_runs([cfg], fresh, progress, device)[0]


def train_runs(cfgs: list, fresh: bool = False, progress: bool = True, device=None) -> list:
    """Train runs that differ only in their seed to cfg.steps, in one process, resuming each where it
    stopped; several are trained together with their updates batched (`learning.q.seeds`), one alone as
    always. Returns the trainers, their runs ended.

    Each run folder is locked (`planning.atomic.OutputLock`) before anything is written in it and until
    training ends: a second trainer of it stops at once with a one-line error instead of appending every
    metrics row twice. A run with a last.pt continues from it (not with `fresh`), the metrics rows logged
    after that checkpoint dropped (they are logged again); a run without one starts over, and what an
    earlier start left (its metrics rows, best.pt, last.pt) is deleted, so metrics.jsonl never holds a
    step twice (a run killed after its first rows but before its first checkpoint read 100, 200, 100, ...).
    Runs trained together resume together: their checkpoints must be at one step. `device`: a `--device`
    (`learning.device`; None: the CPU); several seeds together train on the CPU only.
    """
    from learning.device import check_device

    from .seeds import SeedBatch, check_together

    device = check_device(device)
    for cfg in cfgs:
        check_config(cfg)
    if len(cfgs) > 1:
        check_together(cfgs)
        if device is not None and device.type != "cpu":
            raise DomainError(
                "--device", "several seeds in one process train on the CPU only; train them one at a time"
            )
    model = compile_domain(cfgs[0].domain, cfgs[0].layout)
    outs = [run_folder(cfg, model) for cfg in cfgs]
    if len(set(outs)) < len(outs):
        raise DomainError("--out", "the runs trained together need a folder each; leave --out out")
    with ExitStack() as locks:
        for out in outs:
            cli.check_writable(out, folder=True)
            out.mkdir(parents=True, exist_ok=True)  # the lock lives inside the folder: made before it is taken
            locks.enter_context(OutputLock(out, "training run"))
        trainers = [Trainer(cfg, progress=progress, device=device) for cfg in cfgs]
        batch = SeedBatch(trainers) if len(trainers) > 1 else None
        for trainer in trainers:
            _start(trainer, fresh)
        if batch is not None:
            batch.resumed()
            steps = {t.cfg.seed: t.step for t in trainers}
            if len(set(steps.values())) > 1:
                at = ", ".join(f"seed {k} at step {v}" for k, v in steps.items())
                raise DomainError("--seed", f"the runs stopped at different steps ({at}); resume them one at a time")
        train_loop(trainers, trainers[0].update if batch is None else batch.update, progress)
    return trainers


def _start(trainer: Trainer, fresh: bool) -> None:
    """Resume the trainer from its last.pt, or clear what an earlier start left (`train_runs`)."""
    last = trainer.out / "last.pt"
    if last.is_file() and not fresh:
        trainer.resume(last)
        print(f"resumed {last} at step {trainer.step}", file=sys.stderr)
        return
    stale = [p for p in (trainer.metrics, trainer.out / "best.pt", last) if p.is_file()]
    if stale and not fresh:
        names = ", ".join(p.name for p in stale)
        print(
            f"{trainer.out}: no last.pt to resume from; the run starts over ({names} of its earlier start dropped)",
            file=sys.stderr,
        )
    for p in stale:
        p.unlink()
