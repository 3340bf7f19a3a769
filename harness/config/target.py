"""A target definition, ``targets/NAME.json``: a named build of a DEM code at a git revision (thesis listings 4.1
and 4.10). ``harness.config.targets`` reads it into a ``TargetDefinition``."""
from __future__ import annotations

from typing import Annotated, ClassVar, Literal, Union

from pydantic import Field

from harness.config.base import FileModel
from harness.config.check import Says
from harness.config.runconfig import SAFE_NAME

RECIPES = ("dem", "make", "cmake", "system")
WORKING_TREE = "working-tree"

Scalar = Union[str, int, float]
NonEmpty = Annotated[str, Field(pattern=r"\S")]
Strings = Annotated[list[NonEmpty], Says(what="a list of strings", item="a string", item_bound="must not be empty")]
Settings = Annotated[dict[str, Scalar], Says(what="an object", item="a string or number")]
Switch = Annotated[bool, Says(what="true or false")]
Jobs = Annotated[int, Field(ge=1), Says(what="an integer", bound="must be at least 1")]


class Requirement(FileModel):
    says: ClassVar[Says] = Says(unknown='an object has "executable" and/or "package" (strings)', unknown_here=True)
    executable: str | None = None
    """a program that must be on PATH"""
    package: str | None = None
    """the Debian package that provides it"""


Revision = Annotated[str, Field(pattern=r"\S"), Says(what="a revision (string)", bound="must name a revision")]


class Patch(FileModel):
    """Patch files applied to a range of commits: to a commit that descends from ``from`` (or is it) and does
    not descend from ``before`` (both optional)."""

    from_: Revision | None = Field(None, alias="from")
    """first revision the entry applies to"""
    before: Revision | None = None
    """first revision it no longer applies to"""
    files: Annotated[list[str], Says(what="a list of patch files", item="a file name (string)")] = []
    """patch files relative to the targets folder, applied in order with ``-p1`` to the exported tree"""
    env: Settings = {}
    """environment variables added to the build commands"""
    cmake_options: Settings = {}
    """``-DNAME=VALUE`` options added"""


class Target(FileModel):
    """A target is a named build of a DEM code at a git revision; its name is the file name without
    ``.json``, a safe single path segment (it names workspace folders)."""

    description: str | None = None
    """free text"""
    repository: str | None = None
    """path or URL of the git repository; a relative path is relative to the folder holding ``targets/``.
    Default: the repository the target file is in"""
    revision: str = "HEAD"
    """tag, branch, commit or ``HEAD``"""
    recipe: Annotated[Literal[RECIPES], Says(bound="unknown recipe {value!r} (known: {known})")] | None = None
    """how to build: ``dem`` (the bundled engine), ``make``, ``cmake`` or ``system`` (an installed
    ``executable``); inferred from ``make_target`` / ``executable`` when absent, else ``dem``"""
    source_folder: str | None = None
    """folder inside the repository that is built (``dem``: default ``engine``; else ``.``)"""
    make_target: str | None = None
    """``make``: ``make <make_target>`` in ``source_folder`` (required for ``make``)"""
    make_variables: Settings = {}
    """``make``: ``NAME=VALUE`` arguments"""
    make_jobs: Jobs = 1
    """parallel jobs of older target files (``jobs`` replaces it)"""
    generated_executable: str | None = None
    """``make``: the program it leaves in ``source_folder``; ``cmake``: its path in the build folder
    (required for both)"""
    executable: str | None = None
    """``system``: an absolute path or a name looked up on PATH (required for ``system``)"""
    configure: Strings = []
    """``make``: shell commands run in ``source_folder`` before ``make``"""
    cmake_options: Settings = {}
    """``cmake``: ``-DNAME=VALUE`` options"""
    build_type: Annotated[str, Says(what="a string (e.g. Release)")] = "Release"
    """``cmake``: ``CMAKE_BUILD_TYPE``"""
    build_targets: Strings = []
    """``cmake``: the targets ``cmake --build`` builds (default: all)"""
    prebuild: Strings = []
    """``make``/``cmake``: shell commands run in the exported tree before the build"""
    postbuild: Strings = []
    """``make``/``cmake``: shell commands run after the build succeeded"""
    env: Settings = {}
    """``make``/``cmake``: environment variables of every build command"""
    jobs: Jobs | None = None
    """``make``/``cmake``: parallel compile jobs (default: the machine's cores; ``harness build -j N``)"""
    ccache: Switch | None = None
    """``make``/``cmake``: compile through ccache (default true when ``ccache`` is installed)"""
    export: Strings = []
    """``make``/``cmake``: folders taken from the commit, relative, without ``..`` (default:
    ``source_folder``; ``["."]`` for the whole tree)"""
    requires: Annotated[list[Union[NonEmpty, Requirement]], Says(
        what="a list of requirements", item='an executable name or {"executable": ..., "package": ...}',
        item_bound="must name an executable")] = []
    """``make``/``cmake``: what the build needs, checked before anything starts: an executable name (and the
    Debian package of the same name) or ``{"executable": ..., "package": ...}``"""
    patches: Annotated[list[Patch], Says(what="a list of commit ranges", item="an object")] = []
    """``make``/``cmake``: patch files per range of commits"""
    on_demand: Switch = False
    """built, run and checked only when named on the command line"""
    engine: str = "dem"
    """the engine adapter: ``dem``, ``liggghts``, ``lammps``, ``yade`` or ``generic:FILE``"""
    testcases: Annotated[list[str], Field(json_schema_extra={"items": {"type": "string", "pattern": r"\S"}}),
                         Says(what="a list of folders", item="a folder (string)")] = ["testcases"]
    """test case folders relative to the test case repository root, or absolute folders (read as they are)"""
    testcases_repository: str | None = None
    """default: ``repository``"""
    testcases_revision: str | None = None
    """revision the test cases are exported at; ``working-tree`` reads the checkout as it is. Default: the
    target's ``revision``, or ``working-tree`` when that is ``HEAD``"""
    reference: Annotated[str, Field(json_schema_extra={"pattern": SAFE_NAME})] | None = None
    """name of the target this one is compared against (thesis listing 4.10)"""
    thermo_columns: Settings = {}
    """the harness' thermo names onto the engine's columns, e.g. ``{"ke": "KinEng"}``"""
    mpi_launcher: Annotated[list[NonEmpty], Field(min_length=1), Says(
        what="a list of strings", bound='must hold at least the launcher program, e.g. ["mpirun"]', item="a string",
        item_bound="must not be empty")] = ["mpirun"]
    """launcher prefix of mpi runs"""
    commit_url: Annotated[str, Field(pattern=r"\{commit\}"), Says(
        bound="must hold {{commit}} where the commit goes, e.g. https://example.org/repo/commit/{{commit}}")] \
        | None = None
    """the repository's web view of one commit, with ``{commit}`` where the commit goes"""
