"""Where a report and its results files come from: the header naming the report's commit, command, date and
machine, and the closing sections every report ends with (the runs not yet made, each with its commands, and
one provenance row per results file: its commit, command, configuration, checkpoint hash, date and machine).

A results file without a provenance block (written before results files recorded one) is given the commit
that last touched it, and the hash of the checkpoint file there now.
"""

from __future__ import annotations

from pathlib import Path

from experiments.report.data import last_commit, sha256
from experiments.report.tables import missing_runs, table
from planning.parallel import results_provenance


def header(command: str) -> list[str]:
    """The report's own provenance, as markdown bullets: this checkout's commit (and its uncommitted code),
    `command`, the date and the machine."""
    prov = results_provenance({})
    return [
        f"- commit: `{prov.get('commit') or 'unknown'}`"
        + (
            f" with uncommitted changes to {', '.join(prov['uncommitted_code'][:6])}"
            if prov.get("uncommitted_code")
            else ""
        ),
        f"- command: `{command}`",
        f"- date: {prov['date_utc']}",
        f"- machine: {prov['machine']['host']}, {prov['machine']['platform']}, {prov['machine']['cpus']} CPUs, "
        f"Python {prov['machine']['python']}",
    ]


def config_summary(cfg: dict) -> str:
    """A results file's configuration in one cell: its scalar settings and its reference planner."""
    skip = {"checkpoint", "search", "fallback", "eval", "note"}
    parts = [
        f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"
        for k, v in cfg.items()
        if k not in skip and isinstance(v, (int, float, str))
    ]
    if isinstance(cfg.get("reference"), dict):
        parts.append(f"reference {cfg['reference'].get('planner')}")
    return ", ".join(parts)


def files_table(results: dict) -> list[str]:
    """One row per results file a row reads, used or not (a file two rows read, once)."""
    body, seen = [], set()
    for rows in results.values():
        for rr in rows.values():
            for x in rr.loaded:
                if x.data is None or x.run.out in seen:
                    continue
                seen.add(x.run.out)
                prov = x.data.get("provenance") or {}
                commit = (
                    f"`{prov['commit'][:10]}`"
                    if prov.get("commit")
                    else f"not recorded (file last committed in {last_commit(x.run.out) or 'no commit'})"
                )
                mach = prov.get("machine") or {}
                machine = f"{mach.get('host', '')} {mach.get('platform', '')}".strip() or "not recorded"
                ckpt = prov.get("checkpoint_sha256") or (sha256(x.run.checkpoint) if x.run.checkpoint else None)
                ckpt = (f"`{ckpt[:12]}`" + ("" if prov.get("checkpoint_sha256") else " (file now)")) if ckpt else "—"
                used = "used" if x.used else f"**not used**: {x.note}"
                body.append(
                    [
                        f"`{Path(x.run.out).name}`",
                        used,
                        x.accounting or "—",
                        commit,
                        prov.get("date_utc") or prov.get("written") or "not recorded",
                        machine,
                        f"`{prov['command']}`"
                        if prov.get("command")
                        else f"not recorded; the row's: `{x.run.command}`",
                        config_summary(x.data.get("config") or {}),
                        ckpt,
                        "; ".join([*(f"**{f}**" for f in x.flags), *x.notes]) or "—",
                    ]
                )
    return table(
        [
            "results file",
            "use",
            "failed-task accounting",
            "commit",
            "date",
            "machine",
            "command",
            "configuration",
            "checkpoint sha256",
            "flags (bold) and notes",
        ],
        body,
    )


def closing(results: dict, sections: dict | None = None) -> list[str]:
    """The last two sections of every report: the runs not yet made, and the provenance of the results files
    (those of `results` and of the `sections` that list their own missing runs, such as the task streams')."""
    return [
        "## Runs not yet made",
        "",
        *missing_runs(results),
        "",
        "## Provenance of the results files",
        "",
        *files_table({**results, **(sections or {})}),
        "",
    ]


def notes(path: Path) -> list[str]:
    """The appendix of hand-kept notes with no generator yet, included verbatim (nothing where the file is absent)."""
    if not path.is_file():
        return []
    return [
        "## Appendix: hand-kept notes (not generated)",
        "",
        f"Included verbatim from `{path}`; each note names the results file it reads.",
        "",
        path.read_text().strip(),
        "",
    ]
