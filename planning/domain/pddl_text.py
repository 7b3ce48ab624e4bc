"""The PDDL text before tarski reads it: what we refuse (named by file and line), and derived predicates.

tarski parses STRIPS with typing, ADL conditions and effects, constants and action
costs, but not `(:derived ...)`, and where it meets a construct the compiler does
not handle (numeric fluents beyond static action costs, durative actions, PDDL+)
its message names neither the line nor the action. So each file is first read
here as s-expressions with line numbers:

- a construct we refuse is a one-line DomainError naming the file and line, the
  construct and the action, axiom or task it sits in;
- each `(:derived (p ?x - t) BODY)` is rewritten, in place and keeping every line
  where it was, into an action `(:action <name> :parameters (?x - t) :precondition
  BODY :effect (and))` that tarski parses with the domain's own types, predicates
  and constants; folder.py takes those actions back out as the axioms of `p`.

Where the text does not read as balanced s-expressions nothing is checked here and
tarski reports the syntax error.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from planning.errors import DomainError

NUMERIC_EFFECTS = ("increase", "decrease", "assign", "scale-up", "scale-down")
COMPARISONS = ("<", ">", "<=", ">=")
ARITHMETIC = ("+", "-", "*", "/")
CONNECTIVES = ("and", "or", "not", "imply", "=")
DERIVED_PREFIX = "derived-axiom-"
"""The name of the action a `:derived` block is rewritten into: DERIVED_PREFIX + its index."""


@dataclass
class Token:
    text: str
    line: int
    start: int
    end: int


@dataclass
class Node:
    """A parenthesised list: its items (Token or Node), its first line and its span in the text."""

    line: int
    start: int
    end: int = 0
    items: list = field(default_factory=list)

    @property
    def head(self) -> str:
        return self.items[0].text.lower() if self.items and isinstance(self.items[0], Token) else ""


def read_sexp(text: str) -> list | None:
    """The top-level lists of a PDDL text, or None if its parentheses do not balance."""
    stack, top, line, i, n = [], [], 1, 0, len(text)
    while i < n:
        c = text[i]
        if c == "\n":
            line += 1
            i += 1
        elif c.isspace():
            i += 1
        elif c == ";":
            while i < n and text[i] != "\n":
                i += 1
        elif c == "(":
            stack.append(Node(line, i))
            i += 1
        elif c == ")":
            if not stack:
                return None
            node = stack.pop()
            node.end = i + 1
            (stack[-1].items if stack else top).append(node)
            i += 1
        else:
            j = i
            while j < n and not text[j].isspace() and text[j] not in "();":
                j += 1
            tok = Token(text[i:j], line, i, j)
            if stack:
                stack[-1].items.append(tok)
            i = j
    return None if stack else top


def _sections(nodes: list) -> list:
    """The sections of a `(define ...)`: its lists after the name."""
    for node in nodes:
        if isinstance(node, Node) and node.head == "define":
            return [x for x in node.items[1:] if isinstance(x, Node)]
    return []


class Checker:
    """Walks one file's s-expressions and refuses, in one line, what the compiler cannot compile."""

    def __init__(self, path: Path, text: str):
        self.path = path
        self.text = text

    def refuse(self, node, construct: str, inside: str, why: str):
        snippet = " ".join(self.text[node.start : node.end].split())
        if len(snippet) > 60:
            snippet = snippet[:57] + "..."
        raise DomainError(f"{self.path}:{node.line}", f"{construct} {snippet} in {inside}: {why}")

    # ---- conditions ------------------------------------------------------
    def condition(self, node, inside: str) -> None:
        if not isinstance(node, Node):
            return
        head = node.head
        if head in COMPARISONS or (head == "=" and any(isinstance(x, Node) for x in node.items[1:])):
            self.refuse(
                node, "numeric condition", inside, "numeric fluents are not supported (only static action costs)"
            )
        if head == "preference":
            self.refuse(node, "preference", inside, "preferences are not supported")
        if head in ("forall", "exists"):
            for x in node.items[2:]:
                self.condition(x, inside)
            return
        if head not in CONNECTIVES:
            self.atom(node, inside)
            return
        for x in node.items[1:]:
            self.condition(x, inside)

    def atom(self, node, inside: str) -> None:
        nested = next((x for x in node.items[1:] if isinstance(x, Node)), None)
        if nested is not None:
            self.refuse(
                nested,
                "function term",
                inside,
                "object fluents are not supported (an atom's arguments are objects, constants and parameters)",
            )

    # ---- effects ---------------------------------------------------------
    def effect(self, node, inside: str) -> None:
        if not isinstance(node, Node):
            return
        head = node.head
        if head in NUMERIC_EFFECTS:
            target = node.items[1] if len(node.items) > 1 else None
            if head != "increase" or not (
                isinstance(target, Node) and len(target.items) == 1 and target.head == "total-cost"
            ):
                self.refuse(
                    node,
                    "numeric effect",
                    inside,
                    "numeric fluents are not supported (only action costs: (increase (total-cost) ...))",
                )
            value = node.items[2] if len(node.items) > 2 else None
            if isinstance(value, Node) and (
                value.head in ARITHMETIC or value.head == "" or any(isinstance(x, Node) for x in value.items[1:])
            ):
                self.refuse(
                    node,
                    "cost expression",
                    inside,
                    "an action cost must be a number or "
                    "a static function of the parameters, such as (move-cost ?from ?to)",
                )
            return
        if head == "when":
            if len(node.items) > 1:
                self.condition(node.items[1], inside)
            for x in node.items[2:]:
                self.effect(x, inside)
            return
        if head == "forall":
            for x in node.items[2:]:
                self.effect(x, inside)
            return
        if head == "and":
            for x in node.items[1:]:
                self.effect(x, inside)
            return
        if head == "not" and len(node.items) == 2 and isinstance(node.items[1], Node):
            self.atom(node.items[1], inside)
        elif head:
            self.atom(node, inside)

    # ---- sections --------------------------------------------------------
    def action(self, node, kind: str) -> None:
        name = node.items[1].text if len(node.items) > 1 and isinstance(node.items[1], Token) else "?"
        inside = f"{kind} {name}"
        items = node.items
        for k, x in enumerate(items):
            if isinstance(x, Token) and k + 1 < len(items):
                key = x.text.lower()
                if key == ":precondition":
                    self.condition(items[k + 1], inside)
                elif key == ":effect":
                    self.effect(items[k + 1], inside)


