# SPDX-License-Identifier: GPL-3.0-or-later
"""Where to connect and with which credentials, resolved as the CLI does.

Each setting comes from the argument, else the environment
(HDRSTEREO_SERVER, HDRSTEREO_PROFILE, HDRSTEREO_TLS_CA, HDRSTEREO_TLS_CERT,
HDRSTEREO_TLS_KEY, HDRSTEREO_API_KEY_FILE), else the profile in
~/.config/hdrstereo/client.toml (HDRSTEREO_CLIENT_CONFIG names another
file), else the default (localhost:50051, no TLS). The rules are the CLI's
(clients/cli/connection.cc).
"""

from __future__ import annotations

import dataclasses
import os
import stat
import tomllib
from pathlib import Path
from typing import Mapping, Optional

from .errors import InvalidArgument

DEFAULT_SERVER = "localhost:50051"
_PROFILE_KEYS = ("server", "tls_ca", "tls_cert", "tls_key", "api_key_file")


@dataclasses.dataclass(frozen=True)
class Connection:
    """A resolved connection: the address and, for TLS, the PEM bytes."""

    server: str = DEFAULT_SERVER
    profile: str = ""
    ca_pem: Optional[bytes] = None  # None: no TLS
    cert_pem: Optional[bytes] = None
    key_pem: Optional[bytes] = None
    api_key: Optional[str] = None

    @property
    def tls(self) -> bool:
        return self.ca_pem is not None

    def __repr__(self) -> str:  # never show the secrets
        return (f"Connection(server={self.server!r}, profile={self.profile!r}"
                f", tls={self.tls}, client_cert={self.cert_pem is not None}, "
                f"api_key={'set' if self.api_key else 'unset'})")


def profile_path(env: Mapping[str, str]) -> Path:
    """The profile file the CLI reads."""
    if env.get("HDRSTEREO_CLIENT_CONFIG"):
        return Path(env["HDRSTEREO_CLIENT_CONFIG"])
    return Path(env.get("HOME", "")) / ".config" / "hdrstereo" / "client.toml"


def _read(path: str, what: str) -> bytes:
    try:
        return Path(path).read_bytes()
    except OSError as e:
        raise InvalidArgument(
            f"cannot read {what} {path}: {e.strerror}") from None


def _check_private(path: str, what: str) -> None:
    try:
        mode = os.stat(path).st_mode
    except OSError as e:
        raise InvalidArgument(
            f"cannot read {what} {path}: {e.strerror}") from None
    if mode & (stat.S_IRGRP | stat.S_IROTH):
        who = "other users" if mode & stat.S_IROTH else "its group"
        raise InvalidArgument(
            f"{what} {path} is readable by {who} (mode "
            f"{stat.S_IMODE(mode):04o}); make it yours alone: chmod 600 {path}")


def _load_profiles(path: Path) -> tuple[str, dict[str, dict[str, str]]]:
    try:
        data = tomllib.loads(_read(str(path), "profile file").decode())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise InvalidArgument(f"{path}: {e}") from None
    default = ""
    profiles: dict[str, dict[str, str]] = {}
    for key, value in data.items():
        if key == "default_profile" and isinstance(value, str):
            default = value
        elif key == "profile" and isinstance(value, dict):
            for name, fields in value.items():
                if not isinstance(fields, dict):
                    raise InvalidArgument(
                        f"{path}: [profile.{name}] must be a section")
                for field, v in fields.items():
                    if field not in _PROFILE_KEYS:
                        raise InvalidArgument(
                            f"{path}: unknown key \"{field}\" in "
                            f"[profile.{name}]; known: "
                            + ", ".join(_PROFILE_KEYS))
                    if not isinstance(v, str):
                        raise InvalidArgument(
                            f"{path}: {field} in [profile.{name}] must be a "
                            "\"quoted string\"")
                profiles[name] = dict(fields)
        else:
            raise InvalidArgument(
                f"{path}: unknown key \"{key}\" (the top level knows "
                "default_profile; settings go in a [profile.NAME] section)")
    if default and default not in profiles:
        raise InvalidArgument(f"{path}: default_profile \"{default}\" has no "
                              f"[profile.{default}] section")
    return default, profiles


