"""A session's credentials: the shared secret every member signs its messages with
(HMAC-SHA256), and the master's Ed25519 key pair. Only the master holds the private half,
so only the master can sign a frame or a command; nodes and trackers hold the public half
and check those signatures, but cannot make them.

`cavesim keys --out DIR` writes both files: `master.key` (the secret and the signing key:
the master's only) and `session.key` (the secret and the master's public key: for every
node and tracker). Both are small TOML files, readable by their owner only.
"""

from __future__ import annotations

import os
import secrets
import tomllib
from dataclasses import dataclass
from pathlib import Path

from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey, Ed25519PublicKey

FORMAT = "cavesim-key"
SECRET_BYTES = 32
ED25519_BYTES = 32  # either half of the key pair
MASTER_SIGNATURE_BYTES = 64
MASTER_FILE, SESSION_FILE = "master.key", "session.key"


@dataclass(frozen=True, repr=False)
class Credentials:
    secret: bytes  # the shared HMAC key
    master_public: bytes  # Ed25519 public key that verifies the master's signatures
    master_private: bytes | None = None  # Ed25519 private key: the master's file only

    def __post_init__(self) -> None:
        if len(self.secret) != SECRET_BYTES or len(self.master_public) != ED25519_BYTES \
                or self.master_private is not None and len(self.master_private) != ED25519_BYTES:
            raise ValueError(f"credentials need a {SECRET_BYTES}-byte secret and "
                             f"{ED25519_BYTES}-byte Ed25519 keys")
        object.__setattr__(self, "_public", Ed25519PublicKey.from_public_bytes(
            self.master_public))
        private = None if self.master_private is None \
            else Ed25519PrivateKey.from_private_bytes(self.master_private)
        if private is not None and _raw_public(private) != self.master_public:
            raise ValueError("the master's public key is not the private key's")
        object.__setattr__(self, "_private", private)

    @property
    def can_sign_as_master(self) -> bool:
        return self._private is not None

    def sign_as_master(self, data: bytes) -> bytes:
        if self._private is None:
            raise ValueError("these credentials hold no master signing key (session.key); "
                             "the master needs master.key")
        return self._private.sign(data)

    def is_masters(self, data: bytes, signature: bytes) -> bool:
        """Whether `signature` is the master's over `data`."""
        try:
            self._public.verify(signature, data)
        except InvalidSignature:
            return False
        return True

    def for_members(self) -> Credentials:
        """What nodes and trackers hold: the secret and the master's public key."""
        return Credentials(self.secret, self.master_public)

    def __repr__(self) -> str:  # never print a key
        role = "master" if self.can_sign_as_master else "member"
        return f"Credentials({role}, public {self.master_public[:4].hex()}...)"


def generate() -> Credentials:
    """A new session: a random secret and a fresh master key pair."""
    return of_master(secrets.token_bytes(SECRET_BYTES), secrets.token_bytes(ED25519_BYTES))


def of_master(secret: bytes, private: bytes) -> Credentials:
    """The master's credentials from the secret and its 32-byte Ed25519 private key."""
    public = _raw_public(Ed25519PrivateKey.from_private_bytes(private))
    return Credentials(secret, public, private)


def _raw_public(private: Ed25519PrivateKey) -> bytes:
    return private.public_key().public_bytes(serialization.Encoding.Raw,
                                             serialization.PublicFormat.Raw)


def write_key_files(folder: Path, credentials: Credentials | None = None) -> tuple[Path, Path]:
    """Write master.key and session.key into `folder` (mode 0600); their paths."""
    credentials = credentials or generate()
    folder.mkdir(parents=True, exist_ok=True)
    master, session = folder / MASTER_FILE, folder / SESSION_FILE
    _write(master, "the master's only: the session's secret and the master's signing key",
           secret=credentials.secret, master_private=credentials.master_private,
           master_public=credentials.master_public)
    write_member_key(session, credentials)
    return master, session


def write_member_key(path: Path, credentials: Credentials) -> Path:
    """Write the session.key of `credentials` (no signing key) to `path`, mode 0600."""
    _write(path, "for every node and tracker: the session's secret and the master's "
                 "public key", secret=credentials.secret,
           master_public=credentials.master_public)
    return path


def _write(path: Path, what: str, **keys: bytes | None) -> None:
    lines = [f"# cavesim key file, {what}", f'format = "{FORMAT}"']
    lines += [f'{name} = "{value.hex()}"' for name, value in keys.items() if value is not None]
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    os.fchmod(descriptor, 0o600)  # a file that was there keeps its mode otherwise
    with os.fdopen(descriptor, "w") as file:
        file.write("\n".join(lines) + "\n")


def read_credentials(path: Path) -> Credentials:
    """The credentials in a key file; ValueError names the file and what is wrong."""
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise ValueError(f"--key-file {path}: cannot read it: {e}") from e
    try:
        data = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError):  # a RecursionError: nested too deep
        data = {}
    if data.get("format") != FORMAT:
        raise ValueError(f"--key-file {path}: not a cavesim key file; make the session's keys "
                         f"with `cavesim keys --out DIR` ({MASTER_FILE} for the master, "
                         f"{SESSION_FILE} for nodes and trackers)")
    try:
        secret, public = (bytes.fromhex(data[name]) for name in ("secret", "master_public"))
        private = bytes.fromhex(data["master_private"]) if "master_private" in data else None
        return Credentials(secret, public, private)
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"--key-file {path}: damaged: it needs hex `secret` "
                         f"({SECRET_BYTES} bytes) and `master_public` ({ED25519_BYTES} bytes), "
                         f"and in {MASTER_FILE} `master_private`") from e
