#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
#
# Makes the certificates remote operation needs, with the openssl CLI only:
# a lab CA, the daemon's server certificate, one client certificate per
# user, revocations and the CA's revocation list (CRL). Everything lives in
# one folder (the CA's key never needs to leave it):
#
#   DIR/ca.pem ca.key       the lab CA (ca.key: 0600, keep it offline)
#   DIR/server.pem .key     hdrstereod's certificate (key 0640)
#   DIR/USER.pem USER.key   a client certificate (key 0600) for USER
#   DIR/USER.p12            the same, with the CA, for a browser (0600)
#   DIR/crl/<hash>.r0       the CA's CRL, as hdrstereod --tls-crl-dir reads it
#
# Usage: deploy/make-certs.sh DIR ca [--days N]
#        deploy/make-certs.sh DIR server NAME_OR_IP... [--days N]
#        deploy/make-certs.sh DIR client USER [--days N]
#                                 [--start YYYYMMDDHHMMSSZ --end YYYYMMDDHHMMSSZ]
#        deploy/make-certs.sh DIR revoke USER
#        deploy/make-certs.sh DIR p12 USER
#
# `server` takes the host names and IP addresses clients use to reach the
# daemon (they become its subjectAltNames), e.g. labpc labpc.example.org
# 192.168.1.20 127.0.0.1; the one certificate serves gRPC and the HTTP edge
# (--http-listen), so name every host browsers use too. A client
# certificate names its user twice: SAN URI hdrstereo://user/USER and
# CN=USER; hdrstereod gives the role from its [auth.users], not from the
# certificate. --start/--end set explicit
# validity dates (tests use them for expired and not-yet-valid ones).
# `revoke` marks USER's certificate revoked and renews the CRL; restart
# hdrstereod to load it. `p12` packs USER's certificate, key and the lab CA
# into DIR/USER.p12 (PKCS#12) for importing into a browser, to sign in to
# the HTTP edge with the certificate; its password comes from the variable
# HDRSTEREO_P12_PASSWORD, else openssl asks for it (there is no default).
set -euo pipefail

usage() { sed -n '4,34p' "$0" >&2; exit 2; }
[[ $# -ge 2 ]] || usage
dir=$(realpath -m "$1")
what=$2
shift 2
umask 077
log=$(mktemp)
trap 'rm -f "$log"' EXIT

days=825
start=""
end=""
args=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --days) days=$2; shift 2 ;;
    --start) start=$2; shift 2 ;;
    --end) end=$2; shift 2 ;;
    -h|--help) usage ;;
    *) args+=("$1"); shift ;;
  esac
done

cnf="$dir/ca.cnf"
need_ca() {
  [[ -f "$dir/ca.pem" && -f "$dir/ca.key" && -f "$cnf" ]] || {
    echo "make-certs.sh: no CA in $dir; run: $0 $dir ca" >&2; exit 1; }
}

