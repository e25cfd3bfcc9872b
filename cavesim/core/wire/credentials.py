"""A session's credentials: the shared secret every message carries an HMAC-SHA256 under
(a cheap first filter against outsiders), the master's Ed25519 key pair, and one Ed25519 key
pair per member, each with a certificate: the master's signature over its role, name and
public key. Only the master holds its private half, so only the master can sign a frame or
a command, or make a member; a member signs its own messages with its own key and sends its
certificate along, so a receiver knows which member spoke, in which role, and that the
master made it.

The roles (ROLE_CODES): a wall's node computes and reports its wall; a tracker sends the
head and the wand; an operator (a preview window, `cavesim run --preview`) sends the head
and the wand and the session controls (pause, reset, stop), which count from an operator
alone.

`cavesim keys --out DIR --walls front,left --trackers dtrack --operators desk` writes
`master.key` (the secret and the master's signing key: the master's only),
`wall-front.key`, `wall-left.key`, `tracker-dtrack.key` and `operator-desk.key` (the
secret, the master's public key, the member's own key and certificate). All are small TOML
files, readable by their owner only; a key file that others may read is refused.
"""

from __future__ import annotations

import secrets
from dataclasses import dataclass

from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey, Ed25519PublicKey

from cavesim.core.wire.key_expressions import check_name

FORMAT = "cavesim-key"
SECRET_BYTES = 32
ED25519_BYTES = 32  # either half of a key pair
MASTER_SIGNATURE_BYTES = 64  # any Ed25519 signature
MASTER_FILE = "master.key"
MASTER, WALL, TRACKER, OPERATOR = "master", "wall", "tracker", "operator"
ROLE_CODES = {WALL: 1, TRACKER: 2, OPERATOR: 3}  # the byte a member's card names its role by
_CERTIFIED = b"cavesim member certificate\0"  # what a certificate signs begins with this


def member_file(role: str, name: str) -> str:
    """The key file's name of a member: wall-front.key, tracker-dtrack.key,
    operator-desk.key."""
    return f"{role}-{name}.key"


@dataclass(frozen=True)
class Identity:
    """Who signed a message: the master, or a member by its role and name."""

    role: str
    name: str

    def __str__(self) -> str:
        return self.role if self.role == MASTER else f"{self.role} {self.name}"


MASTER_IDENTITY = Identity(MASTER, MASTER)


def card_body(identity: Identity, public: bytes) -> bytes:
    """A member's role, name and public key as a card carries them (what the master
    certifies)."""
    name = identity.name.encode()
    return bytes([ROLE_CODES[identity.role], len(name)]) + name + public


def read_card(data: bytes, offset: int) -> tuple[Identity, bytes, bytes, int] | None:
    """(identity, public key, certificate, end) of the card at `offset`, or None when the
    bytes there are not one."""
    if len(data) < offset + 2:
        return None
    code, length = data[offset], data[offset + 1]
    roles = {c: r for r, c in ROLE_CODES.items()}
    end = offset + 2 + length + ED25519_BYTES + MASTER_SIGNATURE_BYTES
    if code not in roles or len(data) < end:
        return None
    try:
        name = check_name("member name", data[offset + 2:offset + 2 + length].decode("ascii"))
    except (UnicodeDecodeError, ValueError):
        return None
    public = data[offset + 2 + length:end - MASTER_SIGNATURE_BYTES]
    return Identity(roles[code], name), public, data[end - MASTER_SIGNATURE_BYTES:end], end


@dataclass(frozen=True, repr=False)
class Credentials:
    secret: bytes  # the shared HMAC key
    master_public: bytes  # Ed25519 public key that verifies the master's signatures
    master_private: bytes | None = None  # Ed25519 private key: the master's file only
    member: Identity | None = None  # a member's file: whose it is
    member_private: bytes | None = None  # ... its own Ed25519 private key
    certificate: bytes | None = None  # ... and the master's signature over its card body

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
        object.__setattr__(self, "_card", self._member_card())
        object.__setattr__(self, "_cards", {})  # verified cards -> (identity, public key)

    def _member_card(self) -> bytes | None:
        if self.member is None:
            return None
        key = Ed25519PrivateKey.from_private_bytes(self.member_private)
        body = card_body(self.member, _raw_public(key))
        if not self.is_masters(_CERTIFIED + body, self.certificate):
            raise ValueError(f"the certificate of {self.member} is not the master's "
                             f"signature over its role, name and public key")
        object.__setattr__(self, "_member_key", key)
        return body + self.certificate

    @property
    def can_sign_as_master(self) -> bool:
        return self._private is not None

    @property
    def card(self) -> bytes | None:
        """The member's card: role, name, public key and the master's certificate."""
        return self._card

    def sign_as_master(self, data: bytes) -> bytes:
        if self._private is None:
            raise ValueError("these credentials hold no master signing key (a member's key); "
                             "the master needs master.key")
        return self._private.sign(data)

    def sign_as_member(self, data: bytes) -> bytes:
        return self._member_key.sign(data)

    def is_masters(self, data: bytes, signature: bytes) -> bool:
        """Whether `signature` is the master's over `data`."""
        return _verifies(self._public, data, signature)

    def signer_of(self, card: bytes, data: bytes, signature: bytes) -> Identity | None:
        """Who signed `data`: the member `card` names, if the master certified the card and
        `signature` is that member's over `data` (else None)."""
        known = self._member_of(card)
        return None if known is None or not _verifies(known[1], data, signature) else known[0]

    def _member_of(self, card: bytes) -> tuple[Identity, Ed25519PublicKey] | None:
        """The identity and public key a card names, if the master certified it."""
        if (known := self._cards.get(card)) is not None:
            return known
        parsed = read_card(card, 0)
        if parsed is None or parsed[3] != len(card):
            return None
        identity, public, certificate, _ = parsed
        if not self.is_masters(_CERTIFIED + card_body(identity, public), certificate):
            return None
        known = identity, Ed25519PublicKey.from_public_bytes(public)
        if len(self._cards) < MAX_KNOWN_CARDS:  # only the master's cards get here
            self._cards[card] = known
        return known

    def issue(self, role: str, name: str) -> Credentials:
        """A new member's credentials: its own key pair, certified by the master."""
        if role not in ROLE_CODES:
            raise ValueError(f"a member's role is one of {sorted(ROLE_CODES)}, got {role!r}")
        identity = Identity(role, check_name(f"{role} name", name))
        private = secrets.token_bytes(ED25519_BYTES)
        public = _raw_public(Ed25519PrivateKey.from_private_bytes(private))
        certificate = self.sign_as_master(_CERTIFIED + card_body(identity, public))
        return Credentials(self.secret, self.master_public, None, identity, private,
                           certificate)

    def same_session(self, other: Credentials) -> bool:
        """Whether `other` holds this session's secret and master key (made by one
        `cavesim keys`)."""
        return self.secret == other.secret and self.master_public == other.master_public

    def for_members(self) -> Credentials:
        """The secret and the master's public key alone: no member's key, so what it signs
        is attributed to nobody."""
        return Credentials(self.secret, self.master_public)

    def __repr__(self) -> str:  # never print a key
        role = MASTER if self.can_sign_as_master else str(self.member or "unattributed")
        return f"Credentials({role}, public {self.master_public[:4].hex()}...)"


MAX_KNOWN_CARDS = 1024  # verified cards a receiver remembers


def _verifies(public: Ed25519PublicKey, data: bytes, signature: bytes) -> bool:
    try:
        public.verify(signature, data)
    except InvalidSignature:
        return False
    return True


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
