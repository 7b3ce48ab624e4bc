"""The reward of the continuing task-conditioned MDP (thesis Eq. 3.1, §5.2.4), the one definition every learner uses.

    r_t = R_goal · 1[the action completed the task] − c_PDDL(s, a) / cost_scale

`cost_scale` (PDDL units per RL unit) and R_goal come from the domain folder:
domain.toml [reward], else R_goal from the layout's calibration file written by
`python -m experiments.calibrate`. Without [reward] cost_scale the scale is 1 (one
PDDL unit per reward unit: the restaurant's 100 makes its rewards 100 times
smaller), said once on stderr.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from planning.errors import DomainError
from planning.world.results import file_prefix


def step_reward(cost: float, completed: bool, scale: float, r_goal: float) -> float:
    """The reward of one primitive action: −cost/scale, plus R_goal if it completed the task."""
    return -cost / scale + (r_goal if completed else 0.0)


_warned: set = set()


def cost_scale(model) -> float:
    """PDDL cost units per RL reward unit (domain.toml [reward] cost_scale, default 1: a one-line warning on
    stderr, once per domain file)."""
    reward = getattr(model, "config", {}).get("reward", {})
    if not (isinstance(reward, dict) and "cost_scale" in reward):
        where = str(getattr(model, "files", {}).get("config", model.name))
        if where not in _warned:
            _warned.add(where)
            print(
                f"warning: {where}: no [reward] cost_scale: 1 PDDL cost unit per reward unit (the rewards are "
                "-cost + R_goal; set [reward] cost_scale to scale them)",
                file=sys.stderr,
            )
    return model.cost_scale


def calibration_path(model, results_dir="results") -> Path:
    """Where the calibration of a layout is written: results/calibration-<layout>.json for the restaurant
    (its committed names), results/calibration-<domain>-<layout>.json for any other domain."""
    return Path(results_dir) / f"calibration-{file_prefix(model.name)}{model.layout}.json"


def goal_reward(model, results_dir="results") -> float:
    """The completion reward R_goal: domain.toml [reward] goal_reward, else the layout's calibration file."""
    reward = model.config.get("reward", {})
    if "goal_reward" in reward:
        return float(reward["goal_reward"])
    path = calibration_path(model, results_dir)
    if not path.is_file():
        raise DomainError(
            f"{model.name} {model.layout}",
            f"no completion reward: set [reward] goal_reward in {model.files['config']} "
            f"or run `python -m experiments.calibrate --domain {model.folder} "
            f"--layout {model.layout}` (writes {path})",
        )
    try:
        data = json.loads(path.read_text())
        value, domain, layout = float(data["r_goal"]), data.get("domain"), data.get("layout")
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise DomainError(path, f"unreadable calibration ({e!r}); rerun experiments.calibrate") from None
    if (domain, layout) != (model.name, model.layout):
        raise DomainError(path, f"calibrates {domain} {layout}, not {model.name} {model.layout}")
    from planning.domain.identity import mismatch

    diff = mismatch(data, model)
    if diff is not None:
        raise DomainError(path, f"a calibration made from {diff}; rerun experiments.calibrate --force")
    return value
