# SPDX-License-Identifier: GPL-3.0-or-later
"""Connection settings resolve as the CLI's do: argument > environment >
profile > default; bad settings are refused before any call."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import hdrstereo
from hdrstereo import config


def write(path: Path, text: str, mode: int = 0o600) -> Path:
    path.write_text(text)
    os.chmod(path, mode)
    return path


@pytest.fixture
def lab(tmp_path: Path) -> dict[str, str]:
    """A profile file with PEM-looking files beside it; its environment."""
    write(tmp_path / "ca.pem", "CA")
    write(tmp_path / "bob.pem", "CERT")
    write(tmp_path / "bob.key", "KEY")
    write(tmp_path / "bob-notebook.key", "hs_abc_secret\n")
    write(tmp_path / "client.toml", """\
default_profile = "lab"  # a comment
[profile.lab]
server = "labpc:50052"
tls_ca = "ca.pem"
tls_cert = "bob.pem"
tls_key = "bob.key"
[profile.keyed]
server = "labpc:50053"
tls_ca = "ca.pem"
api_key_file = "bob-notebook.key"
[profile.plain]
server = "labpc:50051"
""")
    return {"HDRSTEREO_CLIENT_CONFIG": str(tmp_path / "client.toml"),
            "HOME": str(tmp_path)}


def test_default_without_anything(tmp_path: Path) -> None:
    c = config.resolve(env={"HOME": str(tmp_path)})
    assert c.server == "localhost:50051"
    assert not c.tls and c.profile == ""


def test_default_profile_paths_relative_to_the_file(lab) -> None:
    c = config.resolve(env=lab)
    assert (c.server, c.profile) == ("labpc:50052", "lab")
    assert (c.ca_pem, c.cert_pem, c.key_pem) == (b"CA", b"CERT", b"KEY")
    assert c.api_key is None


def test_home_config_is_read(lab) -> None:
    home = Path(lab["HOME"])
    (home / ".config/hdrstereo").mkdir(parents=True)
    (home / "client.toml").rename(home / ".config/hdrstereo/client.toml")
    write(home / ".config/hdrstereo/client.toml",
          '[profile.x]\nserver = "from-home:1"\n')
    c = config.resolve(profile="x", env={"HOME": lab["HOME"]})
    assert c.server == "from-home:1"


def test_precedence_argument_environment_profile(lab) -> None:
    env = dict(lab, HDRSTEREO_SERVER="envhost:1")
    assert config.resolve(env=env).server == "envhost:1"
    assert config.resolve(server="arghost:2", env=env).server == "arghost:2"
    env["HDRSTEREO_PROFILE"] = "plain"
    c = config.resolve(env=dict(env, HDRSTEREO_SERVER=""))
    assert (c.server, c.tls) == ("labpc:50051", False)
    # The argument's profile beats the environment's.
    assert config.resolve(profile="keyed", env=env).profile == "keyed"


def test_api_key_file_from_profile(lab) -> None:
    c = config.resolve(profile="keyed", env=lab)
    assert c.api_key == "hs_abc_secret" and c.cert_pem is None
    assert "secret" not in repr(c)


def test_unknown_profile_names_the_known_ones(lab) -> None:
    with pytest.raises(hdrstereo.InvalidArgument,
                       match=r'no profile "nope" in .*; it has: keyed, lab, '
                             r"plain"):
        config.resolve(profile="nope", env=lab)


def test_profile_without_file(tmp_path: Path) -> None:
    with pytest.raises(hdrstereo.InvalidArgument,
                       match="profile \"lab\" asked for, but there is no"):
        config.resolve(env={"HOME": str(tmp_path), "HDRSTEREO_PROFILE": "lab"})


def test_unknown_key_refused_by_name(lab) -> None:
    write(Path(lab["HDRSTEREO_CLIENT_CONFIG"]),
          '[profile.lab]\nserver = "a:1"\ntls_cafile = "x"\n')
    with pytest.raises(hdrstereo.InvalidArgument,
                       match='unknown key "tls_cafile" in \\[profile.lab\\]'):
        config.resolve(env=lab)


def test_cert_without_key(lab) -> None:
    with pytest.raises(hdrstereo.InvalidArgument,
                       match="tls_cert and tls_key go together"):
        config.resolve(profile="plain", tls_ca=str(Path(lab["HOME"]) / "ca.pem"),
                       tls_cert=str(Path(lab["HOME"]) / "bob.pem"), env=lab)


def test_credentials_need_tls(lab) -> None:
    with pytest.raises(hdrstereo.InvalidArgument,
                       match="an API key is only sent over TLS"):
        config.resolve(profile="plain", api_key="hs_a_b", env=lab)


def test_readable_key_refused(lab) -> None:
    os.chmod(Path(lab["HOME"]) / "bob.key", 0o644)
    with pytest.raises(hdrstereo.InvalidArgument,
                       match=r"bob.key is readable by other users \(mode "
                             r"0644\); make it yours alone: chmod 600"):
        config.resolve(env=lab)


def test_key_file_must_hold_one_key(lab) -> None:
    write(Path(lab["HOME"]) / "bob-notebook.key", "not a key\n")
    with pytest.raises(hdrstereo.InvalidArgument,
                       match="does not hold one API key"):
        config.resolve(profile="keyed", env=lab)


def test_missing_ca_file(lab) -> None:
    with pytest.raises(hdrstereo.InvalidArgument,
                       match="cannot read tls_ca /nonexistent/ca.pem"):
        config.resolve(profile="plain", tls_ca="/nonexistent/ca.pem", env=lab)


def test_session_names_checked_before_any_call() -> None:
    # Nothing listens on this address: the name is refused first.
    client = hdrstereo.Client("127.0.0.1:9", timeout=1)
    with pytest.raises(hdrstereo.InvalidArgument,
                       match="'lab 1' must start with a letter or digit and "
                             "use only letters, digits, '-' and '_'"):
        client.sessions.create("lab 1")
    with pytest.raises(hdrstereo.InvalidArgument, match="at most 64"):
        client.capture.stereo("x" * 65)
    with pytest.raises(hdrstereo.InvalidArgument, match="is empty"):
        client.process("")
    client.close()
