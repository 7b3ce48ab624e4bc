"""A Gymnasium environment over any compiled domain folder and layout, the persistent task stream inside.

    import gymnasium, learning.gym_env                  # importing the module registers the ids
    env = gymnasium.make("AnticipatoryMinimal-grid-v0")  # or AnticipatoryRestaurant-two-room-v0, -three-room-v0
    env = gymnasium.make("Anticipatory-v0", domain="path/to/folder", layout="name")   # any domain folder
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(int(np.flatnonzero(info["action_mask"])[0]))

(`gymnasium.make("learning.gym_env:AnticipatoryMinimal-grid-v0")` imports the module itself.)

Observation: the learner's encoding (`learning.encoding.Encoding.observe`): the state's atom
bits, then the task's one-hots; a float32 0/1 `Box` (default) or, with `observation="multibinary"`,
an int8 `MultiBinary`.

Actions: `Discrete` over the layout's ground actions (`model.actions`). Every `reset` and `step`
returns `info["action_mask"]`, int8, 1 for the actions applicable in the current state, and
`action_masks()` gives the same as bool (the sb3-contrib convention, so MaskablePPO works as
is). With `factored=True` the action is a `MultiDiscrete` over the Table A.1 heads (action type,
then the argument heads of `planning.domain.factored`, each with its *none* value);
`info["action_mask"]` / `action_masks()` are then the heads' masks concatenated (what
MaskablePPO takes for MultiDiscrete) and `info["head_masks"]` the same as a tuple per head (what
`MultiDiscrete.sample(mask=...)` takes). Per-head masks are approximate: each head's value is
allowed where SOME applicable action has it, but the heads depend on one another (the type
decides which arguments exist, `pick`'s object decides where it can be picked), so a vector of
individually allowed values may name no applicable action; that is then an invalid action.

An invalid action (a ground action not applicable in the state, or a factored vector naming
none) is a no-op: the world is unchanged, it costs nothing in PDDL units, it uses one of the
task's actions (so a task cannot be stalled forever), and its reward is `-invalid_penalty`
(default: the dearest action's cost / cost_scale, so it is never better than acting).
`check_env`'s unmasked samples rely on it; a masked agent never takes one. Something that is
not an element of the action space at all (1.7, True, a vector where a scalar is due, a value
past the space) is a ValueError naming it (`action_value`), never rounded to an action.

Reward: `learning.reward.step_reward`, the trainer's: -cost / cost_scale, plus R_goal (domain.toml
[reward], else the layout's calibration file) when the action completes the task. A task that
is already satisfied when drawn completes at once, at zero cost (the persistent-world rule);
within an episode such completions earn R_goal each, added to the reward of the step after
which they happen (the trainer's AUTO transition, here without its one step of discount), so
leaving the world prepared pays; those drawn by `reset` earn nothing (no action led there).

Episodes (`horizon`):
  anticipatory (default)  an episode is one block of tasks between two world resets: domain.toml
      [stream] tasks_per_reset (50 in the restaurant; the minimal example's episode of 2). The
      world persists across the block's tasks. When the block's last task ends the episode ends:
      `terminated` if the domain declares its resets terminal ([stream] terminal_reset, the
      minimal example), else `truncated` (the world would go on; the re-sampling is the stream's,
      so bootstrap from the last observation).
  myopic  every task is an episode: `terminated` when it completes, `truncated` when it is
      abandoned; `reset()` then continues the same persistent world with the stream's next task
      (re-sampled every tasks_per_reset tasks), `reset(seed=...)` starts a new stream.
A task not done within [stream] max_actions (64) actions, invalid ones included, is abandoned:
its cost stays charged, `info["abandoned"]` is set and, in the anticipatory horizon, the episode
goes on with the next task (neither terminated nor truncated: abandonment is a rule of the
world, not the end of the agent's horizon); in the myopic horizon it is `truncated`.
`reset()` without a seed in the anticipatory horizon drops what is left of the current block.

`info`: `task` (the task the observation carries), `task_cost` and `task_actions` (its PDDL cost
and actions so far), `completed` / `abandoned` / `invalid` (what this step did), `finished`
(None, or the task this step ended: task, cost, actions, success), `auto_completed` (tasks
completed on drawing, after this step), `tasks_done` (tasks ended in this episode) and
`action_mask`.

Determinism: `reset(seed=s)` seeds the task stream and the world resets from `np_random`, and
`step` draws nothing else, so a seed fixes the whole episode and the ones after it.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from planning.cli import DEFAULT_DOMAIN
from planning.domain.compiler import compile_domain
from planning.domain.folder import layouts
from planning.errors import DomainError
from planning.world.task_stream import PersistentWorld, TaskStream

from .encoding import Encoding
from .reward import cost_scale, goal_reward, step_reward

ROOT = Path(__file__).resolve().parents[1]
HORIZONS = ("anticipatory", "myopic")
GENERIC_ID = "Anticipatory-v0"


def _folder(domain) -> Path:
    """A domain folder as given, else relative to the project (so bundled names work from anywhere)."""
    p = Path(domain)
    return p if p.is_dir() or p.is_absolute() else (ROOT / p if (ROOT / p).is_dir() else p)


def _goal_reward(model) -> float:
    try:
        return goal_reward(model)  # domain.toml, or ./results calibration
    except DomainError:
        return goal_reward(model, ROOT / "results")  # the project's calibration files


class AnticipatoryEnv(gym.Env):
    """The persistent, anticipatory task stream of a domain folder as a Gymnasium environment."""

    metadata = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(
        self,
        domain: str = DEFAULT_DOMAIN,
        layout: str | None = None,
        *,
        factored: bool = False,
        observation: str = "box",
        horizon: str = "anticipatory",
        invalid_penalty: float | None = None,
        goal_reward: float | None = None,
        max_actions: int | None = None,
        tasks_per_reset: int | None = None,
        render_mode: str | None = None,
    ):
        if horizon not in HORIZONS:
            raise DomainError("horizon", f"'{horizon}' is neither anticipatory nor myopic")
        if observation not in ("box", "multibinary"):
            raise DomainError("observation", f"'{observation}' is neither box nor multibinary")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise DomainError("render_mode", f"'{render_mode}' is not one of {self.metadata['render_modes']}")
        self.model = model = compile_domain(_folder(domain), layout)
        self.enc = Encoding(model)
        self.factored, self.horizon, self.render_mode = factored, horizon, render_mode
        stream = model.config.get("stream", {})
        self.max_actions = int(max_actions or stream.get("max_actions", 64))
        self.tasks_per_reset = int(tasks_per_reset or stream.get("tasks_per_reset", 50))
        self.terminal_reset = bool(stream.get("terminal_reset", False))
        self.scale = cost_scale(model)
        self.r_goal = float(goal_reward if goal_reward is not None else _goal_reward(model))
        self.invalid_penalty = float(
            invalid_penalty if invalid_penalty is not None else max(model.action_cost) / self.scale
        )
        n = self.enc.obs_dim
        self.observation_space = (
            spaces.Box(0.0, 1.0, (n,), dtype=np.float32) if observation == "box" else spaces.MultiBinary(n)
        )
        self._int_obs = observation == "multibinary"
        fa = self.enc.factored
        self.heads, self.head_sizes = list(fa.heads), [len(v) for v in fa.vocab]
        self.labels = fa.labels  # (ground actions, heads): no AUTO row
        self.action_space = spaces.MultiDiscrete(self.head_sizes) if factored else spaces.Discrete(model.n_actions)
        self._stream: TaskStream | None = None
        self._world: PersistentWorld | None = None

    # ---- the stream ------------------------------------------------------------------------
    def _open_next(self, stop_at_block_end: bool) -> tuple[list, bool]:
        """Draw tasks until one is open: (the tasks completed on drawing, whether the block ended first)."""
        autos = []
        for _ in range(100 * self.tasks_per_reset + 1000):
            if stop_at_block_end and self._stream.count % self.tasks_per_reset == 0:
                return autos, True
            task, reset = self._stream.next()
            if reset is not None:
                self._world.reset(reset)
                self._episode_done = 0
            if not self._world.begin(task):
                self._task, self._task_actions, self._task_cost = task, 0, 0
                return autos, False
            autos.append(task.name)
            self._episode_done += 1
        raise DomainError(self.model.layout, "every task drawn is already satisfied: no task to act on")

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is not None or self._stream is None:
            self._stream = TaskStream(self.model, int(self.np_random.integers(2**63)))
            self._stream.tasks_per_reset = self.tasks_per_reset
            self._world = PersistentWorld(self.model, max_actions=2**62)  # the budget is kept here
        else:
            if self._world.task is not None:
                self._world.abandon()  # an unfinished task is given up
            k = self._stream.count % self.tasks_per_reset
            if self.horizon == "anticipatory" and k:
                self._stream.count += self.tasks_per_reset - k  # the rest of the block is dropped
        self._episode_done = 0
        autos, _ = self._open_next(stop_at_block_end=False)
        self._update_mask()
        return self._obs(), self._info(auto_completed=autos)

    @property
    def state(self) -> int:
        """The world state (the compiled model's int bitset; `model.describe` prints it)."""
        return self._world.state

    @property
    def task(self):
        """The task the last observation carries (`planning.domain.tasks.Task`)."""
        return self._task

    # ---- acting ----------------------------------------------------------------------------
    def action_value(self, action):
        """The action as the space's element: an int (Discrete) or an int64 vector (MultiDiscrete).

        An action that is not an element is a ValueError naming it, never rounded into one: a
        float with a fractional part (1.7 is not action 1), a bool, a string, another shape
        (Discrete takes a scalar, MultiDiscrete one value per head) or a value outside the space.
        Integers of any kind pass (Python ints, numpy integer scalars and 0-d arrays, as
        policies return them), and so do floats that are whole numbers."""
        arr = np.asarray(action)
        shape = (len(self.head_sizes),) if self.factored else ()
        whole = arr.dtype.kind in "iu" or (
            arr.dtype.kind == "f" and bool(np.all(np.isfinite(arr) & (arr == np.round(arr))))
        )
        if arr.dtype == np.bool_ or not whole:
            raise ValueError(
                f"action {action!r} is not {'a vector of integers' if self.factored else 'an integer'} "
                f"of {self.action_space}"
            )
        if arr.shape != shape:
            raise ValueError(f"action {action!r} has shape {arr.shape}, not {shape} of {self.action_space}")
        value = arr.astype(np.int64) if self.factored else int(arr)
        if not self.action_space.contains(value):
            raise ValueError(f"action {action!r} is not in {self.action_space}")
        return value

    def ground_action(self, action) -> int | None:
        """The applicable ground action an action of the space names, or None (an invalid action)."""
        value = self.action_value(action)
        if self.factored:
            key = tuple(value.tolist())
            hits = [a for a in self._applicable if tuple(self.labels[a].tolist()) == key]
            return hits[0] if hits else None
        return value if value in self._applicable_set else None

    def step(self, action):
        if self._world is None or self._world.task is None:
            raise RuntimeError("call reset() first (the episode has ended)")
        self.action_value(action)  # a ValueError before anything changes
        world = self._world
        a = self.ground_action(action)
        completed = abandoned = False
        if a is None:
            reward = -self.invalid_penalty
        else:
            step = world.act(a)
            completed = step.completed
            self._task_cost += step.cost
            reward = step_reward(step.cost, completed, self.scale, self.r_goal)
        self._task_actions += 1
        if not completed and self._task_actions >= self.max_actions:
            world.abandon()
            abandoned = True
        finished = None
        terminated = truncated = False
        autos: list = []
        if completed or abandoned:
            o = world.outcomes[-1]
            finished = {"task": o.task, "cost": o.cost, "actions": self._task_actions, "success": o.success}
            world.outcomes.clear()  # outcomes are reported in info; keep memory flat
            self._episode_done += 1
            block_end = self._stream.count % self.tasks_per_reset == 0
            if self.horizon == "myopic":
                terminated, truncated = completed, abandoned
            elif block_end:
                terminated, truncated = self.terminal_reset, not self.terminal_reset
            else:
                autos, block_end = self._open_next(stop_at_block_end=True)
                reward += self.r_goal * len(autos)
                if block_end:
                    terminated, truncated = self.terminal_reset, not self.terminal_reset
        self._update_mask()
        obs = self._obs()
        info = self._info(
            completed=completed, abandoned=abandoned, invalid=a is None, finished=finished, auto_completed=autos
        )
        return obs, float(reward), terminated, truncated, info

    # ---- observation, masks, info ----------------------------------------------------------
    def _obs(self) -> np.ndarray:
        o = self.enc.observe(self.enc.pack([self._world.state]), [self._task.index])[0]
        return o.astype(np.int8) if self._int_obs else o

    def _update_mask(self) -> None:
        self._applicable = self.model.applicable(self._world.state)
        self._applicable_set = set(self._applicable)
        if self.factored:
            heads = [np.zeros(n, dtype=np.int8) for n in self.head_sizes]
            if self._applicable:
                lab = self.labels[self._applicable]
                for h, m in enumerate(heads):
                    m[lab[:, h]] = 1
            else:
                for m in heads:
                    m[:] = 1  # nothing applicable: every vector is a no-op
            self._head_masks = heads
            self._mask = np.concatenate(heads)
        else:
            self._mask = np.zeros(self.model.n_actions, dtype=np.int8)
            self._mask[self._applicable] = 1
            if not self._applicable:
                self._mask[:] = 1

    def action_masks(self) -> np.ndarray:
        """The valid actions of the current state as bool (sb3-contrib's MaskablePPO calls this)."""
        return self._mask.astype(bool)

    def _info(self, completed=False, abandoned=False, invalid=False, finished=None, auto_completed=()) -> dict:
        info = {
            "task": self._task.name,
            "task_cost": self._task_cost,
            "task_actions": self._task_actions,
            "completed": completed,
            "abandoned": abandoned,
            "invalid": invalid,
            "finished": finished,
            "auto_completed": list(auto_completed),
            "tasks_done": self._episode_done,
            "action_mask": self._mask.copy(),
        }
        if self.factored:
            info["head_masks"] = tuple(m.copy() for m in self._head_masks)
        return info

    def render(self):
        if self.render_mode != "ansi":
            return None
        return f"task {self._task.name}: {self._task_actions} actions, cost {self._task_cost}\n" + self.model.describe(
            self._world.state
        )


def env_ids(folder: Path) -> list[tuple[str, str]]:
    """(registered id, layout) per layout of a domain folder: Anticipatory<Name>-<layout>-v0."""
    name = "".join(part.capitalize() for part in folder.name.replace("_", "-").split("-"))
    return [(f"Anticipatory{name}-{layout}-v0", layout) for layout in layouts(folder)]


def register_envs() -> list[str]:
    """Register one id per bundled domain folder and layout, and Anticipatory-v0 for any folder."""
    ids = []
    entry = f"{__name__}:AnticipatoryEnv"
    for folder in sorted((ROOT / "domains").iterdir()) if (ROOT / "domains").is_dir() else []:
        if not (folder / "domain.toml").is_file():
            continue
        for env_id, layout in env_ids(folder):
            if env_id not in gym.registry:
                gym.register(id=env_id, entry_point=entry, kwargs={"domain": str(folder), "layout": layout})
            ids.append(env_id)
    if GENERIC_ID not in gym.registry:
        gym.register(id=GENERIC_ID, entry_point=entry)
    return ids + [GENERIC_ID]


register_envs()
