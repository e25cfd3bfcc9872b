"""Zenoh settings in two steps, each on its own: the network flags to typed settings (the
CLI's edge), and settings to a zenoh config (the one function that builds one). No session
is opened here."""

import argparse
import json
from pathlib import Path

import pytest

from cavesim.core.records import PARTICLE_BYTES
from cavesim.core.wire.network import MAX_MESSAGE_BYTES, NetworkSettings, zenoh_config
from cavesim.core.wire.payloads.state_transfer import MAX_CHUNK_PARTICLES
from nodes.arguments import (
    UsageError,
    add_network_arguments,
    network_and_key,
    network_settings,
)

ROOT = Path(__file__).resolve().parents[2]
LOCAL = ROOT / "config/zenoh/local.json5"


def setting(config, key: str):
    return json.loads(config.get_json(key))


def parse(*flags: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="cavesim master", exit_on_error=False)
    add_network_arguments(parser)
    return parser.parse_args(flags)


# -- settings to a zenoh config ------------------------------------------------------------

def test_the_embedded_default_is_a_peer_without_multicast_scouting():
    config = zenoh_config(NetworkSettings())
    assert setting(config, "mode") == "peer"
    assert setting(config, "scouting/multicast/enabled") is False


def test_endpoints_are_written_into_the_config():
    settings = NetworkSettings(listen=("tcp/127.0.0.1:7447", "tcp/127.0.0.1:7448"),
                               connect=("tcp/10.0.0.1:7447",))
    config = zenoh_config(settings)
    assert setting(config, "listen/endpoints") == ["tcp/127.0.0.1:7447", "tcp/127.0.0.1:7448"]
    assert setting(config, "connect/endpoints") == ["tcp/10.0.0.1:7447"]


def test_endpoints_override_the_files():
    settings = NetworkSettings(connect=("tcp/10.0.0.9:7447",), config_file=LOCAL)
    assert setting(zenoh_config(settings), "connect/endpoints") == ["tcp/10.0.0.9:7447"]


def test_a_file_zenoh_cannot_read_is_a_value_error_naming_it(tmp_path):
    bad = tmp_path / "zenoh.json5"
    bad.write_text('{"mode": "bogus"}')
    with pytest.raises(ValueError, match=f"^{bad}: not a usable zenoh config: .*bogus") as e:
        zenoh_config(NetworkSettings(config_file=bad))
    assert ".rs:" not in str(e.value)


def test_an_endpoint_without_a_protocol_is_refused():
    with pytest.raises(ValueError, match="endpoint 'nohost' must look like tcp/HOST:PORT"):
        NetworkSettings(connect=("nohost",))


# -- flags to settings ---------------------------------------------------------------------

def test_without_flags_the_settings_are_the_embedded_default():
    args = parse()
    assert network_settings(args) == NetworkSettings()
    assert (args.session, args.key_file) == ("default", None)


def test_the_flags_become_typed_settings():
    args = parse("--listen", "tcp/0.0.0.0:7447", "--connect", "tcp/10.0.0.1:7447",
                 "--connect", "tcp/10.0.0.2:7447", "--config", str(LOCAL))
    assert network_settings(args) == NetworkSettings(
        ("tcp/0.0.0.0:7447",), ("tcp/10.0.0.1:7447", "tcp/10.0.0.2:7447"), LOCAL)


def test_a_bad_session_name_is_an_argument_error():
    with pytest.raises(argparse.ArgumentError, match="session must be 1-32 letters"):
        parse("--session", "a/b")


@pytest.mark.parametrize(("flags", "line"), [
    (("--connect", "nohost"),
     "cavesim master: error: endpoint 'nohost' must look like tcp/HOST:PORT"),
    (("--config", "/nonexistent.json5"),
     "cavesim master: error: --config /nonexistent.json5: not a usable zenoh config: "),
])
def test_bad_network_flags_are_one_usage_line(flags, line):
    with pytest.raises(UsageError) as e:
        network_and_key(parse(*flags), "master", "master")
    assert str(e.value).startswith(line) and "\n" not in str(e.value)


@pytest.mark.parametrize("config_file", [None, LOCAL], ids=["embedded", "file"])
def test_every_config_refuses_messages_larger_than_cavesim_sends(config_file):
    config = zenoh_config(NetworkSettings(config_file=config_file))
    assert setting(config, "transport/link/rx/max_message_size") == MAX_MESSAGE_BYTES
    assert MAX_MESSAGE_BYTES >= MAX_CHUNK_PARTICLES * PARTICLE_BYTES + 2**12