def resolve(server: Optional[str] = None,
            profile: Optional[str] = None,
            tls_ca: Optional[str] = None,
            tls_cert: Optional[str] = None,
            tls_key: Optional[str] = None,
            api_key: Optional[str] = None,
            api_key_file: Optional[str] = None,
            env: Optional[Mapping[str, str]] = None) -> Connection:
    """Resolves the connection: argument > environment > profile > default.

    Raises InvalidArgument (before any call) for an unknown profile, a bad
    profile file, a certificate without its key, credentials without TLS, a
    private key or key file other users can read, or a key file that does
    not hold one key.
    """
    env = os.environ if env is None else env
    path = profile_path(env)
    wanted = profile or env.get("HDRSTEREO_PROFILE", "")
    chosen: dict[str, str] = {}
    used_profile = ""
    if path.exists():
        default, profiles = _load_profiles(path)
        wanted = wanted or default
        if wanted:
            if wanted not in profiles:
                names = ", ".join(sorted(profiles))
                raise InvalidArgument(
                    f"no profile \"{wanted}\" in {path}"
                    + (f"; it has: {names}" if names else ""))
            chosen = dict(profiles[wanted])
            # Paths in the file are relative to its folder.
            for key in ("tls_ca", "tls_cert", "tls_key", "api_key_file"):
                if chosen.get(key) and not os.path.isabs(chosen[key]):
                    chosen[key] = str(path.parent / chosen[key])
            used_profile = wanted
    elif wanted:
        raise InvalidArgument(
            f"profile \"{wanted}\" asked for, but there is no {path} (set "
            "HDRSTEREO_CLIENT_CONFIG to use another file)")

    def pick(arg: Optional[str], variable: str, key: str) -> str:
        return arg or env.get(variable, "") or chosen.get(key, "")

    address = pick(server, "HDRSTEREO_SERVER", "server") or DEFAULT_SERVER
    ca = pick(tls_ca, "HDRSTEREO_TLS_CA", "tls_ca")
    cert = pick(tls_cert, "HDRSTEREO_TLS_CERT", "tls_cert")
    key = pick(tls_key, "HDRSTEREO_TLS_KEY", "tls_key")
    key_file = "" if api_key else pick(api_key_file, "HDRSTEREO_API_KEY_FILE",
                                       "api_key_file")
    if bool(cert) != bool(key):
        raise InvalidArgument(
            "tls_cert and tls_key go together (a client certificate and its "
            "private key)")
    if not ca:
        if cert or key_file or api_key:
            raise InvalidArgument(
                ("a client certificate" if cert else "an API key") +
                " is only sent over TLS: give tls_ca (the lab CA's "
                "certificate) too, or a profile that has tls_ca")
        return Connection(server=address, profile=used_profile)
    cert_pem = key_pem = None
    if cert:
        cert_pem = _read(cert, "tls_cert")
        _check_private(key, "tls_key")
        key_pem = _read(key, "tls_key")
    if key_file:
        _check_private(key_file, "api_key_file")
        api_key = _read(key_file, "api_key_file").decode(errors="replace")
        api_key = api_key.strip()
        where = f"api_key_file {key_file}"
    else:
        where = "api_key"
    if api_key is not None and (not api_key.startswith("hs_") or
                                any(c in api_key for c in " \t\r\n")):
        raise InvalidArgument(
            f"{where} does not hold one API key (hs_<id>_<secret>, as "
            "`hdrstereo admin key create` printed it)")
    return Connection(server=address, profile=used_profile,
                      ca_pem=_read(ca, "tls_ca"), cert_pem=cert_pem,
                      key_pem=key_pem, api_key=api_key or None)
