"""A target definition, ``targets/NAME.json``: a named build of a DEM code at a git revision (thesis listings 4.1
and 4.10). ``harness.targets`` reads it into a ``TargetDefinition``."""
from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Field

from harness.config.base import FileModel

RECIPES = ("dem", "make", "cmake", "system")
WORKING_TREE = "working-tree"

Scalar = Union[str, int, float]
NonEmpty = Annotated[str, Field(pattern=r"\S")]


class Requirement(FileModel):
    executable: str | None = None
    """a program that must be on PATH"""
    package: str | None = None
    """the Debian package that provides it"""


class Patch(FileModel):
    """Patch files applied to a range of commits: to a commit that descends from ``from`` (or is it) and does
    not descend from ``before`` (both optional)."""

    from_: NonEmpty | None = Field(None, alias="from")
    """first revision the entry applies to"""
    before: NonEmpty | None = None
    """first revision it no longer applies to"""
    files: list[str] = []
    """patch files relative to the targets folder, applied in order with ``-p1`` to the exported tree"""
    env: dict[str, Scalar] = {}
    """environment variables added to the build commands"""
    cmake_options: dict[str, Scalar] = {}
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
    recipe: Literal[RECIPES] | None = None
    """how to build: ``dem`` (the bundled engine), ``make``, ``cmake`` or ``system`` (an installed
    ``executable``); inferred from ``make_target`` / ``executable`` when absent, else ``dem``"""
    source_folder: str | None = None
    """folder inside the repository that is built (``dem``: default ``engine``; else ``.``)"""
    make_target: str | None = None
    """``make``: ``make <make_target>`` in ``source_folder`` (required for ``make``)"""
    make_variables: dict[str, Scalar] = {}
    """``make``: ``NAME=VALUE`` arguments"""
    make_jobs: Annotated[int, Field(ge=1)] = 1
    """parallel jobs of older target files (``jobs`` replaces it)"""
    generated_executable: str | None = None
    """``make``: the program it leaves in ``source_folder``; ``cmake``: its path in the build folder
    (required for both)"""
    executable: str | None = None
    """``system``: an absolute path or a name looked up on PATH (required for ``system``)"""
    configure: list[NonEmpty] = []
    """``make``: shell commands run in ``source_folder`` before ``make``"""
    cmake_options: dict[str, Scalar] = {}
    """``cmake``: ``-DNAME=VALUE`` options"""
    build_type: str = "Release"
    """``cmake``: ``CMAKE_BUILD_TYPE``"""
    build_targets: list[NonEmpty] = []
    """``cmake``: the targets ``cmake --build`` builds (default: all)"""
    prebuild: list[NonEmpty] = []
    """``make``/``cmake``: shell commands run in the exported tree before the build"""
    postbuild: list[NonEmpty] = []
    """``make``/``cmake``: shell commands run after the build succeeded"""
    env: dict[str, Scalar] = {}
    """``make``/``cmake``: environment variables of every build command"""
    jobs: Annotated[int, Field(ge=1)] | None = None
    """``make``/``cmake``: parallel compile jobs (default: the machine's cores; ``harness build -j N``)"""
    ccache: bool | None = None
    """``make``/``cmake``: compile through ccache (default true when ``ccache`` is installed)"""
    export: list[NonEmpty] = []
    """``make``/``cmake``: folders taken from the commit, relative, without ``..`` (default:
    ``source_folder``; ``["."]`` for the whole tree)"""
    requires: list[Union[NonEmpty, Requirement]] = []
    """``make``/``cmake``: what the build needs, checked before anything starts: an executable name (and the
    Debian package of the same name) or ``{"executable": ..., "package": ...}``"""
    patches: list[Patch] = []
    """``make``/``cmake``: patch files per range of commits"""
    on_demand: bool = False
    """built, run and checked only when named on the command line"""
    engine: str = "dem"
    """the engine adapter: ``dem``, ``liggghts``, ``lammps``, ``yade`` or ``generic:FILE``"""
    testcases: list[NonEmpty] = ["testcases"]
    """test case folders relative to the test case repository root, or absolute folders (read as they are)"""
    testcases_repository: str | None = None
    """default: ``repository``"""
    testcases_revision: str | None = None
    """revision the test cases are exported at; ``working-tree`` reads the checkout as it is. Default: the
    target's ``revision``, or ``working-tree`` when that is ``HEAD``"""
    reference: Annotated[str, Field(pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.,:=@+\-]*$")] | None = None
    """name of the target this one is compared against (thesis listing 4.10)"""
    thermo_columns: dict[str, Scalar] = {}
    """the harness' thermo names onto the engine's columns, e.g. ``{"ke": "KinEng"}``"""
    mpi_launcher: Annotated[list[NonEmpty], Field(min_length=1)] = ["mpirun"]
    """launcher prefix of mpi runs"""
    commit_url: Annotated[str, Field(pattern=r"\{commit\}")] | None = None
    """the repository's web view of one commit, with ``{commit}`` where the commit goes"""
