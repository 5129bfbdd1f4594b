#!/usr/bin/env bash
# Installs every Debian package hdrstereo needs to build, test and run.
# Idempotent: packages already present are skipped; apt-get update runs once,
# only when something is missing. Works as root or through sudo.
set -euo pipefail

packages=(
  # build tools; clang parses the daemon for its thread-safety analysis
  # (deploy/check-thread-safety.sh)
  build-essential cmake ninja-build ccache pkg-config git clang-format clang
  # the fuzz targets (tests/fuzz): clang's libFuzzer and sanitizer runtimes
  libclang-rt-14-dev
  # wire contract
  libgrpc++-dev libgrpc-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libabsl-dev libssl-dev
  # certificates for remote operation (deploy/make-certs.sh, its tests)
  openssl
  # hardware
  libgphoto2-dev libserialport-dev libx11-dev libxrandr-dev
  # an independent PTP client: tests check the simulated PTP/IP camera with it
  gphoto2
  # processing
  libopencv-dev libopencv-contrib-dev libraw-dev libtiff-dev libopenexr-dev
  libmaxflow-dev zlib1g-dev
  # daemon and tools
  libsqlite3-dev sqlite3 libspdlog-dev libfmt-dev libcli11-dev nlohmann-json3-dev
  # Slurm processing backend: client tools; the tests' single-node cluster
  slurm-wlm munge
  # HTTP edge (daemon/http): Boost.Beast, header-only in libboost-dev
  libboost-dev
  # the README's curl walkthrough (tests/integration/readme_http_walkthrough.sh
  # runs it as printed): curl, and jq to read the JSON answers
  curl jq
  # metrics endpoint; libcurl sends webhooks (and scrapes metrics in tests);
  # civetweb is the tests' webhook receiver
  prometheus-cpp-dev libcurl4-openssl-dev libcivetweb-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev xvfb x11-apps
  # report test: headless browser
  chromium
  # Python client (clients/python) and its tests, notebook included
  python3 python3-grpcio python3-protobuf python3-numpy python3-opencv
  python3-tqdm python3-pytest python3-nbclient python3-nbformat
  python3-ipykernel python3-matplotlib python3-pip python3-setuptools
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed$'; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "setup-deps: all ${#packages[@]} packages present"
else
  sudo_cmd=()
  if [[ $(id -u) -ne 0 ]]; then
    command -v sudo >/dev/null || { echo "setup-deps: need root or sudo" >&2; exit 1; }
    sudo_cmd=(sudo)
  fi

  echo "setup-deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -q
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# The operator's console (clients/web) and its browser tests (tests/web) are
# built with Node.js 20 or later and npm: NodeSource's nodejs package
# (deb.nodesource.com, node_20.x; it includes npm), which the lab machines
# have. Checked here, not installed: Debian 12's own nodejs is 18, too old,
# and must not replace it. HDRSTEREO_WEB=OFF (a build without the console,
# cmake -DHDRSTEREO_WEB=OFF) skips the check.
if [[ "${HDRSTEREO_WEB:-ON}" != OFF ]]; then
  node_help="install NodeSource's nodejs 20.x package (https://deb.nodesource.com, node_20.x; it includes npm), not Debian 12's nodejs 18, or build without the console (cmake -DHDRSTEREO_WEB=OFF, and HDRSTEREO_WEB=OFF for this script)"
  for tool in node npm; do
    if ! command -v "$tool" >/dev/null; then
      echo "setup-deps: $tool is missing: the console (clients/web) needs Node.js 20 or later and npm; $node_help" >&2
      exit 1
    fi
  done
  node_major=$(node -p 'process.versions.node.split(".")[0]' 2>/dev/null || true)
  if ! [[ "$node_major" =~ ^[0-9]+$ ]] || ((node_major < 20)); then
    echo "setup-deps: node is $(node --version 2>&1 || true) at $(command -v node): the console (clients/web) needs Node.js 20 or later; $node_help" >&2
    exit 1
  fi
  echo "setup-deps: node $(node --version) and npm $(npm --version) present"
fi