# The CRL, named by the hash of its issuer as OpenSSL's CRL lookup expects.
renew_crl() {
  mkdir -p "$dir/crl"
  openssl ca -config "$cnf" -gencrl -crldays 3650 -out "$dir/crl.pem" \
    2>"$log" || { cat "$log" >&2; exit 1; }
  rm -f "$dir"/crl/*.r0
  cp "$dir/crl.pem" "$dir/crl/$(openssl crl -hash -noout -in "$dir/crl.pem").r0"
  chmod 0644 "$dir/crl.pem" "$dir"/crl/*.r0
  chmod 0755 "$dir/crl"
}

# Signs DIR/NAME.csr with the CA into DIR/NAME.pem, with extensions EXT.
sign() {
  local name=$1 ext=$2
  local dates=(-days "$days")
  if [[ -n "$start" || -n "$end" ]]; then
    [[ -n "$start" && -n "$end" ]] || {
      echo "make-certs.sh: --start and --end go together" >&2; exit 2; }
    dates=(-startdate "$start" -enddate "$end")
  fi
  printf '%s\n' "$ext" > "$dir/$name.ext"
  openssl ca -config "$cnf" -batch -notext "${dates[@]}" \
    -extfile "$dir/$name.ext" -in "$dir/$name.csr" -out "$dir/$name.pem" \
    2>"$log" || { cat "$log" >&2; exit 1; }
  rm -f "$dir/$name.csr" "$dir/$name.ext"
  chmod 0644 "$dir/$name.pem"
}

new_key_and_csr() {
  local name=$1 cn=$2
  openssl req -new -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes \
    -keyout "$dir/$name.key" -out "$dir/$name.csr" -subj "/CN=$cn" \
    2>"$log" || { cat "$log" >&2; exit 1; }
}

case "$what" in
  ca)
    mkdir -p "$dir"
    chmod 0755 "$dir"
    [[ ! -e "$dir/ca.key" ]] || {
      echo "make-certs.sh: $dir already has a CA (ca.key); not replacing it" >&2
      exit 1; }
    mkdir -p "$dir/db"
    : > "$dir/db/index.txt"
    openssl rand -hex 16 > "$dir/db/serial"
    cat > "$cnf" <<CNF
[ca]
default_ca = lab
[lab]
dir = $dir
database = \$dir/db/index.txt
serial = \$dir/db/serial
new_certs_dir = \$dir/db
certificate = \$dir/ca.pem
private_key = \$dir/ca.key
default_md = sha256
policy = any
unique_subject = no
copy_extensions = none
default_crl_days = 3650
[any]
commonName = supplied
CNF
    openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes \
      -keyout "$dir/ca.key" -out "$dir/ca.pem" -days "$((days * 4))" \
      -subj "/CN=hdrstereo lab CA ($(hostname))" \
      -addext "basicConstraints=critical,CA:TRUE" \
      -addext "keyUsage=critical,keyCertSign,cRLSign" \
      2>"$log" || { cat "$log" >&2; exit 1; }
    chmod 0600 "$dir/ca.key"
    chmod 0644 "$dir/ca.pem"
    renew_crl
    echo "lab CA: $dir/ca.pem (key $dir/ca.key: keep it private)"
    ;;
  server)
    need_ca
    [[ ${#args[@]} -ge 1 ]] || usage
    sans=()
    for name in "${args[@]}"; do
      if [[ $name =~ ^[0-9.]+$ || $name == *:* ]]; then
        sans+=("IP:$name")
      else
        sans+=("DNS:$name")
      fi
    done
    new_key_and_csr server "${args[0]}"
    sign server "$(printf '%s\n' \
      "subjectAltName=$(IFS=,; echo "${sans[*]}")" \
      "extendedKeyUsage=serverAuth" \
      "keyUsage=critical,digitalSignature,keyEncipherment" \
      "basicConstraints=critical,CA:FALSE")"
    chmod 0640 "$dir/server.key"
    echo "server certificate: $dir/server.pem for ${args[*]}" \
         "(key $dir/server.key)"
    ;;
  client)
    need_ca
    [[ ${#args[@]} -eq 1 ]] || usage
    user=${args[0]}
    [[ $user =~ ^[A-Za-z0-9._@-]{1,64}$ ]] || {
      echo "make-certs.sh: \"$user\" is not a user name (letters, digits," \
           "'.', '_', '@', '-')" >&2; exit 2; }
    new_key_and_csr "$user" "$user"
    sign "$user" "$(printf '%s\n' \
      "subjectAltName=URI:hdrstereo://user/$user" \
      "extendedKeyUsage=clientAuth" \
      "keyUsage=critical,digitalSignature" \
      "basicConstraints=critical,CA:FALSE")"
    chmod 0600 "$dir/$user.key"
    echo "client certificate: $dir/$user.pem (key $dir/$user.key, 0600)" \
         "for user $user"
    ;;
  revoke)
    need_ca
    [[ ${#args[@]} -eq 1 && -f "$dir/${args[0]}.pem" ]] || {
      echo "make-certs.sh: no certificate $dir/${args[*]}.pem" >&2; exit 2; }
    openssl ca -config "$cnf" -revoke "$dir/${args[0]}.pem" \
      2>"$log" || { cat "$log" >&2; exit 1; }
    renew_crl
    echo "revoked $dir/${args[0]}.pem; CRL renewed in $dir/crl (restart" \
         "hdrstereod to load it)"
    ;;
  p12)
    need_ca
    [[ ${#args[@]} -eq 1 ]] || usage
    user=${args[0]}
    [[ -f "$dir/$user.pem" && -f "$dir/$user.key" ]] || {
      echo "make-certs.sh: no certificate $dir/$user.pem and .key" \
           "(make it with: $0 $dir client $user)" >&2; exit 2; }
    passout=()
    if [[ -n "${HDRSTEREO_P12_PASSWORD+set}" ]]; then
      [[ -n "$HDRSTEREO_P12_PASSWORD" ]] || {
        echo "make-certs.sh: HDRSTEREO_P12_PASSWORD is empty" >&2; exit 2; }
      passout=(-passout env:HDRSTEREO_P12_PASSWORD)
    fi
    # No 2>"$log" here: openssl's password prompt goes to the terminal.
    openssl pkcs12 -export -in "$dir/$user.pem" -inkey "$dir/$user.key" \
      -certfile "$dir/ca.pem" -name "hdrstereo $user" \
      -out "$dir/$user.p12" "${passout[@]}"
    chmod 0600 "$dir/$user.p12"
    echo "browser certificate: $dir/$user.p12 (0600) for user $user; import" \
         "it, and $dir/ca.pem as a trusted authority, into the browser"
    ;;
  *) usage ;;
esac
