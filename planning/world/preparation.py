"""What a domain calls preparation, declared in domain.toml, and the measures the reports take of it.

A domain may say which action draws on a preparation and which deliveries it replaces:

    [preparation]
    action = "refill-water"        # draws on a preparation: its share of all actions over training
                                   # (learning.export, Figure A.2)
    [preparation.deliveries]       # the preparation's share of deliveries in executed plans (Table A.5)
    reuse = ["refill-water"]       # action schemas that deliver from the preparation
    fresh = ["fill"]               # action schemas that deliver from scratch ...
    not_of = ["jar"]               # ... except with an argument of these types: that is preparing, not
                                   # delivering (filling the jar itself)

In the restaurant a delivery is water put into a vessel: from the filled jar (refill-water, 50) or from
the fountain (fill, 1,000). `Preparation.of(model)` reads and checks the table (None where the domain
declares none); `count` and `share` measure plans of ground action names, as results files store them.
"""

from __future__ import annotations

from dataclasses import dataclass

from planning.errors import DomainError


@dataclass(frozen=True)
class Preparation:
    """A domain's [preparation]: the action that draws on a preparation and its delivery classes."""

    action: str | None
    reuse: frozenset  # ground action indices that deliver from the preparation
    fresh: frozenset  # ground action indices that deliver from scratch
    model: object

    @classmethod
    def of(cls, model) -> "Preparation | None":
        """The layout's [preparation], checked against its schemas and types; None where there is none."""
        where = model.files["config"]
        table = model.config.get("preparation")
        if table is None:
            return None
        if not isinstance(table, dict):
            raise DomainError(where, f"preparation is {table!r}, not a table")
        extra = sorted(set(table) - {"action", "deliveries"})
        if extra:
            raise DomainError(where, f"[preparation]: unknown key(s) {', '.join(extra)} (known: action, deliveries)")
        schemas = set(model.action_schema)
        action = table.get("action")
        if action is not None and action not in schemas:
            raise DomainError(where, f"[preparation] action {action!r} is not an action of the domain")
        reuse = fresh = frozenset()
        deliveries = table.get("deliveries")
        if deliveries is not None:
            what = "[preparation.deliveries]"
            if not isinstance(deliveries, dict):
                raise DomainError(where, f"{what} is {deliveries!r}, not a table")
            extra = sorted(set(deliveries) - {"reuse", "fresh", "not_of"})
            if extra:
                raise DomainError(where, f"{what}: unknown key(s) {', '.join(extra)} (known: reuse, fresh, not_of)")
            names = {}
            for key in ("reuse", "fresh", "not_of"):
                value = deliveries.get(key, [])
                if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                    raise DomainError(where, f"{what} {key} is {value!r}, not a list of names")
                names[key] = value
            for key in ("reuse", "fresh"):
                if not names[key]:
                    raise DomainError(where, f"{what} names no {key} action")
                for name in names[key]:
                    if name not in schemas:
                        raise DomainError(where, f"{what} {key}: {name!r} is not an action of the domain")
            excluded = set()
            for ty in names["not_of"]:
                objs = model.objects_of(ty)
                if not objs:
                    raise DomainError(where, f"{what} not_of: no object of type {ty!r} in layout {model.layout}")
                excluded |= set(objs)

            def ground(key: str, excluded: set) -> frozenset:
                keep = set(names[key])
                return frozenset(
                    i
                    for i, (s, args) in enumerate(zip(model.action_schema, model.action_args))
                    if s in keep and not excluded & set(args)
                )

            reuse, fresh = ground("reuse", set()), ground("fresh", excluded)
        return cls(action, reuse, fresh, model)

    def count(self, plan: list[str], where="a plan") -> tuple[int, int]:
        """(deliveries from the preparation, deliveries from scratch) in a plan of ground action names;
        `where` (a results file) is named if an action is not one of the layout's."""
        index = self.model.action_index
        reuse = fresh = 0
        for name in plan:
            if name not in index:
                raise DomainError(where, f"action {name!r} is not a ground action of layout {self.model.layout}")
            a = index[name]
            reuse += a in self.reuse
            fresh += a in self.fresh
        return reuse, fresh

    def share(self, rows: list[dict], where="a results file") -> tuple[float | None, int]:
        """(the preparation's share of deliveries, deliveries) over a results file's per-task rows: every
        action the world went through (a failed task's completion included); None where nothing was delivered."""
        reuse = fresh = 0
        for row in rows:
            for key in ("plan", "completion_plan"):
                r, f = self.count(row.get(key) or [], where)
                reuse, fresh = reuse + r, fresh + f
        total = reuse + fresh
        return (reuse / total if total else None), total
