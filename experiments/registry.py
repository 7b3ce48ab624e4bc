"""The agent registry: every agent the evaluation command can play, as a lazy (module, class) row.

An agent class implements the protocol of `planning.world.agents`, whose
hooks the command line uses: `options(parser)` declares its flags with their
defaults (the only place they are written), `from_args(options, model)` builds
it for the compiled layout, and its `run_name` names the default results file
(every setting that changes results: planner, heuristic, K, checkpoint). What
`from_args` reads travels as the agent's options dataclass (`agent_options`),
one field per declared flag. A new agent is one module and one row here.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import importlib

from planning.errors import DomainError

AGENTS = {
    "myopic-oracle": ("oracles.myopic", "MyopicOracle"),
    "clairvoyant": ("oracles.clairvoyant", "ClairvoyantOracle"),
    "random": ("experiments.random_policy", "RandomPolicy"),
    "rl-greedy": ("learning.agents.greedy", "GreedyValuePolicy"),
    "rl-guided": ("learning.agents.guided", "ValueGuidedPlanner"),
    "gnn-native": ("learning.agents.gnn_native", "GNNNativePlanner"),
    "gnn-guided": ("learning.agents.guided", "GNNGuidedPlanner"),
}


def agent_class(name: str):
    """The class registered under `name` (imported on first use)."""
    if name not in AGENTS:
        raise DomainError("--agent", f"unknown agent '{name}' (known: {', '.join(AGENTS)})")
    module, cls = AGENTS[name]
    return getattr(importlib.import_module(module), cls)


def describe() -> str:
    """One line per registered agent: its name and the first line of its docstring."""
    return "\n".join(f"{name:16s} {(agent_class(name).__doc__ or '').strip().splitlines()[0]}" for name in AGENTS)


@functools.cache
def options_class(cls) -> type:
    """The dataclass of an agent class's options: one field per flag its `options` declares, named by the
    flag's dest, defaulting to the flag's default (a required flag has none: it must be given)."""
    p = argparse.ArgumentParser(add_help=False)
    cls.options(p)
    fields = []
    for a in p._actions:
        kind = a.type if isinstance(a.type, type) else bool if isinstance(a.default, bool) else str
        fields.append((a.dest, kind) if a.required else (a.dest, kind, dataclasses.field(default=a.default)))
    return dataclasses.make_dataclass(f"{cls.__name__}Options", fields, frozen=True, kw_only=True)


def agent_options(name_or_cls, args=None, **values):
    """The agent's options: those of `args` (a parsed command line holding the agent's flags, among
    others), else `values` over the flags' defaults; a name that is not one of its flags is a one-line error."""
    cls = agent_class(name_or_cls) if isinstance(name_or_cls, str) else name_or_cls
    kind = options_class(cls)
    fields = {f.name: f for f in dataclasses.fields(kind)}
    if args is not None:
        values = {n: getattr(args, n) for n in fields}
    unknown = sorted(set(values) - set(fields))
    if unknown:
        raise DomainError(f"--{unknown[0].replace('_', '-')}", f"not an option of {cls.__name__}")
    missing = [n for n, f in fields.items() if n not in values and f.default is dataclasses.MISSING]
    if missing:
        raise DomainError(f"--{missing[0].replace('_', '-')}", f"{cls.__name__} needs it")
    return kind(**values)


def build(name_or_cls, options, model):
    """The agent built for the compiled layout from its options (its `from_args`). An agent that plays a
    reference planner (a `reference_agent` option, `learning.agents.guided`) is handed that planner, built here:
    learning/ may not import this registry, which knows every agent."""
    cls = agent_class(name_or_cls) if isinstance(name_or_cls, str) else name_or_cls
    spec = getattr(options, "reference_agent", None)
    if spec is None:
        return cls.from_args(options, model)
    reference = reference_planner(spec, model, cls.reference_defaults(options))
    return cls.from_args(options, model, reference_planner=reference)


def reference_planner(spec: str, model, defaults: dict):
    """The registered planner `spec` names, 'NAME [OPTIONS]', built from its own options over `defaults`."""
    import shlex

    from planning.world.agents import Planner

    words = shlex.split(spec)
    if not words or words[0] not in AGENTS:
        raise DomainError("--reference-agent", f"'{spec}' names no registered agent (known: {', '.join(AGENTS)})")
    cls = agent_class(words[0])
    if not issubclass(cls, Planner):
        raise DomainError("--reference-agent", f"{words[0]} is not a planner: it acts step by step")
    p = argparse.ArgumentParser(prog=f"--reference-agent {words[0]}", add_help=False)
    cls.options(p)
    p.set_defaults(**{k: v for k, v in defaults.items() if k in {a.dest for a in p._actions}})
    return build(cls, agent_options(cls, p.parse_args(words[1:])), model)
