"""Git access through GitPython: resolve a revision to a commit, export folders at a commit.

A repository is a local checkout, a bare repository, a URL or a git bundle file; URLs and bundles are
mirrored into the workspace (``builds/repos/``) and fetched again on use. Revisions are resolved by
``git rev-parse`` itself, so every spelling git accepts works (tags, ``3.7.0~2``, ``HEAD^2``, ``:/subject``).
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
from harness.execution.workspace import workspace


def is_remote(location: str) -> bool:
    """A URL (``https://``, ``ssh://``, ``file://``, ``git@host:``) or a bundle file: mirrored, not opened."""
    return "://" in location or location.startswith("git@") or location.endswith(".bundle")


def open_repository(location: str) -> git.Repo:
    """A local repository (checkout or bare), or a bare mirror of a remote one or of a bundle file in the
    build cache, fetched on every call (a new upstream commit is seen at once). Two processes share a mirror
    under a lock."""
    if is_remote(location):
        mirror = workspace().builds / "repos" / hashlib.sha1(location.encode()).hexdigest()[:16]
        if location.endswith(".bundle") and "://" not in location and not Path(location).is_file():
            raise UserError(f"repository {location}: no such bundle file")
        try:
            with workspace().lock(f"mirror-{mirror.name}"):
                if (mirror / "HEAD").is_file():
                    repo = git.Repo(mirror)
                    repo.git.fetch("--quiet", "--prune", location, "+refs/*:refs/*")
                else:
                    workspace().fresh_folder(mirror)
                    mirror.rmdir()
                    repo = git.Repo.clone_from(location, mirror, mirror=True)
        except git.GitCommandError as exc:
            raise UserError(f"repository {location}: {(exc.stderr or '').strip() or exc}") from None
        return repo
    try:
        return git.Repo(location)
    except (git.NoSuchPathError, git.InvalidGitRepositoryError):
        raise UserError(f"repository {location}: not a git repository") from None


def resolve(repo: git.Repo, revision: str) -> git.Commit:
    """The commit a revision names, in every spelling ``git rev-parse`` accepts (tag, branch, commit id,
    ``HEAD~3``, ``v1^2``, ``:/subject``); an annotated tag is peeled to its commit."""
    try:
        named = repo.git.rev_parse("--verify", "--quiet", "--end-of-options", revision).strip()
        # peeled separately: '^{commit}' after ':/text' would become part of the searched text
        sha = repo.git.rev_parse("--verify", "--quiet", f"{named}^{{commit}}") if named else ""
    except git.GitCommandError:
        sha = ""
    if not sha:
        raise UserError(f"revision {revision!r} not found in repository {repo.git_dir}")
    return repo.commit(sha.strip())


def commit_info(commit: git.Commit) -> dict:
    return {
        "commit": commit.hexsha,
        "committed_at": datetime.fromtimestamp(commit.committed_date, tz=timezone.utc).isoformat(),
        "commit_message": commit.message.strip(),
    }


def export(repo: git.Repo, commit: str, folder: str | list[str], destination: Path) -> Path:
    """Write the files under ``folder`` (``.`` = all; or a list of folders) at ``commit`` into
    ``destination``, keeping modes and the commit's time as modification time.

    Returns the exported folder (``destination/folder``; ``destination`` for a list). Raises UserError if a
    folder does not exist at that commit.
    """
    if isinstance(folder, list):
        for item in folder:
            export(repo, commit, item, destination)
        return destination
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


