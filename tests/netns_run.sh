#!/bin/sh
# Runs a command inside a private network namespace that holds only loopback, with the
# addresses the capture tests' fake GigE Vision cameras bind to (127.0.0.2, 127.0.0.3). GigE
# Vision discovery broadcasts on every interface it finds: inside the namespace no packet can
# leave loopback. Needs root (unshare -n); a failure to set up the namespace fails the test.
set -e
if [ "$#" -eq 0 ]; then
  echo "usage: netns_run.sh COMMAND [ARGS...]" >&2
  exit 2
fi
exec unshare -n sh -c '
  set -e
  ip link set lo up
  ip addr add 127.0.0.2/8 dev lo
  ip addr add 127.0.0.3/8 dev lo
  ip addr add 127.0.0.4/8 dev lo
  export FRINGE_NETNS=1
  exec "$@"' netns_run "$@"
