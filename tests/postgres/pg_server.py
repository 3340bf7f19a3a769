"""A throw-away PostgreSQL server of Debian's ``postgresql`` package, in a temporary folder, for the tests.

``initdb`` and ``pg_ctl`` refuse to run as root: as root the server runs as Debian's ``postgres`` user
(``runuser``). It listens only on a Unix socket in the folder; the URL is the form the harness documents:
``postgresql://postgres@/DBNAME?host=SOCKET_DIR``.
"""
from __future__ import annotations

import glob
import os
import shutil
import subprocess
from pathlib import Path


def binaries() -> Path | None:
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/pg_ctl"))
    return Path(found[-1]).parent if found else None


class Server:
    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self.bin = binaries()
        self.data = self.folder / "data"
        self.socket = self.folder / "socket"
        self.as_postgres = os.geteuid() == 0

    def _run(self, *command: str) -> subprocess.CompletedProcess:
        prefix = ["runuser", "-u", "postgres", "--"] if self.as_postgres else []
        return subprocess.run([*prefix, *command], capture_output=True, text=True, timeout=120)

    def start(self) -> "Server":
        self.folder.mkdir(parents=True, exist_ok=True)
        self.socket.mkdir(exist_ok=True)
        if self.as_postgres:
            shutil.chown(self.folder, "postgres")
            shutil.chown(self.socket, "postgres")
            # the folder's parents (pytest's tmp folders) must be passable for the postgres user
            for parent in self.folder.parents:
                if parent == Path("/"):
                    break
                parent.chmod(parent.stat().st_mode | 0o011)
        done = self._run(str(self.bin / "initdb"), "-D", str(self.data), "-U", "postgres", "--auth=trust",
                         "-E", "UTF8", "--no-sync")
        if done.returncode:
            raise RuntimeError(f"initdb failed: {done.stderr}")
        options = f"-k {self.socket} -c listen_addresses='' -c fsync=off -c max_connections=50"
        done = self._run(str(self.bin / "pg_ctl"), "-D", str(self.data), "-o", options, "-l",
                         str(self.folder / "server.log"), "-w", "start")
        if done.returncode:
            raise RuntimeError(f"pg_ctl start failed: {done.stderr}{(self.folder / 'server.log').read_text()}")
        return self

    def create_database(self, name: str) -> str:
        done = self._run(str(self.bin / "createdb"), "-h", str(self.socket), "-U", "postgres", name)
        if done.returncode:
            raise RuntimeError(f"createdb failed: {done.stderr}")
        return self.url(name)

    def url(self, name: str) -> str:
        return f"postgresql://postgres@/{name}?host={self.socket}"

    def stop(self) -> None:
        self._run(str(self.bin / "pg_ctl"), "-D", str(self.data), "-m", "immediate", "stop")
