"""Git access through GitPython: resolve a revision to a commit, export a folder at a commit.

Exports use ``git archive`` so that a build or a test case set is the content of the commit, never the
working tree, and stays runnable while the working tree changes.
"""
from __future__ import annotations

import hashlib
import io
import tarfile
from datetime import datetime, timezone
from pathlib import Path

import git

from harness.adapters.base import UserError
from harness.workspace import workspace


def open_repository(location: str) -> git.Repo:
    """A local repository, or a bare mirror of a remote one (fetched on every call) in the build cache."""
    if "://" in location or location.startswith("git@"):
        mirror = workspace().builds / "repos" / hashlib.sha1(location.encode()).hexdigest()[:16]
        try:
            if mirror.is_dir():
                repo = git.Repo(mirror)
                repo.git.fetch("--quiet", "--prune", "origin", "+refs/*:refs/*")
            else:
                repo = git.Repo.clone_from(location, mirror, mirror=True)
        except git.GitCommandError as exc:
            raise UserError(f"repository {location}: {exc.stderr.strip() or exc}") from None
        return repo
    try:
        return git.Repo(location)
    except (git.NoSuchPathError, git.InvalidGitRepositoryError):
        raise UserError(f"repository {location}: not a git repository") from None


def resolve(repo: git.Repo, revision: str) -> git.Commit:
    """The commit a tag, branch, commit id or ``HEAD`` names."""
    try:
        return repo.commit(revision)
    except (git.BadName, ValueError, git.GitCommandError):
        raise UserError(f"revision {revision!r} not found in repository {repo.git_dir}") from None


def commit_info(commit: git.Commit) -> dict:
    return {
        "commit": commit.hexsha,
        "committed_at": datetime.fromtimestamp(commit.committed_date, tz=timezone.utc).isoformat(),
        "commit_message": commit.message.strip(),
    }


def export(repo: git.Repo, commit: str, folder: str, destination: Path) -> Path:
    """Write the files under ``folder`` (``.`` = all) at ``commit`` into ``destination``, keeping modes.

    Returns the exported folder (``destination/folder``). Raises UserError if the folder does not exist at
    that commit.
    """
    folder = folder.strip("/") or "."
    args = [commit] if folder == "." else [commit, "--", folder]
    try:
        data = repo.git.archive("--format=tar", *args, stdout_as_string=False)
    except git.GitCommandError as exc:
        detail = (exc.stderr or "").strip().strip("'").removeprefix("stderr: ").strip("'\" \n")
        if "did not match any files" in detail:
            detail = "no such folder at that commit"
        raise UserError(f"cannot export {folder!r} at {commit[:12]} from {repo.git_dir}: {detail}") from None
    destination.mkdir(parents=True, exist_ok=True)
    with tarfile.open(fileobj=io.BytesIO(data)) as archive:
        if folder != "." and not archive.getmembers():
            raise UserError(f"folder {folder!r} does not exist at {commit[:12]} in {repo.git_dir}")
        archive.extractall(destination, filter="tar")
    return destination / folder if folder != "." else destination


