"""Revisions on the command line: ``TARGET@REV`` and ``TARGET@A..B``, as asv's ``asv run A..B``.

``dem@v1.2``, ``dem@HEAD~3`` or ``dem@1a2b3c`` is the target ``dem`` built at that revision instead of the
one its file names; its test cases stay the target's own (the same content for every revision, so that runs
of two revisions can be compared). A revision given this way never becomes the target's current build.
``dem@A..B`` is every commit reachable from B and not from A (git's and asv's meaning: A itself excluded),
oldest first; ``steps`` spreads that many commits evenly over the range, the newest always among them.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

from harness.adapters.base import UserError
from harness.config import gitrepo
from harness.config.targets import TargetDefinition, select_targets


def split(argument: str) -> tuple[str, str | None]:
    """``"dem@HEAD~3"`` -> ``("dem", "HEAD~3")``; ``"dem"`` -> ``("dem", None)``."""
    name, at, revision = argument.partition("@")
    if at and not revision:
        raise UserError(f"{argument!r}: no revision after '@' (TARGET@REV or TARGET@A..B)")
    return name, (revision if at else None)


def at_revision(target: TargetDefinition, revision: str) -> TargetDefinition:
    """``target`` built at ``revision`` (resolved to its commit now), its test cases unchanged."""
    if target.recipe == "system":
        raise UserError(f"{target.name}@{revision}: target {target.name!r} is an installed program "
                        f"({target.executable}); it has no git revisions")
    repo = gitrepo.open_repository(target.repository)
    commit = gitrepo.resolve(repo, revision).hexsha
    return dataclasses.replace(target, revision=commit, explicit_revision=True)


def commits_between(target: TargetDefinition, first: str, last: str, steps: int | None = None) -> list[str]:
    """Commits of ``first..last`` (oldest first), all or ``steps`` of them spread evenly, newest included."""
    repo = gitrepo.open_repository(target.repository)
    start, end = gitrepo.resolve(repo, first).hexsha, gitrepo.resolve(repo, last).hexsha
    commits = repo.git.rev_list("--reverse", f"{start}..{end}").split()
    if not commits:
        raise UserError(f"{target.name}@{first}..{last}: no commits in that range ({last} is not after {first})")
    if steps is not None and 0 < steps < len(commits):
        picked = {round(i * (len(commits) - 1) / max(steps - 1, 1)) for i in range(steps)} if steps > 1 else set()
        picked.add(len(commits) - 1)
        commits = [commits[i] for i in sorted(picked)]
    return commits


def expand(arguments: list[str], folder: Path | None = None, steps: int | None = None
           ) -> tuple[list[TargetDefinition], list[str]]:
    """Target definitions for ``TARGET``, ``TARGET@REV`` and ``TARGET@A..B`` arguments, and file problems."""
    plain = [split(a)[0] for a in arguments]
    targets, problems = select_targets(plain, folder)
    out = []
    for argument, target in zip(arguments, targets) if arguments else ((None, t) for t in targets):
        revision = split(argument)[1] if argument else None
        if revision is None:
            out.append(target)
        elif ".." in revision:
            first, _, last = revision.partition("..")
            if not first or not last or last.startswith("."):
                raise UserError(f"{argument!r}: a range is TARGET@A..B with two revisions")
            out.extend(at_revision(target, commit) for commit in commits_between(target, first, last, steps))
        else:
            out.append(at_revision(target, revision))
    return out, problems
