"""Key files on disk: `master.key` and one file per member (credentials.py), TOML,
mode 0600. Reading one checks that only its owner may read it, that it is whole, and whose
it is: `read_key_file` names the file and what is wrong in one line."""

from __future__ import annotations

import os
import stat
import tomllib
from pathlib import Path

from cavesim.core.input_files import read_input
from cavesim.core.limits import MAX_TOML_BYTES
from cavesim.core.wire.credentials import (
    FORMAT,
    MASTER,
    MASTER_FILE,
    OPERATOR,
    ROLE_CODES,
    TRACKER,
    WALL,
    Credentials,
    Identity,
    member_file,
)


def write_key_files(folder: Path, credentials: Credentials, walls: tuple[str, ...],
                    trackers: tuple[str, ...] = (), operators: tuple[str, ...] = ()
                    ) -> list[Path]:
    """Write master.key and a key of each wall, tracker and operator into `folder` (mode
    0600); their paths, master.key first."""
    folder.mkdir(parents=True, exist_ok=True)
    master = folder / MASTER_FILE
    _write(master, "the master's only: the session's secret and the master's signing key",
           role=MASTER, secret=credentials.secret, master_private=credentials.master_private,
           master_public=credentials.master_public)
    return [master] + write_member_keys(folder, credentials, walls, trackers, operators)


def write_member_keys(folder: Path, credentials: Credentials, walls: tuple[str, ...],
                      trackers: tuple[str, ...] = (), operators: tuple[str, ...] = ()
                      ) -> list[Path]:
    """Issue a key to each wall, tracker and operator with the master's `credentials` and
    write each into `folder` (mode 0600); their paths."""
    members = [(role, name) for role, names in ((WALL, walls), (TRACKER, trackers),
                                                (OPERATOR, operators))
               for name in names]
    return [write_member_key(folder / member_file(role, name), credentials.issue(role, name))
            for role, name in members]


def write_member_key(path: Path, member: Credentials) -> Path:
    """Write a member's credentials (no master signing key) to `path`, 0600."""
    _write(path, f"{member.member}'s only: its own key, certified by the master",
           role=member.member.role, name=member.member.name, secret=member.secret,
           master_public=member.master_public, member_private=member.member_private,
           certificate=member.certificate)
    return path


def _write(path: Path, what: str, **keys: bytes | str | None) -> None:
    lines = [f"# cavesim key file, {what}", f'format = "{FORMAT}"']
    lines += [f'{name} = "{value if isinstance(value, str) else value.hex()}"'
              for name, value in keys.items() if value is not None]
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    os.fchmod(descriptor, 0o600)  # a file that was there keeps its mode otherwise
    with os.fdopen(descriptor, "w") as file:
        file.write("\n".join(lines) + "\n")


def read_key_file(path: Path, role: str, name: str | None = None,
                  flag: str = "--key-file") -> Credentials:
    """The credentials in the key file of `role` (and of member `name`, where given), given
    as `flag`; ValueError names the flag, the file and what is wrong, in one line."""
    where = f"{flag} {path}"
    try:
        mode = stat.S_IMODE(path.stat().st_mode)
        text = read_input(path, ValueError, "the key file", MAX_TOML_BYTES).decode()
    except (OSError, UnicodeDecodeError) as e:
        raise ValueError(f"{where}: cannot read it: {e}") from e
    except ValueError as e:  # no regular file, or too large: the line names it
        raise ValueError(f"--key-file {e}") from e
    if mode & 0o077:
        raise ValueError(f"{where}: others may read it (mode {mode:04o}); a key file must be "
                         f"its owner's only: run `chmod 600 {path}`")
    try:
        data = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError):  # a RecursionError: nested too deep
        data = {}
    if data.get("format") != FORMAT or data.get("role") not in (MASTER, *ROLE_CODES):
        raise ValueError(f"{where}: not a cavesim key file; make the session's keys with "
                         f"`cavesim keys --out DIR --walls ...` ({MASTER_FILE} for the master, "
                         f"{member_file('wall', 'NAME')} for each wall)")
    held = Identity(data["role"], data.get("name", MASTER))
    wanted = Identity(role, name or held.name)
    if held != wanted:
        raise ValueError(f"{where}: holds the key of {held}; this needs {wanted}'s "
                         f"({MASTER_FILE if role == MASTER else member_file(role, wanted.name)}"
                         f" from `cavesim keys`)")
    return _credentials(data, held, where)


def _credentials(data: dict, held: Identity, where: str) -> Credentials:
    fields = ("secret", "master_public") + (("master_private",) if held.role == MASTER
                                           else ("member_private", "certificate"))
    try:
        values = {field: bytes.fromhex(data[field]) for field in fields}
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{where}: damaged: it needs the hex fields {', '.join(fields)}") \
            from e
    try:
        if held.role == MASTER:
            return Credentials(values["secret"], values["master_public"],
                               values["master_private"])
        return Credentials(values["secret"], values["master_public"], None, held,
                           values["member_private"], values["certificate"])
    except ValueError as e:
        raise ValueError(f"{where}: its halves do not belong together ({e}): it was edited "
                         f"or pieced together from two key sets; make new keys with "
                         f"`cavesim keys`") from e