def _unsupported_section(checker: Checker, node: Node, where_kind: str) -> None:
    head = node.head
    name = node.items[1].text if len(node.items) > 1 and isinstance(node.items[1], Token) else "?"
    where = f"{checker.path}:{node.line}"
    if head == ":durative-action":
        raise DomainError(
            where, f"durative action {name}: durative actions are not supported (only instantaneous :action)"
        )
    if head in (":process", ":event"):
        raise DomainError(where, f"PDDL+ {head[1:]} {name}: processes and events are not supported")
    if head == ":constraints":
        raise DomainError(
            where, f"(:constraints ...) in the {where_kind}: state-trajectory constraints are not supported"
        )


@dataclass
class Prepared:
    """A file's text as tarski is to read it, and the axioms its `:derived` blocks became."""

    text: str
    derived: dict = field(default_factory=dict)  # pseudo-action name -> (derived predicate, line)


def prepare_domain(path: Path, text: str, kind: str = "domain") -> Prepared:
    """Check a domain (or task schema) file and rewrite its `:derived` blocks into actions tarski parses.

    `kind` is "domain" (domain.pddl: actions and derived predicates) or "tasks" (tasks.pddl:
    task schemas, no derived predicates)."""
    nodes = read_sexp(text)
    if nodes is None:
        return Prepared(text)
    checker = Checker(path, text)
    what = "action" if kind == "domain" else "task schema"
    taken = {
        x.items[1].text.lower()
        for x in _sections(nodes)
        if x.head == ":action" and len(x.items) > 1 and isinstance(x.items[1], Token)
    }
    edits, derived = [], {}
    for node in _sections(nodes):
        _unsupported_section(checker, node, "domain")
        if node.head == ":action":
            checker.action(node, what)
        elif node.head == ":derived":
            head = node.items[1] if len(node.items) > 1 else None
            if not isinstance(head, Node) or not head.head or len(node.items) != 3:
                checker.refuse(node, "derived predicate", "domain", "write it as (:derived (p ?x - type) condition)")
            pred = head.head
            if kind != "domain":
                checker.refuse(
                    node,
                    "derived predicate",
                    f"{what} file",
                    f"derived predicates belong in domain.pddl, not in {path.name}",
                )
            checker.condition(node.items[2], f"derived predicate {pred}")
            k = len(derived)
            name = f"{DERIVED_PREFIX}{k}"
            while name in taken:
                k += 1
                name = f"{DERIVED_PREFIX}{k}"
            taken.add(name)
            derived[name] = (pred, node.line)
            edits.append((node, head, name))
    if not edits:
        return Prepared(text, derived)
    out, pos = [], 0
    for node, head, name in edits:
        body = node.items[2]
        params = text[head.items[0].end : head.end - 1]  # "?x - t ?y" with its newlines
        lead = text[node.start : head.start].count("\n")
        between = text[head.end : body.start]
        trailing = text[body.end : node.end - 1]
        out += [
            text[pos : node.start],
            f"(:action {name}",
            "\n" * lead,
            " :parameters (",
            params,
            ")",
            between,
            " :precondition ",
            text[body.start : body.end],
            trailing,
            " :effect (and))",
        ]
        pos = node.end
    out.append(text[pos:])
    return Prepared("".join(out), derived)


def check_problem(path: Path, text: str) -> str | None:
    """The domain name a problem declares (`(:domain NAME)`, None if unread); a one-line error for what a
    problem may not hold: numeric goals, a metric other than total-cost, timed initial literals, constraints."""
    nodes = read_sexp(text)
    if nodes is None:
        return None
    checker = Checker(path, text)
    domain = None
    for node in _sections(nodes):
        _unsupported_section(checker, node, "problem")
        if node.head == ":domain" and len(node.items) > 1 and isinstance(node.items[1], Token):
            domain = node.items[1].text.lower()
        elif node.head == ":goal":
            for x in node.items[1:]:
                checker.condition(x, "the goal")
        elif node.head == ":metric":
            words = " ".join(checker.text[node.start : node.end].lower().split())
            if not re.fullmatch(r"\(:metric minimize \(\s*total-cost\s*\)\)", words.replace("( ", "(")):
                checker.refuse(node, "metric", "the problem", "only (:metric minimize (total-cost)) is supported")
        elif node.head == ":init":
            for x in node.items[1:]:
                if (
                    isinstance(x, Node)
                    and x.head == "at"
                    and len(x.items) > 1
                    and isinstance(x.items[1], Token)
                    and re.fullmatch(r"[0-9.]+", x.items[1].text)
                ):
                    checker.refuse(
                        x, "timed initial literal", "the problem's :init", "timed literals are not supported"
                    )
    return domain
